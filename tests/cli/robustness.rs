//! Robustness matrix over mtwin's own generator, defaults only.
//!
//! Every cell generates, from a seed, a structure (modes, damping, mode shapes) and two
//! measurements at one pose (excitation along x, then along y; displacement responses
//! dx, dy), writes them as time-series CSV (docs/formats.md, "Time-series CSV"), runs the real binary
//! `mtwin identify X.csv Y.csv --out twin.json` with no other option, evaluates the twin
//! with `mtwin eval --freqs` and compares its receptance with the analytic FRF of the
//! generating structure in the band where the force has energy:
//! fit = 100 · (1 − ‖H − Ĥ‖ / ‖H‖) per channel (xx, yy; yx, xy when the structure
//! couples the axes; when it does not, the recorded cross responses are noise only and
//! the twin's cross channel is judged against zero, relative to the direct channel).
//!
//! Thresholds come from the data, never from mtwin's twin: a good identifier should be
//! at least as close to the truth as the best plain FRF estimate of the same records
//! (the H1 `mtwin frf` makes, the plain full-record DFT ratio, a plain per-hit H1 for
//! impacts, a plain Welch H1 for random force; each judged against the truth on its own
//! lines), minus a margin of 1 point, and need not exceed 99 %:
//! threshold = min(99, best plain estimate − 1).
//!
//! The matrix varies one thing at a time around a nominal cell (impacts well apart,
//! 1 % response noise, 2 % damping, hard tip, coupled axes, 8 modes, 10.24 kHz) and adds
//! a few combined corners. The table goes to stderr; every failure is listed at once.
//! A cell flagged `known_failure` is printed as KNOWN FAIL instead of failing the test.
//!
//! `cargo test --release --test cli robustness:: -- --nocapture`

use crate::common::{mtwin, s, stderr, tmp};
use identify::axis::{Axis, Channel};
use identify::frf::Frf;
use identify::model::ModalModel;
use identify::read::{read_frf_csv, write_timeseries};
use identify::timeseries::{ResponseKind, TimeSeries};
use identify::twin::Twin;
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::time::Instant;
use vmachine::daq::{acquire, simulate_machine, Daq};
use vmachine::excitation::{chirp, impacts, noise, Hit};
use vmachine::structure::{ModalMachine, VMode};

