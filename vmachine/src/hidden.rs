//! Test data with one hidden effect, its parameters drawn from a seed: what `mtwin
//! diagnose` must find. [`case`]: impact tests; [`milling_case`]: milling records (its
//! own table). Impact tests (hammer along x and y, 5 hits, responses x and y) on
//! [`ModalMachine::default_machine`] at the workspace centre, against a twin identified
//! from clean tests there ([`base_tests`], [`BaseTwins`]).
//!
//! | effect | hidden in the data | truth reported |
//! |---|---|---|
//! | `None` | nothing (fresh noise) | — |
//! | `ModeChange` | mode 4 (330 Hz) stiffness −10…−20 % | `new_freq_hz` |
//! | `UnmodeledMode` | a new 400–480 Hz mode along x | `freq_hz` |
//! | `TimeDelay` | responses 2–5 samples late | `delay_s` |
//! | `Disturbance` | a 600–700 Hz sinusoid on x, 30 % of the response RMS | `freq_hz` |
//! | `CrossCoupling` | the twin knows x→x only; the data also record y | `channel` |
//! | `PoseDependence` | the twin has one pose; the data come from two poses ±0.15–0.25 m along x or y | `axis_of_variation`, `freq_shift_pct_per_m` (per mode) |
//! | `Nonlinearity` | mode 2 (180 Hz) with a cubic stiffness shifting it 3–5 % (±) at 400 N hits; tests at 40 N and 400 N | `kind` |

use crate::daq::{acquire, impact_record, milling_forces, simulate_machine, Daq};
use crate::excitation::Milling;
use crate::structure::{ModalMachine, VMode};
use mtwin_core::axis::Axis;
use mtwin_core::timeseries::{ResponseKind, TimeSeries};
use mtwin_core::twin::Twin;
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

/// Band of the base twins' identification (the caller identifies them from
/// [`base_tests`] in this band, automatic order).
pub const BASE_BAND_HZ: (f64, f64) = (30.0, 2500.0);

/// Clean impact tests at [`POSE`], hammer and responses along `axes`: the data of a base
/// twin.
pub fn base_tests(m: &ModalMachine, axes: &[Axis]) -> Vec<TimeSeries> {
    tests_at(m, POSE, axes, axes, 1)
}

