//! Test data with one hidden effect, its parameters drawn from a seed: what `mtwin
//! diagnose` must find. Impact tests (hammer along x and y, 5 hits, responses x and y) on
//! [`ModalMachine::default_machine`] at the workspace centre, against a twin identified
//! from clean tests there ([`base_twin`]).
//!
//! | effect | hidden in the data | truth reported |
//! |---|---|---|
//! | `None` | nothing (fresh noise) | — |
//! | `ModeChange` | mode 4 (330 Hz) stiffness −10…−20 % | `new_freq_hz` |
//! | `UnmodeledMode` | a new 400–480 Hz mode along x | `freq_hz` |
//! | `TimeDelay` | responses 2–5 samples late | `delay_s` |
//! | `Disturbance` | a 600–700 Hz sinusoid on x, 30 % of the response RMS | `freq_hz` |
//! | `CrossCoupling` | the twin knows x→x only; the data also record y | `channel` |
//! | `PoseDependence` | the twin has one pose; the data come from two poses ±0.15–0.25 m along x or y | `axis_of_variation`, `freq_shift_pct_per_m` |
//! | `Nonlinearity` | mode 2 (180 Hz) with a cubic stiffness shifting it 3–5 % (±) at 400 N hits; tests at 40 N and 400 N | `kind` |

use crate::daq::{impact_record, Daq};
use crate::structure::{ModalMachine, VMode};
use identify::axis::Axis;
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::rational_fit::FitOptions;
use identify::timeseries::TimeSeries;
use identify::twin::Twin;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The axes hammered and recorded.
pub const AXES: [Axis; 2] = [Axis::X, Axis::Y];

/// The pose of the tests (the workspace centre).
pub const POSE: [f64; 3] = [0.3, 0.3, 0.2];

/// The kinds of hidden effect (the SPEC's causes this generator covers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Nothing hidden.
    None,
    /// A worn mode.
    ModeChange,
    /// A new resonance.
    UnmodeledMode,
    /// A constant delay of the responses.
    TimeDelay,
    /// A vibration from outside.
    Disturbance,
    /// A channel the twin lacks.
    CrossCoupling,
    /// Modes that move with the pose beyond the twin's poses.
    PoseDependence,
    /// A mode with a cubic stiffness (hardening or softening).
    Nonlinearity,
}

impl Effect {
    /// Every effect.
    pub const ALL: [Effect; 8] = [
        Effect::None,
        Effect::ModeChange,
        Effect::UnmodeledMode,
        Effect::TimeDelay,
        Effect::Disturbance,
        Effect::CrossCoupling,
        Effect::PoseDependence,
        Effect::Nonlinearity,
    ];

    /// The SPEC cause code.
    pub fn code(self) -> &'static str {
        match self {
            Effect::None => "none",
            Effect::ModeChange => "mode_change",
            Effect::UnmodeledMode => "unmodeled_mode",
            Effect::TimeDelay => "time_delay",
            Effect::Disturbance => "disturbance",
            Effect::CrossCoupling => "cross_coupling",
            Effect::PoseDependence => "pose_dependence",
            Effect::Nonlinearity => "nonlinearity",
        }
    }
}

/// A generated case.
#[derive(Debug, Clone)]
pub struct Case {
    /// What is hidden.
    pub effect: Effect,
    /// The twin to diagnose.
    pub twin: Twin,
    /// The new test data.
    pub records: Vec<TimeSeries>,
    /// The hidden numbers, as the SPEC's `details` keys (e.g. `new_freq_hz`).
    pub truth: serde_json::Map<String, serde_json::Value>,
}

/// Impact tests at `pose`, hammer along each of `axes`, responses along `out`.
pub fn tests_at(
    m: &ModalMachine,
    pose: [f64; 3],
    axes: &[Axis],
    out: &[Axis],
    seed: u64,
) -> Vec<TimeSeries> {
    axes.iter()
        .enumerate()
        .map(|(k, a)| impact_record(m, pose, *a, out, 5, &Daq::default(), seed + k as u64))
        .collect()
}