/// Margin [points] by which the twin may fall short of the best plain estimate.
const MARGIN: f64 = 1.0;
/// What a good identifier reaches on clean data [%].
const CLEAN_TARGET: f64 = 99.0;
/// Lowest and highest natural frequency of the generated structures [Hz].
const MODE_BAND: (f64, f64) = (80.0, 1500.0);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Impact,
    LinChirp,
    LogChirp,
    Random,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Spacing {
    /// Hits 6 decay times of the slowest mode apart (−52 dB before the next hit).
    Separated,
    /// Hits one decay time apart (37 % of the response left at the next hit).
    Close,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Cross {
    /// Every mode moves along x and y: cross channels yx, xy exist.
    Coupled,
    /// Each mode moves along x or along y only: the cross responses are noise only.
    NoiseOnly,
}

#[derive(Clone, Debug)]
struct Cell {
    name: &'static str,
    kind: Kind,
    modes: usize,
    zeta: f64,
    /// Response sensor noise, standard deviation relative to the RMS of the record's
    /// direct response (the same on every response channel of the record).
    noise: f64,
    fs: f64,
    spacing: Spacing,
    /// Soft hammer tip: the force spectrum is 20 dB down at 1/3 of Nyquist.
    soft_tip: bool,
    cross: Cross,
    seed: u64,
    /// Fails with the current identifier: printed as KNOWN FAIL, not asserted.
    known_failure: bool,
}

const NOMINAL: Cell = Cell {
    name: "nominal",
    kind: Kind::Impact,
    modes: 8,
    zeta: 0.02,
    noise: 0.01,
    fs: 10240.0,
    spacing: Spacing::Separated,
    soft_tip: false,
    cross: Cross::Coupled,
    seed: 1,
    known_failure: false,
};

fn cells() -> Vec<Cell> {
    vec![
        NOMINAL,
        // response noise
        Cell {
            name: "noise 0.1%",
            noise: 0.001,
            seed: 2,
            ..NOMINAL
        },
        Cell {
            name: "noise 5%",
            noise: 0.05,
            seed: 3,
            ..NOMINAL
        },
        // hit spacing
        Cell {
            name: "hits close",
            spacing: Spacing::Close,
            seed: 4,
            ..NOMINAL
        },
        // damping
        Cell {
            name: "damping 0.5%",
            zeta: 0.005,
            seed: 5,
            ..NOMINAL
        },
        Cell {
            name: "damping 8%",
            zeta: 0.08,
            seed: 6,
            ..NOMINAL
        },
        // force roll-off
        Cell {
            name: "soft tip",
            soft_tip: true,
            seed: 7,
            ..NOMINAL
        },
        // noise-only cross channels
        Cell {
            name: "noise-only cross",
            cross: Cross::NoiseOnly,
            seed: 8,
            ..NOMINAL
        },
        // excitation
        Cell {
            name: "linear chirp",
            kind: Kind::LinChirp,
            seed: 9,
            ..NOMINAL
        },
        Cell {
            name: "log chirp",
            kind: Kind::LogChirp,
            seed: 10,
            ..NOMINAL
        },
        Cell {
            name: "random",
            kind: Kind::Random,
            seed: 11,
            ..NOMINAL
        },
        // number of modes
        Cell {
            name: "1 mode",
            modes: 1,
            seed: 12,
            ..NOMINAL
        },
        Cell {
            name: "3 modes",
            modes: 3,
            seed: 13,
            ..NOMINAL
        },
        Cell {
            name: "20 modes",
            modes: 20,
            seed: 14,
            ..NOMINAL
        },
        // sample rate
        Cell {
            name: "fs 5 kHz",
            fs: 5000.0,
            seed: 15,
            known_failure: true,
            ..NOMINAL
        },
        Cell {
            name: "fs 25.6 kHz",
            fs: 25600.0,
            seed: 16,
            ..NOMINAL
        },
        // second seed of the sample-rate cell that fails, and the corners' parts
        Cell {
            name: "fs 5 kHz, seed b",
            fs: 5000.0,
            seed: 21,
            ..NOMINAL
        },
        Cell {
            name: "random noise 5%",
            kind: Kind::Random,
            noise: 0.05,
            seed: 22,
            ..NOMINAL
        },
        Cell {
            name: "random damping 8%",
            kind: Kind::Random,
            zeta: 0.08,
            seed: 23,
            ..NOMINAL
        },
        Cell {
            name: "random damping 0.5%",
            kind: Kind::Random,
            zeta: 0.005,
            seed: 24,
            ..NOMINAL
        },
        Cell {
            name: "linear chirp noise 5%",
            kind: Kind::LinChirp,
            noise: 0.05,
            seed: 25,
            ..NOMINAL
        },
        Cell {
            name: "hits close, damping 0.5%",
            spacing: Spacing::Close,
            zeta: 0.005,
            seed: 26,
            ..NOMINAL
        },
        // combined corners
        Cell {
            name: "C1 close+0.5%+noise 5%",
            spacing: Spacing::Close,
            zeta: 0.005,
            noise: 0.05,
            seed: 17,
            ..NOMINAL
        },
        Cell {
            name: "C2 soft+20 modes+25.6k",
            soft_tip: true,
            modes: 20,
            fs: 25600.0,
            seed: 18,
            ..NOMINAL
        },
        Cell {
            name: "C3 random+8%+noise 5%",
            kind: Kind::Random,
            zeta: 0.08,
            noise: 0.05,
            seed: 19,
            ..NOMINAL
        },
        Cell {
            name: "C4 log+0.5%+nocross+5k",
            kind: Kind::LogChirp,
            zeta: 0.005,
            cross: Cross::NoiseOnly,
            fs: 5000.0,
            seed: 20,
            ..NOMINAL
        },
        Cell {
            name: "C5 20 modes+0.5%+noise 5%",
            modes: 20,
            zeta: 0.005,
            noise: 0.05,
            seed: 27,
            ..NOMINAL
        },
    ]
}

/// splitmix64: a tiny seeded generator for the structure and the hit times.
struct Mix(u64);

impl Mix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [−1, 1).
    fn sym(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }
}