/// The twins [`case`] diagnoses against, each identified by the caller from
/// [`base_tests`] of the default machine in [`BASE_BAND_HZ`]: the generator makes data
/// and truth only; it judges the identification and does not call it.
#[derive(Debug, Clone)]
pub struct BaseTwins {
    /// From tests with hammer and responses along x and y ([`AXES`]).
    pub xy: Twin,
    /// From tests with hammer and response along x only (the cross-coupling case: a
    /// twin without the cross channels).
    pub x: Twin,
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

/// The axis (x or y) and half-span \[m\] of a hidden pose dependence drawn from `rng`,
/// with its truth (the axis, every mode's frequency shift in %/m) written to `truth`.
fn pose_dependence_truth(
    machine: &ModalMachine,
    rng: &mut StdRng,
    truth: &mut serde_json::Map<String, serde_json::Value>,
) -> (usize, f64) {
    let axis = rng.gen_range(0..2usize);
    let span = rng.gen_range(0.15..0.25);
    truth.insert("axis_of_variation".into(), ["x", "y", "z"][axis].into());
    let rates: Vec<f64> = machine.modes.iter().map(|v| 100.0 * v.grad[axis]).collect();
    truth.insert("freq_shift_pct_per_m".into(), serde_json::json!(rates));
    (axis, span)
}

/// One case of `effect` with parameters from `seed`, against the twins `base` (passed in
/// so many cases share one identification).
pub fn case(effect: Effect, seed: u64, base: &BaseTwins) -> Case {
    let machine = ModalMachine::default_machine();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut truth = serde_json::Map::new();
    let fresh = 1000 + 10 * seed;
    let (twin, records) = match effect {
        Effect::None => (
            base.xy.clone(),
            tests_at(&machine, POSE, &AXES, &AXES, fresh),
        ),
        Effect::ModeChange => {
            let factor = rng.gen_range(0.8..0.9);
            let worn = machine.clone().with_stiffness_change(4, factor);
            truth.insert("new_freq_hz".into(), worn.mode_at(4, POSE).freq_hz().into());
            (base.xy.clone(), tests_at(&worn, POSE, &AXES, &AXES, fresh))
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
            (base.xy.clone(), tests_at(&extra, POSE, &AXES, &AXES, fresh))
        }
        Effect::TimeDelay => {
            let k = rng.gen_range(2..=5usize);
            truth.insert("delay_s".into(), (k as f64 / Daq::default().fs).into());
            let recs = tests_at(&machine, POSE, &AXES, &AXES, fresh)
                .into_iter()
                .map(|t| delayed(t, k))
                .collect();
            (base.xy.clone(), recs)
        }
        Effect::Disturbance => {
            let f = rng.gen_range(600.0..700.0);
            truth.insert("freq_hz".into(), serde_json::json!([f]));
            let recs = tests_at(&machine, POSE, &AXES, &AXES, fresh)
                .into_iter()
                .map(|t| disturbed(t, Axis::X, f, 0.3))
                .collect();
            (base.xy.clone(), recs)
        }
        Effect::CrossCoupling => {
            truth.insert("channel".into(), "yx".into());
            (
                base.x.clone(),
                tests_at(&machine, POSE, &[Axis::X], &AXES, fresh),
            )
        }
        Effect::PoseDependence => {
            let (axis, span) = pose_dependence_truth(&machine, &mut rng, &mut truth);
            let mut recs = Vec::new();
            for (i, d) in [-span, span].iter().enumerate() {
                let mut p = POSE;
                p[axis] += d;
                recs.extend(tests_at(&machine, p, &AXES, &AXES, fresh + 2 * i as u64));
            }
            (base.xy.clone(), recs)
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
            (base.xy.clone(), recs)
        }
    };
    Case {
        effect,
        twin,
        records,
        truth,
    }
}

/// Seconds of each milling record of [`milling_case`].
pub const MILL_SECONDS: f64 = 4.0;

/// Broadband share of the milling force (standard deviation relative to the cutting
/// force's RMS) in [`milling_case`].
pub const MILL_BROADBAND: f64 = 0.5;

/// One milling record of [`milling_tests`]: spindle speed, axial depth of cut, pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cut {
    /// Spindle speed \[rev/min\].
    pub rpm: f64,
    /// Axial depth of cut \[m\].
    pub ap: f64,
    /// Where the tool is (fixed during the record).
    pub pose: [f64; 3],
}

/// [`acquire`] at a fixed pose with the noise seed of `daq` mixed with `record` (each
/// record of a set gets its own noise).
fn acquire_at(
    forces: [Option<Vec<f64>>; 3],
    resp: [Option<Vec<f64>>; 3],
    pose: [f64; 3],
    daq: &Daq,
    record: u64,
    name: &str,
) -> TimeSeries {
    let daq = Daq {
        seed: daq.seed ^ record.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        ..daq.clone()
    };
    acquire(forces, resp, &move |_t| pose, &daq, name)
}

/// Milling records ([`MILL_SECONDS`] each, 3-tooth cutter, mechanistic force plus a
/// [`MILL_BROADBAND`] share, forces and responses along x and y), one per cut. With
/// `duffing = Some((k, γ))` mode `k` has the cubic modal stiffness γ
/// ([`Duffing::response`]).
pub fn milling_tests(
    m: &ModalMachine,
    cuts: &[Cut],
    seed: u64,
    duffing: Option<(usize, f64)>,
) -> Vec<TimeSeries> {
    let daq = Daq::default();
    let fs = daq.fs_sim();
    cuts.iter()
        .enumerate()
        .map(|(i, c)| {
            let (forces, s) = cut_forces(c, i, seed);
            let pose = c.pose;
            let resp = match duffing {
                Some((mode, gamma)) => Duffing {
                    machine: m,
                    mode,
                    gamma,
                    pose,
                }
                .response(&forces, fs, &AXES, daq.response),
                None => simulate_machine(m, &forces, fs, &move |_t| pose, &AXES, daq.response),
            };
            acquire_at(
                forces,
                resp,
                pose,
                &daq,
                s,
                &format!("milling_{:.0}rpm_{:.1}mm", c.rpm, 1e3 * c.ap),
            )
        })
        .collect()
}

/// The forces (at the simulation rate) of cut number `i` of [`milling_tests`] and the
/// seed of its record.
fn cut_forces(c: &Cut, i: usize, seed: u64) -> ([Option<Vec<f64>>; 3], u64) {
    let fs = Daq::default().fs_sim();
    let n = (MILL_SECONDS * fs) as usize;
    let s = seed.wrapping_add(2 * i as u64);
    (milling_forces(&milling_cut(c), fs, n, MILL_BROADBAND, s), s)
}