/// The twin identified from clean tests at [`POSE`] (30–2500 Hz, automatic order),
/// with channels `axes` × `axes`.
pub fn base_twin(m: &ModalMachine, axes: &[Axis]) -> Twin {
    let opts = CampaignOptions {
        fit: FitOptions {
            band_hz: Some((30.0, 2500.0)),
            ..FitOptions::default()
        },
        ..CampaignOptions::default()
    };
    identify_campaign(&tests_at(m, POSE, axes, axes, 1), &opts, &|_, _| {})
        .expect("identification of the base twin")
        .twin
}

/// Responses delayed by `k` samples (the first `k` samples repeat the first value).
pub fn delayed(mut ts: TimeSeries, k: usize) -> TimeSeries {
    for r in ts.response.iter_mut().flatten() {
        let first = r[0];
        let n = r.len();
        r.rotate_right(k);
        r[..k.min(n)].iter_mut().for_each(|v| *v = first);
    }
    ts
}

/// A sinusoid of `rel` × the response RMS at `f_hz` added to the response along `axis`.
pub fn disturbed(mut ts: TimeSeries, axis: Axis, f_hz: f64, rel: f64) -> TimeSeries {
    let dt = ts.dt;
    if let Some(r) = ts.response[axis.index()].as_mut() {
        let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
        for (i, v) in r.iter_mut().enumerate() {
            *v += rel * rms * (2.0 * std::f64::consts::PI * f_hz * i as f64 * dt).sin();
        }
    }
    ts
}

/// One case of `effect` with parameters from `seed`. `base` is [`base_twin`] of the
/// default machine with channels x, y (passed in so many cases share one identification).
pub fn case(effect: Effect, seed: u64, base: &Twin) -> Case {
    let machine = ModalMachine::default_machine();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut truth = serde_json::Map::new();
    let fresh = 1000 + 10 * seed;
    let (twin, records) = match effect {
        Effect::None => (base.clone(), tests_at(&machine, POSE, &AXES, &AXES, fresh)),
        Effect::ModeChange => {
            let factor = rng.gen_range(0.8..0.9);
            let worn = machine.clone().with_stiffness_change(4, factor);
            truth.insert("new_freq_hz".into(), worn.mode_at(4, POSE).freq_hz().into());
            (base.clone(), tests_at(&worn, POSE, &AXES, &AXES, fresh))
        }
        Effect::UnmodeledMode => {
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
            truth.insert("freq_hz".into(), f.into());
            (base.clone(), tests_at(&extra, POSE, &AXES, &AXES, fresh))
        }
        Effect::TimeDelay => {
            let k = rng.gen_range(2..=5usize);
            truth.insert("delay_s".into(), (k as f64 / Daq::default().fs).into());
            let recs = tests_at(&machine, POSE, &AXES, &AXES, fresh)
                .into_iter()
                .map(|t| delayed(t, k))
                .collect();
            (base.clone(), recs)
        }
        Effect::Disturbance => {
            let f = rng.gen_range(600.0..700.0);
            truth.insert("freq_hz".into(), serde_json::json!([f]));
            let recs = tests_at(&machine, POSE, &AXES, &AXES, fresh)
                .into_iter()
                .map(|t| disturbed(t, Axis::X, f, 0.3))
                .collect();
            (base.clone(), recs)
        }
        Effect::CrossCoupling => {
            truth.insert("channel".into(), "yx".into());
            let tw = base_twin(&machine, &[Axis::X]);
            (tw, tests_at(&machine, POSE, &[Axis::X], &AXES, fresh))
        }
        Effect::PoseDependence => {
            let axis = rng.gen_range(0..2usize);
            let span = rng.gen_range(0.15..0.25);
            truth.insert("axis_of_variation".into(), ["x", "y", "z"][axis].into());
            let mut recs = Vec::new();
            for (i, d) in [-span, span].iter().enumerate() {
                let mut p = POSE;
                p[axis] += d;
                recs.extend(tests_at(&machine, p, &AXES, &AXES, fresh + 2 * i as u64));
            }
            (base.clone(), recs)
        }
        Effect::Nonlinearity => {
            let sign = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let shift = sign * rng.gen_range(0.03..0.05);
            truth.insert(
                "kind".into(),
                if sign > 0.0 { "hardening" } else { "softening" }.into(),
            );
            let mut recs = duffing_tests_at(&machine, 2, shift, 400.0, 40.0, POSE, &AXES, fresh);
            recs.extend(duffing_tests_at(
                &machine,
                2,
                shift,
                400.0,
                400.0,
                POSE,
                &AXES,
                fresh + 5,
            ));
            (base.clone(), recs)
        }
    };
    Case {
        effect,
        twin,
        records,
        truth,
    }
}

