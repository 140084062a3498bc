//! Diagnose finds an effect hidden in generated MILLING data (virtual machine,
//! `vmachine::hidden::milling_case`): the twin is identified from impact tests, then
//! milling records (mechanistic cutting force at three spindle speeds plus a broadband
//! share, forces and responses along x and y) hide one effect whose parameters are drawn
//! from a seed. A fixed handful of seeds, one or two per effect; the confusion table over
//! many seeds is `cargo run --release --example diagnose_confusion -- 20 milling`.

use identify::diagnose::{diagnose, Cause, DiagnoseOptions, Diagnosis};
use identify::twin::Twin;
use serde_json::Value;
use std::sync::OnceLock;
use vmachine::daq::Daq;
use vmachine::hidden::{milling_case, Case, Effect, AXES};
use vmachine::structure::ModalMachine;

use crate::common::hidden_base;

// seeds of the confusion table's milling run (seeds 100…119 per effect) whose cases
// cover both directions where the generator draws one (hardening and softening)
const SEED_NONE_A: u64 = 100;
const SEED_NONE_B: u64 = 101;
const SEED_MODE_CHANGE: u64 = 101;
const SEED_UNMODELED: u64 = 100;
const SEED_DELAY: u64 = 102;
const SEED_DISTURBANCE: u64 = 103;
const SEED_CROSS: u64 = 100;
const SEED_POSE: u64 = 101;
const SEED_NONLINEAR_A: u64 = 100;
const SEED_NONLINEAR_B: u64 = 106;

fn base() -> &'static Twin {
    static BASE: OnceLock<Twin> = OnceLock::new();
    BASE.get_or_init(|| hidden_base::base_twin(&ModalMachine::default_machine(), &AXES))
}

fn run(effect: Effect, seed: u64) -> (Case, Diagnosis, Twin) {
    let c = milling_case(effect, seed, base());
    let (d, ext) = diagnose(&c.twin, &c.records, &DiagnoseOptions::default()).unwrap();
    eprintln!(
        "seed {seed} {effect:?} (truth {}) -> {:?}: {} {}",
        Value::Object(c.truth.clone()),
        d.cause,
        d.summary,
        Value::Object(d.details.clone())
    );
    assert!(ext.validate(std::path::Path::new("ext")).is_ok());
    (c, d, ext)
}

fn num(m: &serde_json::Map<String, Value>, k: &str) -> f64 {
    m.get(k)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("{k} missing in {m:?}"))
}

fn assert_close(k: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs(),
        "{k}: {got} vs {want} (tolerance {:.1} %)",
        100.0 * rel
    );
}

/// The diagnosis reports `k` within `rel` of the hidden truth's `k`.
fn assert_same(d: &Diagnosis, c: &Case, k: &str, rel: f64) {
    assert_close(k, num(&d.details, k), num(&c.truth, k), rel);
}

fn assert_gain(d: &Diagnosis) {
    assert!(
        d.fit_after_pct > d.fit_before_pct,
        "no held-out gain: {:.2} % -> {:.2} %",
        d.fit_before_pct,
        d.fit_after_pct
    );
}

#[test]
fn milling_none_stays_none_and_modes_are_found_with_their_numbers() {
    for seed in [SEED_NONE_A, SEED_NONE_B] {
        let (_, d, _) = run(Effect::None, seed);
        assert_eq!(d.cause, Cause::None, "{}", d.summary);
    }
    // a worn mode (which one, how much: from the seed)
    let (c, d, _) = run(Effect::ModeChange, SEED_MODE_CHANGE);
    assert_eq!(d.cause, Cause::ModeChange, "{}", d.summary);
    assert_same(&d, &c, "freq_hz", 0.01);
    assert_same(&d, &c, "new_freq_hz", 0.01);
    assert_same(&d, &c, "new_damping", 0.3);
    assert_gain(&d);
    // a new mode in the band the cut excites
    let (c, d, ext) = run(Effect::UnmodeledMode, SEED_UNMODELED);
    assert_eq!(d.cause, Cause::UnmodeledMode, "{}", d.summary);
    assert_same(&d, &c, "freq_hz", 0.01);
    assert_same(&d, &c, "damping", 0.3);
    assert_eq!(
        ext.poses[0].model.modes.len(),
        c.twin.poses[0].model.modes.len() + 1
    );
    assert_gain(&d);
}

#[test]
fn milling_delay_disturbance_and_cross_coupling_are_found_with_their_numbers() {
    let dt = 1.0 / Daq::default().fs;
    let (c, d, _) = run(Effect::TimeDelay, SEED_DELAY);
    assert_eq!(d.cause, Cause::TimeDelay, "{}", d.summary);
    let (got, want) = (num(&d.details, "delay_s"), num(&c.truth, "delay_s"));
    assert!((got - want).abs() < 0.25 * dt, "{got} s vs {want} s");
    assert_gain(&d);
    // a vibration from outside, away from every spindle harmonic
    let (c, d, _) = run(Effect::Disturbance, SEED_DISTURBANCE);
    assert_eq!(d.cause, Cause::Disturbance, "{}", d.summary);
    let want = c.truth["freq_hz"][0].as_f64().unwrap();
    let found: Vec<f64> = serde_json::from_value(d.details["freq_hz"].clone()).unwrap();
    assert!(
        found.iter().any(|g| (g - want).abs() < 0.005 * want),
        "{found:?} vs {want}"
    );
    assert_gain(&d);
    // the twin lacks xy and yx; milling forces x and y at once, so both are missing
    let (_, d, ext) = run(Effect::CrossCoupling, SEED_CROSS);
    assert_eq!(d.cause, Cause::CrossCoupling, "{}", d.summary);
    let ch = d.details["channel"].as_str().unwrap();
    assert!(ch == "xy" || ch == "yx", "{ch}");
    assert!(["xy", "yx"]
        .iter()
        .all(|n| ext.channels.iter().any(|c| c.name() == *n)));
    assert_gain(&d);
}

#[test]
fn milling_pose_dependence_and_nonlinearity_are_found_with_their_numbers() {
    let (c, d, ext) = run(Effect::PoseDependence, SEED_POSE);
    assert_eq!(d.cause, Cause::PoseDependence, "{}", d.summary);
    assert_eq!(d.details["axis_of_variation"], c.truth["axis_of_variation"]);
    // the true rate of the mode diagnose names
    let k = d.details["mode"].as_u64().unwrap() as usize;
    let want = c.truth["freq_shift_pct_per_m"][k].as_f64().unwrap();
    let got = num(&d.details, "freq_shift_pct_per_m");
    assert!(
        (got - want).abs() < 0.2 * want.abs().max(5.0),
        "mode {k}: {got:.1} %/m vs {want:.1} %/m"
    );
    assert!(ext.poses.len() >= 3);
    assert_gain(&d);
    // a cubic stiffness: light and heavy cuts (1 and 3 mm) see the mode apart
    for seed in [SEED_NONLINEAR_A, SEED_NONLINEAR_B] {
        let (c, d, _) = run(Effect::Nonlinearity, seed);
        assert_eq!(d.cause, Cause::Nonlinearity, "{}", d.summary);
        assert_eq!(d.details["kind"], c.truth["kind"]);
        assert_same(&d, &c, "freq_hz", 0.02);
        // the linearised twin, when it helps; never a loss
        assert!(d.fit_after_pct >= d.fit_before_pct);
    }
}
