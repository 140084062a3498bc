//! Each hidden effect changes what it should; cases are reproducible from their seed.
mod common;

use lumped::effects::{case_with, CaseOptions, Effect};
use lumped::excitation::{Hammer, Hit};
use lumped::measure::{impact_clean, Setup};
use lumped::structure::{Machine, CENTRE};
use lumped::Response;
use std::f64::consts::PI;

fn short(clean: bool) -> CaseOptions {
    let mut o = CaseOptions {
        impact_s: 0.8,
        hits: 2,
        milling_s: 0.6,
        ..CaseOptions::default()
    };
    if clean {
        o.impact = Setup::clean(Response::Displacement);
        o.milling = Setup::clean(Response::Displacement);
    }
    o
}

fn detail(c: &lumped::effects::Case, key: &str) -> f64 {
    c.answer["details"][key].as_f64().unwrap_or(f64::NAN)
}

#[test]
fn cases_are_reproducible_from_their_seed() {
    let base = Machine::nominal();
    for e in [Effect::TimeDelay, Effect::ModeChange, Effect::Healthy] {
        let a = case_with(&base, e, 11, &short(false));
        let b = case_with(&base, e, 11, &short(false));
        assert_eq!(a.answer, b.answer);
        assert_eq!(a.machine, b.machine);
        for ((na, ra), (nb, rb)) in a.records.iter().zip(&b.records) {
            assert_eq!(na, nb);
            assert_eq!(ra.to_csv(), rb.to_csv());
        }
        assert_eq!(a.answer["cause"], e.cause());
    }
    let c = case_with(&base, Effect::ModeChange, 12, &short(false));
    let a = case_with(&base, Effect::ModeChange, 11, &short(false));
    assert_ne!(a.records[0].1.to_csv(), c.records[0].1.to_csv());
}

#[test]
fn healthy_changes_nothing() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::Healthy, 3, &short(false));
    assert_eq!(c.machine, base);
    assert_eq!(c.answer["cause"], "none");
    assert_eq!(c.records.len(), 2);
}

#[test]
fn mode_change_moves_the_named_mode() {
    let base = Machine::nominal();
    for seed in 0..4 {
        let c = case_with(&base, Effect::ModeChange, seed, &short(false));
        let (f0, f1) = (detail(&c, "freq_hz"), detail(&c, "new_freq_hz"));
        let (z0, z1) = (detail(&c, "damping"), detail(&c, "new_damping"));
        assert!(
            (f1 / f0 - 1.0).abs() >= 0.03 || (z1 / z0 - 1.0).abs() >= 0.4,
            "{}",
            c.answer
        );
        // the modified machine really has a mode there
        let m = c.machine.modes(CENTRE);
        assert!(m
            .iter()
            .any(|x| (x.freq_hz - f1).abs() < 0.01 && (x.zeta - z1).abs() < 1e-4));
    }
}

#[test]
fn unmodeled_mode_adds_a_resonance() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::UnmodeledMode, 5, &short(false));
    let f = detail(&c, "freq_hz");
    assert_eq!(c.machine.modes(CENTRE).len(), base.modes(CENTRE).len() + 3);
    let a = ["x", "y", "z"]
        .iter()
        .position(|s| c.answer["details"]["axis"] == *s)
        .unwrap_or(0);
    let h0 = base.analytic_frf(CENTRE, &[f]).h[0][(a, a)];
    let h1 = c.machine.analytic_frf(CENTRE, &[f]).h[0][(a, a)];
    assert!(
        (h1 - h0).norm() > 0.1 * h0.norm(),
        "{} vs {}",
        h1.norm(),
        h0.norm()
    );
}

#[test]
fn cross_coupling_opens_a_cross_channel() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::CrossCoupling, 2, &short(false));
    let old = detail(&c, "old_peak_m_per_n");
    let new = detail(&c, "new_peak_m_per_n");
    assert!(
        new > 10.0 * old.max(1e-12) || new > 3.0 * old,
        "{}",
        c.answer
    );
    let ch = c.answer["details"]["channel"].as_str().unwrap_or("");
    assert!(["yx", "zx", "zy"].contains(&ch));
}

#[test]
fn pose_dependence_is_stronger_than_nominal() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::PoseDependence, 4, &short(false));
    let r = detail(&c, "freq_shift_pct_per_m");
    let r0 = detail(&c, "nominal_shift_pct_per_m");
    assert!((r - r0).abs() > 5.0, "{}", c.answer);
    assert_eq!(c.records.len(), 4);
}

/// Delay from the phase slope of the full-record ratio against the analytic truth.
#[test]
fn time_delay_is_the_stated_number_of_samples() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::TimeDelay, 6, &short(true));
    let tau = detail(&c, "delay_s");
    let r = &c.records[0].1;
    let fx = common::dft(&r.force[0]);
    let dx = common::dft(&r.response[0]);
    let df = r.fs / r.len() as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    // up to 800 Hz the phase of a 6-sample delay stays within ±π (no unwrapping needed)
    for k in (1..r.len() / 2).filter(|&k| (100.0..800.0).contains(&(k as f64 * df))) {
        let f = k as f64 * df;
        let h = base.analytic_frf(CENTRE, &[f]).h[0][(0, 0)];
        let ph = (dx[k] / fx[k] / h).arg();
        let w = 2.0 * PI * f;
        sxy += w * ph;
        sxx += w * w;
    }
    let est = -sxy / sxx;
    assert!(
        (est - tau).abs() < 0.1 / r.fs,
        "estimated {est}, stated {tau}"
    );
}