/// Impact tests where mode `k` has a cubic (Duffing) modal stiffness: hammer along each of
/// `axes` with hits of about `peak` N, responses (acceleration) along `out`. The cubic
/// coefficient is chosen so that at the response amplitude of `ref_peak` N hits the
/// mode's backbone frequency is `shift` higher (hardening; negative = softening). The
/// other modes stay linear (exact simulation); mode `k` is integrated with RK4 at the
/// simulation rate.
#[allow(clippy::too_many_arguments)]
pub fn duffing_tests_at(
    m: &ModalMachine,
    k: usize,
    shift: f64,
    ref_peak: f64,
    peak: f64,
    pose: [f64; 3],
    out: &[Axis],
    seed: u64,
) -> Vec<TimeSeries> {
    use crate::daq::{acquire, simulate_machine};
    use crate::excitation::{hit_series, impacts};
    let daq = Daq::default();
    let fs = daq.fs_sim();
    let mut lin = m.clone();
    let v = lin.modes.remove(k);
    let mode = m.mode_at(k, pose);
    let (w, z) = (mode.wn, mode.zeta);
    // amplitude of the mode after a ref_peak hit (half-sine of 0.25 ms): impulse/(m ω)
    let impulse = ref_peak * 2.5e-4 * 2.0 / std::f64::consts::PI;
    let a_ref = v.shape.iter().fold(0.0f64, |a, s| a.max(s.abs())) * impulse / (v.mass * w);
    // backbone ω_eff² = ω²(1 + ¾ γ A²)
    let gamma = ((1.0 + shift).powi(2) - 1.0) / (0.75 * a_ref * a_ref);
    AXES.iter()
        .enumerate()
        .map(|(ai, axis)| {
            let spacing = 0.5;
            let n = ((5.0 * spacing + 0.05) * fs) as usize;
            let hs = hit_series(5, 0.02, spacing, peak, 2.5e-4, seed + ai as u64);
            let f = impacts(fs, n, &hs, None);
            let mut forces: [Option<Vec<f64>>; 3] = [None, None, None];
            forces[axis.index()] = Some(f.clone());
            let pose_at = move |_t: f64| pose;
            let mut resp = simulate_machine(&lin, &forces, fs, &pose_at, out, daq.response);
            // the Duffing mode: η'' + 2ζωη' + ω²(η + γη³) = φ_axis F / m
            let phi_in = v.shape[axis.index()];
            let acc = |eta: f64, vel: f64, force: f64| {
                phi_in * force / v.mass - 2.0 * z * w * vel - w * w * (eta + gamma * eta.powi(3))
            };
            let h = 1.0 / fs;
            let (mut eta, mut vel) = (0.0f64, 0.0f64);
            let mut eta_dd = vec![0.0; n];
            for i in 0..n {
                let f0 = f[i];
                let f1 = if i + 1 < n { f[i + 1] } else { f0 };
                let fm = 0.5 * (f0 + f1);
                eta_dd[i] = acc(eta, vel, f0);
                let (k1x, k1v) = (vel, acc(eta, vel, f0));
                let (k2x, k2v) = (
                    vel + 0.5 * h * k1v,
                    acc(eta + 0.5 * h * k1x, vel + 0.5 * h * k1v, fm),
                );
                let (k3x, k3v) = (
                    vel + 0.5 * h * k2v,
                    acc(eta + 0.5 * h * k2x, vel + 0.5 * h * k2v, fm),
                );
                let (k4x, k4v) = (vel + h * k3v, acc(eta + h * k3x, vel + h * k3v, f1));
                eta += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                vel += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
            for o in out {
                if let Some(r) = resp[o.index()].as_mut() {
                    let phi_o = v.shape[o.index()];
                    for (ri, a) in r.iter_mut().zip(&eta_dd) {
                        *ri += phi_o * a;
                    }
                }
            }
            let daq = Daq {
                seed: daq.seed ^ (seed + ai as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                ..daq.clone()
            };
            acquire(
                forces,
                resp,
                &pose_at,
                &daq,
                &format!("impact_{axis}_{peak:.0}N"),
            )
        })
        .collect()
}
