//! Diagnose finds an effect hidden in generated impact data (virtual machine): the twin is
//! identified from one set of tests, then new tests are generated with one effect — a new
//! mode, a changed mode, or nothing — whose parameters are drawn from a seed.

use identify::axis::Axis;
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::diagnose::{diagnose, Cause, DiagnoseOptions};
use identify::rational_fit::FitOptions;
use identify::timeseries::TimeSeries;
use identify::twin::Twin;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use vmachine::daq::{impact_record, Daq};
use vmachine::structure::{ModalMachine, VMode};

const AXES: [Axis; 2] = [Axis::X, Axis::Y];
const POSE: [f64; 3] = [0.3, 0.3, 0.2];

fn tests_on(m: &ModalMachine, seed: u64) -> Vec<TimeSeries> {
    AXES.iter()
        .enumerate()
        .map(|(k, a)| impact_record(m, POSE, *a, &AXES, 5, &Daq::default(), seed + k as u64))
        .collect()
}

fn twin(m: &ModalMachine) -> Twin {
    let opts = CampaignOptions {
        fit: FitOptions {
            band_hz: Some((30.0, 2500.0)),
            ..FitOptions::default()
        },
        ..CampaignOptions::default()
    };
    identify_campaign(&tests_on(m, 1), &opts, &|_, _| {})
        .unwrap()
        .twin
}

#[test]
fn hidden_effects_are_found_with_their_numbers() {
    let machine = ModalMachine::default_machine();
    let tw = twin(&machine);
    let opts = DiagnoseOptions::default();
    for seed in [11u64, 12] {
        let mut rng = StdRng::seed_from_u64(seed);
        // nothing hidden: no false alarm
        let (d, _) = diagnose(&tw, &tests_on(&machine, 100 + seed), &opts).unwrap();
        eprintln!("seed {seed} none -> {:?} {}", d.cause, d.summary);
        assert_eq!(d.cause, Cause::None, "{}", d.summary);
        // a new mode (tool holder) at a random frequency between the twin's modes
        let f = rng.gen_range(400.0..480.0);
        let zeta = rng.gen_range(0.015..0.03);
        let extra = machine.clone().with_extra_mode(VMode {
            f_hz: f,
            zeta,
            mass: 60.0,
            shape: [0.8, 0.2, 0.0],
            grad: [0.0; 3],
            quad: [0.0; 3],
        });
        let (d, ext) = diagnose(&tw, &tests_on(&extra, 200 + seed), &opts).unwrap();
        eprintln!(
            "seed {seed} unmodeled {f:.1} Hz -> {:?} {}",
            d.cause, d.summary
        );
        assert_eq!(d.cause, Cause::UnmodeledMode, "{}", d.summary);
        let got = d.details["freq_hz"].as_f64().unwrap();
        assert!((got - f).abs() < 0.01 * f, "{got} vs {f}");
        assert!(d.fit_after_pct > d.fit_before_pct);
        assert!(ext.validate(std::path::Path::new("ext")).is_ok());
        // a worn mode: stiffness of mode 4 (330 Hz, x/y) drops 10-20 %
        let factor = rng.gen_range(0.8..0.9);
        let worn = machine.clone().with_stiffness_change(4, factor);
        let f_new = worn.mode_at(4, POSE).freq_hz();
        let (d, _) = diagnose(&tw, &tests_on(&worn, 300 + seed), &opts).unwrap();
        eprintln!(
            "seed {seed} mode change -> {f_new:.1} Hz: {:?} {}",
            d.cause, d.summary
        );
        assert_eq!(d.cause, Cause::ModeChange, "{}", d.summary);
        let got = d.details["new_freq_hz"].as_f64().unwrap();
        assert!((got - f_new).abs() < 0.01 * f_new, "{got} vs {f_new}");
        assert!(d.fit_after_pct > d.fit_before_pct);
    }
}