#[test]
fn cubic_spring_matters_only_at_high_force() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::Nonlinearity, 1, &short(false));
    assert!(c.machine.cubic.is_some());
    let setup = Setup::clean(Response::Displacement);
    let hammer = Hammer::plastic();
    let axis = if c.answer["details"]["axis"] == "y" {
        1
    } else {
        0
    };
    let rel_diff = |peak: f64| {
        let hits = [Hit { t: 0.01, peak }];
        let lin = impact_clean(&base, &setup, CENTRE, axis, &hammer, &hits, 0.3);
        let nl = impact_clean(&c.machine, &setup, CENTRE, axis, &hammer, &hits, 0.3);
        let d: f64 = lin.response[axis]
            .iter()
            .zip(&nl.response[axis])
            .map(|(a, b)| (a - b).powi(2))
            .sum();
        let n: f64 = lin.response[axis].iter().map(|a| a * a).sum();
        (d / n).sqrt()
    };
    let low = rel_diff(60.0);
    let high = rel_diff(1200.0);
    assert!(
        low < 0.01 && high > 0.03 && high > 10.0 * low,
        "low {low}, high {high}"
    );
}

/// The cubic joint spring is drawn by what it does: the mode it moves most moves by at
/// least 1 % between a 60 N and a 1200 N hit (noise-free). Drawn by its strength alone,
/// the table screw's spring moved its 72.9 Hz mode by 0.17-0.21 % at seeds 1 and 9 (an
/// effect below the scatter of a linear machine's frequencies between hits); now a joint
/// that cannot reach 1 % gives way to another.
#[test]
fn cubic_spring_moves_its_named_mode_by_at_least_a_percent() {
    let base = Machine::nominal();
    for seed in [1, 9] {
        let c = case_with(&base, Effect::Nonlinearity, seed, &short(false));
        let d = &c.answer["details"];
        let shift = d["freq_shift_pct"].as_f64().unwrap_or(0.0);
        assert!(shift.abs() >= 1.0, "seed {seed}: {d}");
        assert_ne!(d["joint"], "table_screw", "seed {seed}: {d}");
    }
}

#[test]
fn disturbance_lines_show_in_the_milling_response() {
    let base = Machine::nominal();
    let c = case_with(&base, Effect::Disturbance, 8, &short(true));
    let fd: Vec<f64> = c.answer["details"]["freq_hz"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_f64()).collect())
        .unwrap_or_default();
    assert!(!fd.is_empty());
    let r = &c.records[0].1;
    let spec: Vec<f64> = (0..3)
        .map(|d| common::dft(&r.response[d]))
        .fold(vec![0.0; r.len()], |acc, s| {
            acc.iter().zip(&s).map(|(a, b)| a + b.norm()).collect()
        });
    let df = r.fs / r.len() as f64;
    for f in fd {
        let k = (f / df).round() as usize;
        let line = spec[k - 1..=k + 1].iter().cloned().fold(0.0, f64::max);
        let mut around: Vec<f64> = (k.saturating_sub(40)..k + 40)
            .filter(|&j| j + 3 < k || j > k + 3)
            .map(|j| spec[j])
            .collect();
        around.sort_by(f64::total_cmp);
        let median = around[around.len() / 2];
        assert!(
            line > 5.0 * median,
            "{f} Hz: line {line:.3e}, median {median:.3e}"
        );
    }
}

/// The effects recorded in milling are the same drawn effects as in the impact tests
/// (same answer, same changed machine), recorded as milling cuts; the milled delay
/// is stated at the milling sample rate (the delay itself is `Clean::delayed`, as in
/// the impact case: `time_delay_is_the_stated_number_of_samples`).
#[test]
fn milled_effects_are_the_impact_effects_in_milling_records() {
    let base = Machine::nominal();
    for e in Effect::MILLED {
        let imp = case_with(&base, e, 4, &short(false));
        let mill = case_with(
            &base,
            e,
            4,
            &CaseOptions {
                milling_data: true,
                ..short(false)
            },
        );
        assert_eq!(imp.machine, mill.machine, "{e:?}");
        assert_eq!(imp.answer["cause"], mill.answer["cause"], "{e:?}");
        assert!(
            mill.records.iter().all(|(n, _)| n.starts_with("mill_")),
            "{e:?}: {:?}",
            mill.records.iter().map(|r| &r.0).collect::<Vec<_>>()
        );
        assert!(imp.records.iter().all(|(n, _)| n.starts_with("imp_")));
        if e == Effect::TimeDelay {
            let k = detail(&mill, "delay_samples");
            let fs = mill.records[0].1.fs;
            assert!((detail(&mill, "delay_s") - k / fs).abs() < 1e-12);
        } else {
            // the milling answer adds how much the effect shows in the cuts
            let mut m = mill.answer.clone();
            let d = m["details"].as_object_mut().expect("details");
            // (a damping change leaves the mean deflection as it was)
            for (key, least) in [
                ("milling_response_change", f64::MIN_POSITIVE),
                ("milling_static_change", 0.0),
            ] {
                let v = d.remove(key).and_then(|v| v.as_f64());
                assert!(
                    v.is_some_and(|v| v >= least && v.is_finite()),
                    "{e:?} {key}: {v:?}"
                );
            }
            assert_eq!(imp.answer, m, "{e:?}");
        }
    }
}