/// The cell's structure: modes log-spaced over [`MODE_BAND`] (±4 % jitter), modal
/// stiffness 0.5–2 · 10⁸ N/m (so every mode's peak counts), shapes 0.5–1 with random
/// signs.
fn structure(c: &Cell) -> ModalMachine {
    let mut r = Mix(c.seed.wrapping_mul(7919) ^ 0x5EED);
    let modes = (0..c.modes)
        .map(|k| {
            let f0 = if c.modes == 1 {
                300.0
            } else {
                MODE_BAND.0 * (MODE_BAND.1 / MODE_BAND.0).powf(k as f64 / (c.modes - 1) as f64)
            };
            let f_hz = f0 * (1.0 + 0.04 * r.sym());
            let stiffness = 1e8 * 2f64.powf(r.sym());
            let w = 2.0 * PI * f_hz;
            let mut amp = || (0.5 + 0.5 * r.uniform()) * if r.sym() < 0.0 { -1.0 } else { 1.0 };
            let shape = match c.cross {
                Cross::Coupled => [amp(), amp(), 0.0],
                Cross::NoiseOnly if k % 2 == 0 => [amp().abs(), 0.0, 0.0],
                Cross::NoiseOnly => [0.0, amp().abs(), 0.0],
            };
            VMode {
                f_hz,
                zeta: c.zeta,
                mass: stiffness / (w * w),
                shape,
                grad: [0.0; 3],
                quad: [0.0; 3],
            }
        })
        .collect();
    ModalMachine {
        modes,
        lo: [0.0; 3],
        hi: [0.0; 3],
    }
}

/// Decay time 1/(ζω) of the slowest mode [s].
fn tau_max(m: &ModalMachine) -> f64 {
    m.modes
        .iter()
        .map(|v| 1.0 / (v.zeta * 2.0 * PI * v.f_hz))
        .fold(0.0, f64::max)
}

/// |spectrum| of a half-sine pulse of unit width at `x` = f · width, relative to DC.
fn half_sine_rel(x: f64) -> f64 {
    if (x - 0.5).abs() < 1e-9 {
        return PI / 4.0;
    }
    ((PI * x).cos() / (1.0 - 4.0 * x * x)).abs()
}

