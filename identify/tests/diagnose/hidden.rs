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
use vmachine::hidden::{delayed, disturbed};
use vmachine::structure::ModalMachine;

use crate::common::hidden_base;

const AXES: [Axis; 2] = [Axis::X, Axis::Y];
const POSE: [f64; 3] = [0.3, 0.3, 0.2];

fn tests_on(m: &ModalMachine, seed: u64) -> Vec<TimeSeries> {
    AXES.iter()
        .enumerate()
        .map(|(k, a)| impact_record(m, POSE, *a, &AXES, 5, &Daq::default(), seed + k as u64))
        .collect()
}

fn twin(m: &ModalMachine) -> Twin {
    hidden_base::base_twin(m, &AXES)
}

#[test]
fn hidden_effects_are_found_with_their_numbers() {
    // the generator of the confusion table (vmachine::hidden), a fixed handful of seeds
    use vmachine::hidden::{case, Effect};
    let base = hidden_base::base_twins();
    let opts = DiagnoseOptions::default();
    for seed in [11u64, 12] {
        for (effect, cause, key) in [
            (Effect::None, Cause::None, None),
            (Effect::UnmodeledMode, Cause::UnmodeledMode, Some("freq_hz")),
            (Effect::ModeChange, Cause::ModeChange, Some("new_freq_hz")),
        ] {
            let c = case(effect, seed, &base);
            let (d, ext) = diagnose(&c.twin, &c.records, &opts).unwrap();
            eprintln!("seed {seed} {effect:?} -> {:?} {}", d.cause, d.summary);
            assert_eq!(d.cause, cause, "{}", d.summary);
            if let Some(k) = key {
                let (want, got) = (c.truth[k].as_f64().unwrap(), d.details[k].as_f64().unwrap());
                assert!((got - want).abs() < 0.01 * want, "{k}: {got} vs {want}");
                assert!(d.fit_after_pct > d.fit_before_pct);
                assert!(ext.validate(std::path::Path::new("ext")).is_ok());
            }
        }
    }
}

#[test]
fn hidden_delay_and_disturbance_are_found_with_their_numbers() {
    let machine = ModalMachine::default_machine();
    let tw = twin(&machine);
    let opts = DiagnoseOptions::default();
    let dt = 1.0 / Daq::default().fs;
    for seed in [21u64, 22] {
        let mut rng = StdRng::seed_from_u64(seed);
        // a constant delay of 2–5 samples in the response channels (acquisition chain)
        let k = rng.gen_range(2..=5);
        let recs: Vec<TimeSeries> = tests_on(&machine, 400 + seed)
            .into_iter()
            .map(|t| delayed(t, k))
            .collect();
        let (d, _) = diagnose(&tw, &recs, &opts).unwrap();
        eprintln!(
            "seed {seed} delay {k} samples -> {:?} {}",
            d.cause, d.summary
        );
        assert_eq!(d.cause, Cause::TimeDelay, "{}", d.summary);
        let got = d.details["delay_s"].as_f64().unwrap();
        let want = k as f64 * dt;
        assert!((got - want).abs() < 0.1 * want, "{got} s vs {want} s");
        assert!(d.fit_after_pct > d.fit_before_pct + 1.0);
        // a disturbance at a frequency away from the modes, in x
        let f = rng.gen_range(600.0..700.0);
        let recs: Vec<TimeSeries> = tests_on(&machine, 500 + seed)
            .into_iter()
            .map(|t| disturbed(t, Axis::X, f, 0.3))
            .collect();
        let (d, _) = diagnose(&tw, &recs, &opts).unwrap();
        eprintln!(
            "seed {seed} disturbance {f:.1} Hz -> {:?} {}",
            d.cause, d.summary
        );
        assert_eq!(d.cause, Cause::Disturbance, "{}", d.summary);
        let found: Vec<f64> = serde_json::from_value(d.details["freq_hz"].clone()).unwrap();
        assert!(
            found.iter().any(|g| (g - f).abs() < 0.005 * f),
            "{found:?} vs {f}"
        );
        assert!(d.fit_after_pct > d.fit_before_pct);
    }
}

#[test]
fn hidden_cross_coupling_is_found() {
    // the twin knows only x→x (hammer and sensor along x); the new tests also record y
    let machine = ModalMachine::default_machine();
    let opts = CampaignOptions {
        fit: FitOptions {
            band_hz: Some((30.0, 2500.0)),
            ..FitOptions::default()
        },
        ..CampaignOptions::default()
    };
    let xonly = vec![impact_record(
        &machine,
        POSE,
        Axis::X,
        &[Axis::X],
        5,
        &Daq::default(),
        1,
    )];
    let tw = identify_campaign(&xonly, &opts, &|_, _| {}).unwrap().twin;
    let tests = vec![impact_record(
        &machine,
        POSE,
        Axis::X,
        &AXES,
        5,
        &Daq::default(),
        77,
    )];
    let (d, ext) = diagnose(&tw, &tests, &DiagnoseOptions::default()).unwrap();
    eprintln!("cross -> {:?} {}", d.cause, d.summary);
    assert_eq!(d.cause, Cause::CrossCoupling, "{}", d.summary);
    assert_eq!(d.details["channel"], "yx");
    assert!(ext.channels.iter().any(|c| c.name() == "yx"));
    assert!(d.fit_after_pct > d.fit_before_pct);
}