/// The cubic modal stiffness γ that moves mode `k` by `shift` (relative; negative =
/// softening) in the most strongly excited of `cuts` (as [`milling_tests`] with `seed`
/// makes them): statistical linearisation, `ω_eq² = ω²(1 + 3γ E[η²])` with the mode's
/// linear motion η.
pub fn duffing_gamma(m: &ModalMachine, k: usize, shift: f64, cuts: &[Cut], seed: u64) -> f64 {
    let fs = Daq::default().fs_sim();
    let var = cuts
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let (f, _) = cut_forces(c, i, seed);
            let linear = Duffing {
                machine: m,
                mode: k,
                gamma: 0.0,
                pose: c.pose,
            };
            let (eta, _) = linear.motion(&f, fs);
            eta.iter().map(|e| e * e).sum::<f64>() / eta.len().max(1) as f64
        })
        .fold(0.0, f64::max);
    ((1.0 + shift).powi(2) - 1.0) / (3.0 * var.max(1e-300))
}

fn milling_cut(c: &Cut) -> Milling {
    Milling {
        rpm: c.rpm,
        teeth: 3,
        ap: c.ap,
        ..Milling::default()
    }
}

/// The frequency `f` Hz is at least `gap` Hz away from every harmonic of the spindle
/// frequency of each speed in `rpms` (the tooth-passing harmonics and the runout's
/// spindle harmonics: the lines the cutting force itself puts into the response).
fn off_harmonics(f: f64, rpms: &[f64], gap: f64) -> bool {
    rpms.iter().all(|r| {
        let fsp = r / 60.0;
        let k = (f / fsp).round();
        (f - k * fsp).abs() >= gap
    })
}