/// f · width where the half-sine's spectrum is 20 dB below DC (first crossing).
fn half_sine_m20() -> f64 {
    let (mut a, mut b) = (1.0, 1.5);
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if half_sine_rel(m) > 0.1 {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// One generated record and what the judge knows about its excitation.
struct Record {
    ts: TimeSeries,
    /// Hit times [s] (impacts).
    hits: Vec<f64>,
}

/// Design of the excitation: the force at the simulation rate and the hit times.
fn force(c: &Cell, tau: f64, fs_sim: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut r = Mix(seed);
    let rest = 6.0 * tau;
    match c.kind {
        Kind::Impact => {
            let width = if c.soft_tip {
                half_sine_m20() / (c.fs / 6.0)
            } else {
                1.25 / c.fs
            };
            let (spacing, count) = match c.spacing {
                Spacing::Separated => (6.0 * tau, 4),
                Spacing::Close => (tau, 8),
            };
            let mut hits = Vec::new();
            let mut t = 0.02;
            for _ in 0..count {
                hits.push(Hit {
                    t,
                    peak: 200.0 * (1.0 + 0.2 * r.sym()),
                    width,
                });
                t += spacing * (1.0 + 0.15 * r.sym());
            }
            let end = hits.last().map_or(0.0, |h| h.t) + rest;
            let n = (end * fs_sim) as usize;
            (
                impacts(fs_sim, n, &hits, None),
                hits.iter().map(|h| h.t).collect(),
            )
        }
        Kind::LinChirp | Kind::LogChirp => {
            let (f0, f1) = sweep_range(c);
            let ns = (4.0 * fs_sim) as usize;
            let mut f = if c.kind == Kind::LinChirp {
                chirp(fs_sim, ns, f0, f1, 10.0, 1)
            } else {
                let tsw = ns as f64 / fs_sim;
                let k = (f1 / f0).ln() / tsw;
                (0..ns)
                    .map(|i| {
                        let t = i as f64 / fs_sim;
                        10.0 * (2.0 * PI * f0 * ((k * t).exp() - 1.0) / k).sin()
                    })
                    .collect()
            };
            f.extend(std::iter::repeat_n(0.0, (rest * fs_sim) as usize));
            (f, vec![])
        }
        Kind::Random => {
            let n = ((16.0f64).max(40.0 * tau) * fs_sim) as usize;
            (noise(n, 10.0, seed), vec![])
        }
    }
}

/// Start and end of the sweeps [Hz].
fn sweep_range(c: &Cell) -> (f64, f64) {
    match c.kind {
        Kind::LogChirp => (30.0, 0.45 * c.fs),
        _ => (20.0, 0.45 * c.fs),
    }
}

/// The band where the force has energy (by design, not from mtwin): within 20 dB of
/// its peak and inside the DAQ's anti-alias passband (0.4 fs); sweeps without their
/// first and last 10 %–50 % where the spectrum ripples.
fn judged_band(c: &Cell) -> (f64, f64) {
    let aa = 0.4 * c.fs;
    match c.kind {
        Kind::Impact => {
            let width = if c.soft_tip {
                half_sine_m20() / (c.fs / 6.0)
            } else {
                1.25 / c.fs
            };
            (10.0, aa.min(half_sine_m20() / width))
        }
        Kind::LinChirp => {
            let (f0, f1) = sweep_range(c);
            (1.5 * f0, aa.min(0.9 * f1))
        }
        Kind::LogChirp => {
            // power spectral density ∝ 1/f: 20 dB below the start at 100 · f0
            let (f0, f1) = sweep_range(c);
            (1.5 * f0, aa.min(0.9 * f1).min(100.0 * f0))
        }
        Kind::Random => (10.0, aa),
    }
}

/// The record with excitation along `axis`: simulated at 8 × fs, anti-alias filtered
/// and decimated by vmachine's DAQ (force noise 0.1 % of its RMS), then response noise
/// of `c.noise` × RMS of the direct response on every response channel.
fn record(c: &Cell, m: &ModalMachine, axis: Axis) -> Record {
    let seed = c.seed * 1000 + axis.index() as u64;
    let daq = Daq {
        fs: c.fs,
        oversample: 8,
        force_noise: 0.001,
        response_noise: 0.0,
        response: ResponseKind::Displacement,
        seed,
    };
    let fs_sim = daq.fs_sim();
    let (f, hits) = force(c, tau_max(m), fs_sim, seed);
    let mut forces: [Option<Vec<f64>>; 3] = [None, None, None];
    forces[axis.index()] = Some(f);
    let pose = |_t: f64| [0.0; 3];
    let resp = simulate_machine(
        m,
        &forces,
        fs_sim,
        &pose,
        &[Axis::X, Axis::Y],
        ResponseKind::Displacement,
    );
    let mut ts = acquire(forces, resp, &pose, &daq, &format!("robust_{axis}"));
    ts.position = [None, None, None];
    let direct = ts.response(axis).expect("direct response");
    let rms = (direct.iter().map(|v| v * v).sum::<f64>() / direct.len() as f64).sqrt();
    for (k, a) in [Axis::X, Axis::Y].into_iter().enumerate() {
        let n = ts.len();
        let e = noise(n, c.noise * rms, seed * 7 + 3 + k as u64);
        if let Some(v) = ts.response[a.index()].as_mut() {
            v.iter_mut().zip(&e).for_each(|(y, e)| *y += e);
        }
    }
    ts.comments.push(format!(
        "robustness cell '{}': {:?}, {} modes, zeta {}, response noise {} of the direct RMS",
        c.name, c.kind, c.modes, c.zeta, c.noise
    ));
    Record { ts, hits }
}

fn spectrum(x: &[f64]) -> Vec<Complex64> {
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(x.len());
    let mut input = x.to_vec();
    let mut out = fft.make_output_vec();
    fft.process(&mut input, &mut out).expect("fft");
    out
}

/// Lines (f, H) of an estimate for channel (out, in) of one record.
type Lines = Vec<(f64, Complex64)>;

/// Plain H1 from segments `starts` of `len` samples with window `w` (None = rectangular).
fn segment_h1(
    f: &[f64],
    y: &[f64],
    starts: &[usize],
    len: usize,
    w: Option<&[f64]>,
    fs: f64,
) -> Lines {
    let lines = len / 2 + 1;
    let mut sxy = vec![Complex64::new(0.0, 0.0); lines];
    let mut sxx = vec![0.0; lines];
    for &i0 in starts {
        let seg = |x: &[f64]| -> Vec<f64> {
            (0..len)
                .map(|j| x[i0 + j] * w.map_or(1.0, |w| w[j]))
                .collect()
        };
        let (fa, fb) = (spectrum(&seg(f)), spectrum(&seg(y)));
        for k in 0..lines {
            sxy[k] += fa[k].conj() * fb[k];
            sxx[k] += fa[k].norm_sqr();
        }
    }
    (0..lines)
        .filter(|&k| sxx[k] > 0.0)
        .map(|k| (k as f64 * fs / len as f64, sxy[k] / sxx[k]))
        .collect()
}

/// The plain estimates of one record's channel `out`/`axis` (the judge's own, not mtwin's).
fn plain_estimates(c: &Cell, rec: &Record, axis: Axis, out: Axis) -> Vec<(&'static str, Lines)> {
    let ts = &rec.ts;
    let fs = ts.fs();
    let f = ts.force(axis).expect("force");
    let y = ts.response(out).expect("response");
    let n = f.len();
    let mut est = Vec::new();
    // the whole record's DFT ratio (the response has decayed at the end but for random)
    let (fa, fb) = (spectrum(f), spectrum(y));
    est.push((
        "ratio",
        (1..fa.len())
            .map(|k| (k as f64 * fs / n as f64, fb[k] / fa[k]))
            .collect(),
    ));
    match c.kind {
        Kind::Impact => {
            let starts: Vec<usize> = rec
                .hits
                .iter()
                .map(|t| ((t - 0.005) * fs).max(0.0) as usize)
                .collect();
            let mut len = n - starts.last().copied().unwrap_or(0);
            for w in starts.windows(2) {
                len = len.min(w[1] - w[0]);
            }
            est.push(("per-hit", segment_h1(f, y, &starts, len, None, fs)));
        }
        Kind::Random => {
            let want = (8.0 * tau_max(&structure(c)) * fs) as usize;
            let nfft = want
                .next_power_of_two()
                .min((n / 4).next_power_of_two() / 2);
            let hann: Vec<f64> = (0..nfft)
                .map(|j| 0.5 - 0.5 * (2.0 * PI * j as f64 / nfft as f64).cos())
                .collect();
            let starts: Vec<usize> = (0..)
                .map(|k| k * nfft / 2)
                .take_while(|i| i + nfft <= n)
                .collect();
            est.push(("welch", segment_h1(f, y, &starts, nfft, Some(&hann), fs)));
        }
        _ => {}
    }
    est
}

/// fit = 100 · (1 − ‖H − Ĥ‖ / ‖R‖) over `lines` in `band`, H the truth of `ch`, R the
/// truth of `norm_ch` (the channel itself, or the direct channel when `ch` is zero).
fn fit(
    truth: &ModalModel,
    ch: Channel,
    norm_ch: Channel,
    lines: &[(f64, Complex64)],
    band: (f64, f64),
) -> f64 {
    let ci = truth.channel_index(ch).expect("truth channel");
    let ni = truth.channel_index(norm_ch).expect("truth channel");
    let (mut num, mut den) = (0.0, 0.0);
    for &(f, h) in lines.iter().filter(|(f, _)| *f >= band.0 && *f <= band.1) {
        num += (truth.eval_hz(ci, f) - h).norm_sqr();
        den += truth.eval_hz(ni, f).norm_sqr();
    }
    if den == 0.0 {
        return f64::NAN;
    }
    100.0 * (1.0 - (num / den).sqrt())
}

/// The octave [f, 2f) of `band` holding the largest share of the error ‖H − Ĥ‖², and
/// that share [%].
fn worst_octave(
    truth: &ModalModel,
    ch: Channel,
    lines: &[(f64, Complex64)],
    band: (f64, f64),
) -> (f64, f64) {
    let ci = truth.channel_index(ch).expect("truth channel");
    let octaves = (band.1 / band.0).log2().ceil().max(1.0) as usize;
    let mut err = vec![0.0; octaves];
    for &(f, h) in lines.iter().filter(|(f, _)| *f >= band.0 && *f <= band.1) {
        let k = ((f / band.0).log2().floor() as usize).min(octaves - 1);
        err[k] += (truth.eval_hz(ci, f) - h).norm_sqr();
    }
    let total: f64 = err.iter().sum();
    let (k, e) = err
        .iter()
        .enumerate()
        .fold((0, 0.0), |b, (k, &e)| if e > b.1 { (k, e) } else { b });
    (
        band.0 * 2f64.powi(k as i32),
        if total > 0.0 { 100.0 * e / total } else { 0.0 },
    )
}

fn channel_lines(frf: &Frf, ch: Channel) -> Option<Lines> {
    frf.channel(ch).map(|c| {
        frf.freqs_hz
            .iter()
            .copied()
            .zip(c.h.iter().copied())
            .collect()
    })
}

struct ChannelResult {
    ch: Channel,
    twin: f64,
    reference: f64,
    reference_from: String,
    threshold: f64,
    /// Every plain estimate's fit [%] (name, fit).
    plain: Vec<(String, f64)>,
    /// Start of the octave with most of the twin's error [Hz], and its share [%].
    worst_octave: (f64, f64),
}

/// Below this the best plain estimate is too poor to judge against: the cell's design
/// is broken, and that fails the test too.
const UNJUDGEABLE: f64 = 50.0;

impl ChannelResult {
    fn pass(&self) -> bool {
        self.reference >= UNJUDGEABLE && self.twin >= self.threshold
    }
}

struct CellResult {
    cell: Cell,
    band: (f64, f64),
    truth_modes: usize,
    twin_modes: String,
    twin_excitation: String,
    twin_band: String,
    channels: Vec<ChannelResult>,
    error: Option<String>,
    warnings: usize,
    seconds: f64,
}

impl CellResult {
    fn pass(&self) -> bool {
        self.error.is_none()
            && !self.channels.is_empty()
            && self.channels.iter().all(ChannelResult::pass)
    }
}

fn run_cell(c: &Cell) -> CellResult {
    let t0 = Instant::now();
    let m = structure(c);
    let truth = m.model_at([0.0; 3], &[Axis::X, Axis::Y]);
    let band = judged_band(c);
    let mut res = CellResult {
        cell: c.clone(),
        band,
        truth_modes: m.modes.len(),
        twin_modes: "-".into(),
        twin_excitation: "-".into(),
        twin_band: "-".into(),
        channels: vec![],
        error: None,
        warnings: 0,
        seconds: 0.0,
    };
    let dir = tmp();
    let recs: Vec<(Axis, Record)> = [Axis::X, Axis::Y]
        .into_iter()
        .map(|a| (a, record(c, &m, a)))
        .collect();
    let mut files = Vec::new();
    for (a, r) in &recs {
        let p = dir.path().join(format!("hit_{a}.csv"));
        write_timeseries(&p, &r.ts).expect("write record");
        files.push(p);
    }
    let files_s: Vec<&str> = files.iter().map(|p| s(p)).collect();
    // mtwin's own H1 of the same records (the FRF the twin is made from)
    let h1_path = dir.path().join("h1.csv");
    let mut args = vec!["frf"];
    args.extend(&files_s);
    args.extend(["--out", s(&h1_path)]);
    let o = mtwin(&args);
    let mtwin_h1 = if o.status.success() {
        read_frf_csv(&h1_path).ok()
    } else {
        None
    };
    // the twin, defaults only
    let twin_path = dir.path().join("twin.json");
    let mut args = vec!["identify"];
    args.extend(&files_s);
    args.extend(["--out", s(&twin_path)]);
    let o = mtwin(&args);
    if !o.status.success() {
        res.error = Some(format!("identify failed: {}", stderr(&o).trim()));
        res.seconds = t0.elapsed().as_secs_f64();
        keep(c, &dir);
        return res;
    }
    if let Ok(twin) = Twin::load(&twin_path) {
        let p = &twin.poses[0];
        res.twin_modes = p.model.modes.len().to_string();
        res.twin_band = format!("{:.0}-{:.0}", p.band_hz[0], p.band_hz[1]);
        if let Some(plan) = &p.plan {
            // the estimate's kind, short: "impact", "impact+exp" (exponential window),
            // "chirp", "welch"
            let e = plan.excitation.to_lowercase();
            res.twin_excitation = if e.contains("impact") {
                if e.contains("exponential") {
                    "impact+exp".into()
                } else {
                    "impact".into()
                }
            } else if e.contains("chirp") || e.contains("sweep") {
                "chirp".into()
            } else if e.contains("welch") {
                "welch".into()
            } else {
                plan.excitation.chars().take(12).collect()
            };
            res.warnings = plan.quality_warnings.len();
        }
    }
    // the twin's receptance on a grid fine enough for the sharpest peak (≥ 6 lines in
    // its half-power band)
    let sharpest = m
        .modes
        .iter()
        .map(|v| v.zeta * v.f_hz)
        .fold(f64::INFINITY, f64::min);
    let df = (sharpest / 3.0).clamp(0.02, 0.5);
    let grid: Vec<f64> = (0..)
        .map(|k| band.0 + k as f64 * df)
        .take_while(|f| *f <= band.1)
        .collect();
    let mut text = String::new();
    for f in &grid {
        let _ = writeln!(text, "{f}");
    }
    let freqs_path = dir.path().join("freqs.txt");
    std::fs::write(&freqs_path, text).expect("freqs file");
    let eval_path = dir.path().join("twin_frf.csv");
    let o = mtwin(&[
        "eval",
        "--twin",
        s(&twin_path),
        "--at",
        "0,0,0",
        "--freqs",
        s(&freqs_path),
        "--out",
        s(&eval_path),
    ]);
    if !o.status.success() {
        res.error = Some(format!("eval failed: {}", stderr(&o).trim()));
        res.seconds = t0.elapsed().as_secs_f64();
        keep(c, &dir);
        return res;
    }
    let twin_frf = read_frf_csv(&eval_path).expect("twin FRF");
    for (axis, rec) in &recs {
        for out in [Axis::X, Axis::Y] {
            let ch = Channel::new(out, *axis);
            let direct = Channel::new(*axis, *axis);
            let norm_ch = if out == *axis || c.cross == Cross::Coupled {
                ch
            } else {
                direct
            };
            // a channel the twin left out is a zero receptance
            let twin_lines = channel_lines(&twin_frf, ch).unwrap_or_else(|| {
                grid.iter()
                    .map(|&f| (f, Complex64::new(0.0, 0.0)))
                    .collect()
            });
            let twin_fit = fit(&truth, ch, norm_ch, &twin_lines, band);
            let mut plain: Vec<(String, f64)> = plain_estimates(c, rec, *axis, out)
                .into_iter()
                .map(|(name, lines)| (name.to_string(), fit(&truth, ch, norm_ch, &lines, band)))
                .collect();
            if let Some(l) = mtwin_h1.as_ref().and_then(|h| channel_lines(h, ch)) {
                plain.push(("mtwin frf".into(), fit(&truth, ch, norm_ch, &l, band)));
            }
            let mut best = (f64::NEG_INFINITY, String::from("none"));
            for (name, v) in &plain {
                if *v > best.0 {
                    best = (*v, name.clone());
                }
            }
            res.channels.push(ChannelResult {
                ch,
                worst_octave: worst_octave(&truth, ch, &twin_lines, band),
                twin: twin_fit,
                reference: best.0,
                reference_from: best.1,
                plain,
                threshold: CLEAN_TARGET.min(best.0 - MARGIN),
            });
        }
    }
    res.seconds = t0.elapsed().as_secs_f64();
    keep(c, &dir);
    res
}

/// With `MTWIN_ROBUSTNESS_KEEP=DIR` the cell's files (records, H1, twin, FRFs) are
/// copied to `DIR/<cell>/` for a rerun by hand.
fn keep(c: &Cell, dir: &tempfile::TempDir) {
    let Ok(root) = std::env::var("MTWIN_ROBUSTNESS_KEEP") else {
        return;
    };
    let name: String = c
        .name
        .chars()
        .map(|ch| if ch.is_ascii_alphanumeric() { ch } else { '_' })
        .collect();
    let to = std::path::Path::new(&root).join(name);
    std::fs::create_dir_all(&to).expect("keep dir");
    for e in std::fs::read_dir(dir.path()).expect("cell dir").flatten() {
        let _ = std::fs::copy(e.path(), to.join(e.file_name()));
    }
}

#[test]
fn robustness_matrix_defaults_only_fit_the_truth() {
    let t0 = Instant::now();
    // `MTWIN_ROBUSTNESS_ONLY=text` runs only the cells whose name contains it
    let only = std::env::var("MTWIN_ROBUSTNESS_ONLY").unwrap_or_default();
    let cells: Vec<Cell> = cells()
        .into_iter()
        .filter(|c| c.name.contains(only.as_str()))
        .collect();
    let results: Vec<CellResult> = cells
        .par_iter()
        .map(|c| {
            let r = run_cell(c);
            eprintln!(
                "done: {:<26} {:>5.1} s {}",
                c.name,
                r.seconds,
                if r.pass() { "pass" } else { "FAIL" }
            );
            r
        })
        .collect();
    let mut table = String::new();
    let _ = writeln!(
        table,
        "{:<26} {:<9} {:>5} {:>5} {:>6} {:>6} {:>11} | {:<10} {:>9} {:>5} | {:>3} {:>8} {:>8} {:<9} {:>7} {:>6} {:>4}  {:<28} plain estimates vs truth [%]",
        "cell", "excite", "zeta", "noise", "fs", "modes", "band Hz", "twin exc", "twin band", "twin", "ch", "twin %", "ref %", "ref from", "thr %", "err@Hz", "%", "result"
    );
    let mut failures = Vec::new();
    let mut known = Vec::new();
    for r in &results {
        let c = &r.cell;
        let head = format!(
            "{:<26} {:<9} {:>5.3} {:>5.3} {:>6.0} {:>6} {:>11} | {:<10} {:>9} {:>5}",
            c.name,
            format!("{:?}", c.kind),
            c.zeta,
            c.noise,
            c.fs,
            r.truth_modes,
            format!("{:.0}-{:.0}", r.band.0, r.band.1),
            r.twin_excitation,
            r.twin_band,
            r.twin_modes,
        );
        let verdict = |ok: bool| match (ok, c.known_failure) {
            (true, false) => "pass",
            (true, true) => "pass (flagged known_failure)",
            (false, true) => "KNOWN FAIL",
            (false, false) => "FAIL",
        };
        if let Some(e) = &r.error {
            let _ = writeln!(table, "{head} | {}: {e}", verdict(false));
        }
        for ch in &r.channels {
            let _ = writeln!(
                table,
                "{head} | {:>3} {:>8.2} {:>8.2} {:<9} {:>7.2} {:>6.0} {:>4.0}  {:<28} {}",
                ch.ch.to_string(),
                ch.twin,
                ch.reference,
                ch.reference_from,
                ch.threshold,
                ch.worst_octave.0,
                ch.worst_octave.1,
                verdict(ch.pass()),
                ch.plain
                    .iter()
                    .map(|(n, v)| format!("{n} {v:.2}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        if !r.pass() {
            let what: Vec<String> = r
                .channels
                .iter()
                .filter(|ch| !ch.pass())
                .map(|ch| {
                    if ch.reference < UNJUDGEABLE {
                        format!(
                            "{}: no plain estimate reaches {UNJUDGEABLE} % ({:.2} %): the cell cannot judge",
                            ch.ch, ch.reference
                        )
                    } else {
                        format!(
                            "{} {:.2} % < {:.2} % (short by {:.2}; {:.0} % of the error in {:.0}-{:.0} Hz)",
                            ch.ch,
                            ch.twin,
                            ch.threshold,
                            ch.threshold - ch.twin,
                            ch.worst_octave.1,
                            ch.worst_octave.0,
                            2.0 * ch.worst_octave.0
                        )
                    }
                })
                .chain(r.error.clone())
                .collect();
            let line = format!(
                "{} (twin: {} excitation, band {}, {} modes of {}, {} warnings): {}",
                c.name,
                r.twin_excitation,
                r.twin_band,
                r.twin_modes,
                r.truth_modes,
                r.warnings,
                what.join("; ")
            );
            if c.known_failure {
                known.push(line);
            } else {
                failures.push(line);
            }
        }
    }
    eprintln!("\n{table}");
    eprintln!(
        "{} cells in {:.1} s; known failures: {}",
        results.len(),
        t0.elapsed().as_secs_f64(),
        known.len()
    );
    for k in &known {
        eprintln!("KNOWN FAIL {k}");
    }
    assert!(
        failures.is_empty(),
        "{} of {} cells fail:\n{}",
        failures.len(),
        results.len(),
        failures.join("\n")
    );
}