#[test]
fn hidden_pose_dependence_is_found_with_its_axis_and_rate() {
    // the twin was measured at one pose only; new tests at poses along one axis (drawn
    // from the seed) show modes moving with the position (the machine's mode 2, 180 Hz,
    // shifts by -30 %/m along x; mode 1, 95 Hz, by +30 %/m along y)
    let machine = ModalMachine::default_machine();
    let tw = twin(&machine);
    assert_eq!(tw.poses.len(), 1);
    let m = &machine;
    for (seed, axis) in [(31u64, 0usize), (32, 1)] {
        let mut rng = StdRng::seed_from_u64(seed);
        let span = rng.gen_range(0.15..0.25);
        let poses: Vec<[f64; 3]> = [-span, span]
            .iter()
            .map(|d| {
                let mut p = POSE;
                p[axis] += d;
                p
            })
            .collect();
        let recs: Vec<TimeSeries> = poses
            .iter()
            .enumerate()
            .flat_map(|(i, p)| {
                AXES.iter().enumerate().map(move |(k, a)| {
                    impact_record(
                        m,
                        *p,
                        *a,
                        &AXES,
                        5,
                        &Daq::default(),
                        600 + seed * 10 + (2 * i + k) as u64,
                    )
                })
            })
            .collect();
        let (d, ext) = diagnose(&tw, &recs, &DiagnoseOptions::default()).unwrap();
        eprintln!(
            "seed {seed} pose dependence along {axis} ±{span:.2} m -> {:?} {}",
            d.cause, d.summary
        );
        assert_eq!(d.cause, Cause::PoseDependence, "{}", d.summary);
        assert_eq!(d.details["axis_of_variation"], ["x", "y", "z"][axis]);
        // the true rate of the mode diagnose names, at the centre
        let k = d.details["mode"].as_u64().unwrap() as usize;
        let truth = 100.0 * machine.modes[k].grad[axis];
        let got = d.details["freq_shift_pct_per_m"].as_f64().unwrap();
        assert!(
            (got - truth).abs() < 0.2 * truth.abs().max(5.0),
            "mode {k}: {got:.1} %/m vs {truth:.1} %/m"
        );
        assert!(ext.poses.len() >= 3);
        assert!(d.fit_after_pct > d.fit_before_pct);
    }
}

#[test]
fn hidden_nonlinearity_is_found_with_its_kind() {
    // mode 2 (180 Hz) gets a cubic stiffness: hard hits (400 N) shift it by a few per
    // cent, light ones (40 N) hardly; the twin was identified on a linear machine
    let machine = ModalMachine::default_machine();
    let tw = twin(&machine);
    for (seed, sign) in [(41u64, 1.0), (42, -1.0)] {
        let mut rng = StdRng::seed_from_u64(seed);
        let shift = sign * rng.gen_range(0.03..0.05);
        let mut recs =
            vmachine::hidden::duffing_tests_at(&machine, 2, shift, 400.0, 40.0, POSE, &AXES, seed);
        recs.extend(vmachine::hidden::duffing_tests_at(
            &machine,
            2,
            shift,
            400.0,
            400.0,
            POSE,
            &AXES,
            seed + 5,
        ));
        let (d, ext) = diagnose(&tw, &recs, &DiagnoseOptions::default()).unwrap();
        eprintln!(
            "seed {seed} duffing shift {shift:+.3} -> {:?} {} {}",
            d.cause,
            d.summary,
            serde_json::to_string(&d.details).unwrap()
        );
        assert_eq!(d.cause, Cause::Nonlinearity, "{}", d.summary);
        assert_eq!(
            d.details["kind"],
            if sign > 0.0 { "hardening" } else { "softening" }
        );
        let f = d.details["freq_hz"].as_f64().unwrap();
        assert!((f - 180.0).abs() < 0.02 * 180.0, "{f} Hz");
        assert!(ext.validate(std::path::Path::new("ext")).is_ok());
        // the extension: a cubic modal stiffness of the right sign on that mode
        let kappa = d.details["kappa"].as_f64().expect("a cubic term");
        assert_eq!(kappa > 0.0, sign > 0.0, "kappa {kappa}");
        assert_eq!(ext.extensions.cubic.len(), 1);
        assert_eq!(ext.extensions.cubic[0].kappa, kappa);
        // the gain on held-out hits (small: the held-out hits' tails are mostly noise)
        assert!(d.fit_after_pct > d.fit_before_pct);
    }
}