/// One case of `effect` in milling data, with its parameters from `seed`: 3 spindle
/// speeds drawn from 2000–5000 rpm (3 teeth, 2 mm depth of cut, [`MILL_SECONDS`] each)
/// at [`POSE`], against `base` (the twin [`BaseTwins::xy`] of the default machine, identified
/// from impact tests).
///
/// | effect | hidden in the data | truth reported |
/// |---|---|---|
/// | `None` | nothing (fresh noise) | — |
/// | `ModeChange` | mode 2, 4, 5 or 6 (180/330/520/760 Hz) stiffness −10…−20 % | `freq_hz`, `new_freq_hz`, `new_damping`, `axis` |
/// | `UnmodeledMode` | a new mode at 400–480 or 600–700 Hz, mostly along x or y | `freq_hz`, `damping`, `axis` |
/// | `TimeDelay` | responses 2–5 samples late | `delay_s` |
/// | `Disturbance` | a 560–720 Hz sinusoid on x or y, 30 % of the response RMS, ≥ 4 Hz from every spindle harmonic | `freq_hz` |
/// | `CrossCoupling` | the twin lacks the cross channels xy, yx | `channel` (a list: either is right) |
/// | `PoseDependence` | 2 speeds at each of two poses ±0.15–0.25 m along x or y | `axis_of_variation`, `freq_shift_pct_per_m` (per mode) |
/// | `Nonlinearity` | mode 2 or 4 with a cubic stiffness (±), 2 speeds at 1 mm and at 3 mm depth of cut: 3–5 % shift in the cut that moves the mode most ([`duffing_gamma`]) | `freq_hz`, `kind` |
pub fn milling_case(effect: Effect, seed: u64, base: &Twin) -> Case {
    let machine = ModalMachine::default_machine();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut truth = serde_json::Map::new();
    let fresh = 5000 + 10 * seed;
    let rpms: Vec<f64> = (0..3).map(|_| rng.gen_range(2000.0..5000.0)).collect();
    let cuts = |pose: [f64; 3], ap: f64, k: usize| -> Vec<Cut> {
        rpms[..k].iter().map(|&rpm| Cut { rpm, ap, pose }).collect()
    };
    let plain = cuts(POSE, 2e-3, 3);
    let fs = Daq::default().fs;
    let (twin, records) = match effect {
        Effect::None => (base.clone(), milling_tests(&machine, &plain, fresh, None)),
        Effect::ModeChange => {
            let k = [2usize, 4, 5, 6][rng.gen_range(0..4)];
            let factor = rng.gen_range(0.8..0.9);
            let worn = machine.clone().with_stiffness_change(k, factor);
            let old = machine.mode_at(k, POSE);
            let shape = machine.modes[k].shape;
            truth.insert("freq_hz".into(), old.freq_hz().into());
            truth.insert("new_freq_hz".into(), worn.mode_at(k, POSE).freq_hz().into());
            truth.insert("new_damping".into(), old.zeta.into());
            truth.insert("axis".into(), dominant(shape).into());
            (base.clone(), milling_tests(&worn, &plain, fresh, None))
        }
        Effect::UnmodeledMode => {
            let f = if rng.gen_bool(0.5) {
                rng.gen_range(400.0..480.0)
            } else {
                rng.gen_range(600.0..700.0)
            };
            let zeta = rng.gen_range(0.015..0.03);
            let shape = if rng.gen_bool(0.5) {
                [0.8, 0.2, 0.0]
            } else {
                [0.2, 0.8, 0.0]
            };
            let extra = machine.clone().with_extra_mode(VMode {
                f_hz: f,
                zeta,
                mass: 60.0,
                shape,
                grad: [0.0; 3],
                quad: [0.0; 3],
            });
            truth.insert("freq_hz".into(), f.into());
            truth.insert("damping".into(), zeta.into());
            truth.insert("axis".into(), dominant(shape).into());
            (base.clone(), milling_tests(&extra, &plain, fresh, None))
        }
        Effect::TimeDelay => {
            let k = rng.gen_range(2..=5usize);
            truth.insert("delay_s".into(), (k as f64 / fs).into());
            let recs = milling_tests(&machine, &plain, fresh, None)
                .into_iter()
                .map(|t| delayed(t, k))
                .collect();
            (base.clone(), recs)
        }
        Effect::Disturbance => {
            let f = loop {
                let f = rng.gen_range(560.0..720.0);
                if off_harmonics(f, &rpms, 4.0) {
                    break f;
                }
            };
            let axis = AXES[rng.gen_range(0..2)];
            truth.insert("freq_hz".into(), serde_json::json!([f]));
            let recs = milling_tests(&machine, &plain, fresh, None)
                .into_iter()
                .map(|t| disturbed(t, axis, f, 0.3))
                .collect();
            (base.clone(), recs)
        }
        Effect::CrossCoupling => {
            truth.insert("channel".into(), serde_json::json!(["xy", "yx"]));
            (
                without_cross_channels(base),
                milling_tests(&machine, &plain, fresh, None),
            )
        }
        Effect::PoseDependence => {
            let (axis, span) = pose_dependence_truth(&machine, &mut rng, &mut truth);
            let mut all = Vec::new();
            for d in [-span, span] {
                let mut p = POSE;
                p[axis] += d;
                all.extend(cuts(p, 2e-3, 2));
            }
            (base.clone(), milling_tests(&machine, &all, fresh, None))
        }
        Effect::Nonlinearity => {
            let k = [2usize, 4][rng.gen_range(0..2)];
            let sign: f64 = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let shift = sign * rng.gen_range(0.03..0.05);
            truth.insert("freq_hz".into(), machine.mode_at(k, POSE).freq_hz().into());
            truth.insert(
                "kind".into(),
                if sign > 0.0 { "hardening" } else { "softening" }.into(),
            );
            let mut all = cuts(POSE, 1e-3, 2);
            all.extend(cuts(POSE, 3e-3, 2));
            let gamma = duffing_gamma(&machine, k, shift, &all, fresh);
            (
                base.clone(),
                milling_tests(&machine, &all, fresh, Some((k, gamma))),
            )
        }
    };
    Case {
        effect,
        twin,
        records,
        truth,
    }
}

/// `x` or `y`, whichever a mode shape moves more.
fn dominant(shape: [f64; 3]) -> &'static str {
    if shape[0].abs() >= shape[1].abs() {
        "x"
    } else {
        "y"
    }
}

/// The twin without its cross channels (only `xx`, `yy`, `zz` left).
pub fn without_cross_channels(twin: &Twin) -> Twin {
    let mut t = twin.clone();
    let direct = |c: &mtwin_core::axis::Channel| c.output == c.input;
    t.channels.retain(direct);
    for p in &mut t.poses {
        p.model.channels.retain(|c| direct(&c.channel));
        p.frf.channels.retain(|c| direct(&c.channel));
        p.fit.retain(|c| direct(&c.channel));
    }
    t
}

/// Impact tests where mode `k` has a cubic (Duffing) modal stiffness: hammer along each of
/// `axes` with hits of about `peak` N, responses (acceleration) along `out`. The cubic
/// coefficient is chosen so that at the response amplitude of `ref_peak` N hits the
/// mode's backbone frequency is `shift` higher (hardening; negative = softening). The
/// other modes stay linear (exact simulation); mode `k` is integrated with RK4 at the
/// simulation rate ([`Duffing::response`]).
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
    use crate::excitation::{hit_series, impacts};
    let daq = Daq::default();
    let fs = daq.fs_sim();
    let v = &m.modes[k];
    let w = m.mode_at(k, pose).wn;
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
            let mut forces: [Option<Vec<f64>>; 3] = [None, None, None];
            forces[axis.index()] = Some(impacts(fs, n, &hs, None));
            let cubic = Duffing {
                machine: m,
                mode: k,
                gamma,
                pose,
            };
            let resp = cubic.response(&forces, fs, out, daq.response);
            acquire_at(
                forces,
                resp,
                pose,
                &daq,
                seed + ai as u64,
                &format!("impact_{axis}_{peak:.0}N"),
            )
        })
        .collect()
}

/// Mode `mode` of `machine`, standing at `pose`, with the cubic (Duffing) modal stiffness
/// `gamma`: `η'' + 2ζωη' + ω²(η + γη³) = φ·F / m`.
#[derive(Debug, Clone, Copy)]
pub struct Duffing<'a> {
    /// The machine.
    pub machine: &'a ModalMachine,
    /// Index of the cubic mode.
    pub mode: usize,
    /// Cubic stiffness γ of the modal coordinate (the term ω²γη³).
    pub gamma: f64,
    /// Where the machine stands.
    pub pose: [f64; 3],
}

impl Duffing<'_> {
    /// Motion of the mode under `forces` sampled at `fs` (RK4 at the sampling rate, the
    /// force linear between samples). Returns `(η, η'')` per sample.
    pub fn motion(&self, forces: &[Option<Vec<f64>>; 3], fs: f64) -> (Vec<f64>, Vec<f64>) {
        let v = &self.machine.modes[self.mode];
        let mode = self.machine.mode_at(self.mode, self.pose);
        let (w, z, gamma) = (mode.wn, mode.zeta, self.gamma);
        let n = forces.iter().flatten().map(Vec::len).next().unwrap_or(0);
        // the modal force φ·F
        let mut f = vec![0.0; n];
        for (a, fa) in forces.iter().enumerate() {
            if let Some(fa) = fa {
                f.iter_mut().zip(fa).for_each(|(t, x)| *t += v.shape[a] * x);
            }
        }
        let acc = |eta: f64, vel: f64, force: f64| {
            force / v.mass - 2.0 * z * w * vel - w * w * (eta + gamma * eta.powi(3))
        };
        let h = 1.0 / fs;
        let (mut eta, mut vel) = (0.0f64, 0.0f64);
        let mut eta_s = vec![0.0; n];
        let mut eta_dd = vec![0.0; n];
        for i in 0..n {
            let f0 = f[i];
            let f1 = if i + 1 < n { f[i + 1] } else { f0 };
            let fm = 0.5 * (f0 + f1);
            eta_s[i] = eta;
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
        (eta_s, eta_dd)
    }

    /// Response of the machine to any `forces` (sampled at `fs`): the cubic mode by
    /// [`Duffing::motion`], the other modes exactly. Responses (`kind`) along `out`, at
    /// `fs`.
    pub fn response(
        &self,
        forces: &[Option<Vec<f64>>; 3],
        fs: f64,
        out: &[Axis],
        kind: ResponseKind,
    ) -> [Option<Vec<f64>>; 3] {
        let pose = self.pose;
        let mut lin = self.machine.clone();
        lin.modes.remove(self.mode);
        let mut resp = simulate_machine(&lin, forces, fs, &move |_t| pose, out, kind);
        let (eta, eta_dd) = self.motion(forces, fs);
        let q = match kind {
            ResponseKind::Acceleration => eta_dd,
            ResponseKind::Displacement => eta,
        };
        for o in out {
            if let Some(r) = resp[o.index()].as_mut() {
                let phi_o = self.machine.modes[self.mode].shape[o.index()];
                r.iter_mut().zip(&q).for_each(|(ri, a)| *ri += phi_o * a);
            }
        }
        resp
    }
}
