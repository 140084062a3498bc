//! FRF estimation from force and response time series (paper section 2.1; what MATLAB's
//! `modalfrf` does, with the corrections a modal analyst would add).
//!
//! [`estimate_frf`] turns records ([`TimeSeries`]) into a receptance [`Frf`] with
//! coherence:
//!
//! * **Input direction.** Per record, the force axes whose RMS is at least 30 % of the
//!   strongest one are the inputs. One input: channels (each response axis, that force
//!   axis). Several inputs (continuous excitation only): MIMO H1, `H = Gyf Gff⁻¹`, with
//!   multiple coherence; impact records with force on two axes are dropped (an oblique
//!   hit cannot be split into two inputs). Records with the same inputs are averaged
//!   together (their cross spectra accumulate).
//! * **Estimators** ([`Estimator`]): with `F`, `Y` the DFTs of force and response,
//!   `Gff = Σ F̄F`, `Gfy = Σ F̄Y`, `Gyy = Σ ȲY`:
//!   H1 = Gfy / Gff (noise on the response), H2 = Gyy / Gyf (noise on the force),
//!   Hv = total least squares per line (smallest eigenvector of the 2×2 spectral
//!   matrix). Coherence γ² = |Gfy|² / (Gff Gyy).
//! * **Units.** Acceleration spectra become receptance by dividing by `(jω + σ)²`
//!   (σ = exponential-window decay, 0 otherwise); displacement is used directly. The
//!   output is receptance \[m/N\] on lines `k fs / nfft`, `k ≥ 1` (0 Hz and the Nyquist
//!   line are excluded).
//! * **Excitation** ([`Excitation`]): `Auto` calls a record an impact test when fewer
//!   than 2 % of its force samples exceed 20 % of the force peak, else continuous.
//!   - *Impact*: hits are upward crossings of 20 % of the largest force peak, at least
//!     [`ImpactOptions::min_spacing_s`] apart. Each hit gives one record from a short
//!     pre-trigger to the next hit's pre-trigger (or the end). The force gets a force
//!     window (pulse kept, cosine taper of one pulse width after it, zero after).
//!     When the response has not decayed to 1 % of its peak (or into its pre-trigger
//!     noise) by the end of the record,
//!     both signals get the same exponential window `e^{-σ t}`, with σ chosen so that
//!     the response ends near 1 % of its peak; the estimate then equals `H(s + σ)`
//!     (every pole moved left by σ: add `σ / ωₙ` to a mode's damping ratio to undo it),
//!     reported in [`FrfEstimate::exp_window_sigma`]. Overloads (three or more
//!     consecutive samples at the extreme value of the force or a response) are
//!     dropped with a warning. Double hits (a second pulse above 10 % of the hit's peak
//!     after the pulse ended) are dropped too, unless fewer than three clean hits along
//!     their force axis would remain: then they are kept with a force window over every
//!     pulse (a warning says so), since one average leaves no coherence to judge the
//!     channels and the band by. H1 is averaged over the good hits; common record length
//!     = the shortest hit record (or `nfft`, zero padding when longer).
//!   - *Continuous* (noise, shaker, operating data): Welch, periodic Hann window,
//!     50 % overlap; segments are streamed (one segment in memory at a time), and a
//!     record too long to hold is streamed from its file by
//!     [`estimate_frf_streamed`] (module `stream`: same numbers, `O(nfft)` memory). `nfft`
//!     rule: the largest power of two up to 2¹⁶ that still gives at least
//!     [`FrfOptions::min_averages`] (8) segments over all records of the estimate. With
//!     8 averages the random error of H1 at γ² = 0.9 is about 12 %; 2¹⁶ lines give the
//!     resolution a 1 %-damped mode needs (half-power bandwidth 0.02 f ≥ 4 lines) down
//!     to f ≈ 200 fs / 2¹⁶.
//!   - *Chirp* (deterministic excitation whose response is inside the record: single
//!     sweep that dies out, or periodic chirp with an integer number of periods):
//!     rectangular window, no leakage, no bias. Without `nfft`: one DFT of the whole
//!     record (all records cut to the shortest). With `nfft` = the period length:
//!     non-overlapping periods, averaged (coherence becomes meaningful).
//!
//! Plan once, run many: each thread keeps the real-FFT plans and Hann windows of the last
//! few DFT lengths up to 2^20 points (a campaign estimates many records of one length),
//! the spectra are transformed straight into reused buffers and accumulated line by line
//! per channel pair, and the impact/continuous decision looks at the same systematic
//! subsample of a long force as a streamed read does.
//!
//! On several cores (rayon) a Welch estimate in memory windows and transforms one
//! segment per thread at a time and adds their spectra in chunks of lines, each line
//! summed in segment order: the result is the same bit for bit on any number of threads
//! and equals the streamed estimate, which takes one segment at a time.
//!
//! ```
//! use identify::spectra::{estimate_frf, FrfOptions, Excitation};
//! use identify::timeseries::{TimeSeries, ResponseKind};
//! // A pure gain of 2e-6 m/N under pseudo-random force.
//! let n = 4096;
//! let f: Vec<f64> = (0..n).map(|i| ((i * 7919 % 1013) as f64 / 1013.0) - 0.5).collect();
//! let d: Vec<f64> = f.iter().map(|v| 2e-6 * v).collect();
//! let mut ts = TimeSeries { dt: 1e-3, response_kind: Some(ResponseKind::Displacement), ..Default::default() };
//! ts.force[0] = Some(f);
//! ts.response[0] = Some(d);
//! let opts = FrfOptions { excitation: Excitation::Continuous, ..Default::default() };
//! let est = estimate_frf(&[ts], &opts).unwrap();
//! let h = &est.frf.channels[0].h;
//! assert!(h.iter().all(|z| (z.re - 2e-6).abs() < 1e-12 && z.im.abs() < 1e-12));
//! ```

use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::frf::{Frf, FrfChannel};
use crate::timeseries::{ResponseKind, TimeSeries};
use num_complex::Complex64;
use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::f64::consts::PI;
use std::sync::Arc;

/// Which FRF estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Estimator {
    /// `Gfy / Gff`: unbiased by noise on the response (the usual choice).
    #[default]
    H1,
    /// `Gyy / Gyf`: unbiased by noise on the force; better at resonances.
    H2,
    /// Total least squares per line (noise on both); lies between H1 and H2.
    Hv,
}

/// What kind of excitation the records contain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Excitation {
    /// Impact when the force is a few short pulses, else continuous (see module docs).
    #[default]
    Auto,
    /// Impact hammer / impulse device: hit detection, force and exponential windows.
    Impact,
    /// Random, shaker or operating forces: Welch averaging with a Hann window.
    Continuous,
    /// Deterministic chirp inside the record: rectangular-window DFT ratio.
    Chirp,
}

/// Settings of the impact processing.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpactOptions {
    /// Hit threshold relative to the largest force peak of the record (default 0.2).
    pub trigger_fraction: f64,
    /// Minimum time between two hits (s, default 0.05); closer pulses are double hits.
    pub min_spacing_s: f64,
    /// Pre-trigger kept before each hit (s, default 1 ms, at least 4 samples).
    pub pretrigger_s: f64,
    /// A later pulse above this fraction of the hit's peak is a double hit (default 0.1).
    pub double_hit_fraction: f64,
    /// Response level at the record end, relative to its peak, that the exponential
    /// window aims at (default 0.01).
    pub end_level: f64,
    /// Exponential window decay σ [1/s]: `None` = automatic, `Some(0.0)` = never.
    pub exp_window_sigma: Option<f64>,
    /// Given when hits ring into the next: each hit's record then loses the free decay
    /// of the hits before it and gains its own decay past the next hit, both fitted over
    /// a first fit's poles to the record's own free decays (`spectra/ringing.rs`).
    /// `None` (the default): records as measured.
    pub separation: Option<HitSeparation>,
}

impl Default for ImpactOptions {
    fn default() -> Self {
        ImpactOptions {
            trigger_fraction: 0.2,
            min_spacing_s: 0.05,
            pretrigger_s: 1e-3,
            double_hit_fraction: 0.1,
            end_level: 0.01,
            exp_window_sigma: None,
            separation: None,
        }
    }
}

/// Options of [`estimate_frf`].
#[derive(Debug, Clone, PartialEq)]
pub struct FrfOptions {
    /// Estimator (H1 by default).
    pub estimator: Estimator,
    /// Excitation type (automatic by default).
    pub excitation: Excitation,
    /// DFT length: Welch segment, chirp period, or impact record length. `None` = rule
    /// of the module docs.
    pub nfft: Option<usize>,
    /// Highest frequency kept (Hz); `None` = up to (excluding) Nyquist.
    pub fmax_hz: Option<f64>,
    /// Welch overlap fraction (default 0.5).
    pub overlap: f64,
    /// Minimum number of Welch averages the automatic `nfft` aims at (default 8).
    pub min_averages: usize,
    /// Impact processing settings.
    pub impact: ImpactOptions,
}

impl Default for FrfOptions {
    fn default() -> Self {
        FrfOptions {
            estimator: Estimator::H1,
            excitation: Excitation::Auto,
            nfft: None,
            fmax_hz: None,
            overlap: 0.5,
            min_averages: 8,
            impact: ImpactOptions::default(),
        }
    }
}

/// Result of [`estimate_frf`].
#[derive(Debug, Clone, PartialEq)]
pub struct FrfEstimate {
    /// Receptance \[m/N\] with coherence, 0 Hz excluded.
    pub frf: Frf,
    /// Things the user should know (dropped records, low coherence, few averages).
    pub warnings: Vec<String>,
    /// Number of averages used (hits for impacts, segments for Welch and chirp).
    pub hits_used: usize,
    /// Averages behind each channel's estimate, the fewest over the channels: a channel's
    /// H1 comes from the records of its own force direction only (an x hammer test of 5
    /// hits and a y one of 5: `hits_used` 10, each channel 5). What its coherence's
    /// variance and noise-only level are computed with.
    pub averages_per_channel: usize,
    /// One line per dropped hit or record, with the reason.
    pub hits_dropped: Vec<String>,
    /// Decay \[1/s\] of the exponential window, when one was applied: the estimate equals
    /// `H(s + σ)`, i.e. every pole is shifted left by σ (damping ratio up by σ / ωₙ).
    pub exp_window_sigma: Option<f64>,
    /// Human description of what was done.
    pub method: String,
    /// Frequency resolution (Hz).
    pub df_hz: f64,
    /// Impacts: the length \[s\] of each hit's record (the DFT length), the time a hit's
    /// response has to decay before the next one. `None` for other excitations.
    pub hit_record_s: Option<f64>,
    /// Band `(lo, hi)` in Hz where the force auto-spectrum is within 20 dB of its peak
    /// (the contiguous range around the peak; intersection over the input groups): the
    /// lines outside it are poorly excited. `None` when undefined (no force).
    pub excitation_band_hz: Option<(f64, f64)>,
    /// When the coherence comes from the FRF's line-to-line scatter (a single chirp
    /// record, [`scatter_coherence`]) instead of averages: the number of lines each
    /// estimate spans, which sets the level pure noise reaches. `None` otherwise.
    pub coherence_dof: Option<usize>,
}

/// Force axes whose RMS is at least this fraction of the strongest are inputs.
const INPUT_RMS_FRACTION: f64 = 0.3;
/// Relative tolerance on equal sample rates between records.
const FS_TOLERANCE: f64 = 1e-3;

/// Estimates receptance FRFs with coherence from one or more records (module docs).
pub fn estimate_frf(records: &[TimeSeries], opts: &FrfOptions) -> Result<FrfEstimate> {
    if records.is_empty() {
        return Err(Error::BadInput(
            "no records given for the FRF estimate".into(),
        ));
    }
    let dt = records[0].dt;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::BadInput(format!(
            "{}: invalid sample period {dt}",
            records[0].source
        )));
    }
    let mut stats = Vec::with_capacity(records.len());
    for r in records {
        if ((r.dt - dt) / dt).abs() > FS_TOLERANCE {
            return Err(Error::BadInput(format!(
                "{} is sampled at {:.6} Hz but {} at {:.6} Hz; estimate records with different sample rates separately (or resample)",
                r.source,
                r.fs(),
                records[0].source,
                1.0 / dt
            )));
        }
        let n = r.len();
        let mut forces: [Option<ForceStats>; 3] = Default::default();
        for (what, col) in r
            .force
            .iter()
            .map(|c| ("force", c))
            .chain(r.response.iter().map(|c| ("response", c)))
        {
            if let Some(v) = col {
                if v.len() != n {
                    return Err(Error::BadInput(format!(
                        "{}: a {what} column has {} samples, another {n}; all columns of a record must have the same length",
                        r.source,
                        v.len()
                    )));
                }
            }
        }
        // each force column read once here: finite, mean, RMS, extremes, subsample
        for (col, st) in r.force.iter().zip(&mut forces) {
            if let Some(v) = col {
                let s = ForceStats::new(v);
                if !s.finite {
                    return Err(not_finite(r, "force", v));
                }
                *st = Some(s);
            }
        }
        check_responses(&r.source, r.response_kind, &r.response_axes())?;
        stats.push(forces);
    }
    check_options(opts)?;

    let infos: Vec<RecordInfo> = (records.iter().zip(stats))
        .map(|(r, s)| RecordInfo::new(r, s))
        .collect::<Result<_>>()?;
    let excitation = resolve_excitation(opts.excitation, &infos)?;
    if excitation != Excitation::Continuous {
        // (the Welch path checks the responses while it windows them)
        for r in records {
            for v in r.response.iter().flatten() {
                check_finite(r, "response", v)?;
            }
        }
    }
    let mut ctx = Ctx::new(dt, opts);
    match excitation {
        Excitation::Impact => impact::estimate(records, &infos, &mut ctx),
        Excitation::Continuous => on_worker(|| continuous(records, &infos, &mut ctx)),
        _ => chirp(records, &infos, &mut ctx),
    }
}

/// The error for the first sample of `v` (a `what` column of `r`) that is NaN or
/// infinite.
fn not_finite(r: &TimeSeries, what: &str, v: &[f64]) -> Error {
    let i = v.iter().position(|x| !x.is_finite()).unwrap_or(0);
    Error::BadInput(format!(
        "{}: {what} sample {i} is not finite; remove NaN/Inf from the record",
        r.source
    ))
}

/// Fails with [`not_finite`] when a sample of `v` is NaN or infinite.
fn check_finite(r: &TimeSeries, what: &str, v: &[f64]) -> Result<()> {
    // x·0 is NaN exactly for NaN and ±Inf: one vectorised pass, then the position
    if sum4(v, |x| x * 0.0) != 0.0 {
        return Err(not_finite(r, what, v));
    }
    Ok(())
}

/// Response columns must exist and have a kind.
fn check_responses(source: &str, kind: Option<ResponseKind>, axes: &[Axis]) -> Result<()> {
    if kind.is_none() && !axes.is_empty() {
        return Err(Error::BadInput(format!(
            "{source}: response columns without a kind; set response_kind (acceleration or displacement)"
        )));
    }
    if axes.is_empty() {
        return Err(Error::BadInput(format!(
            "{source} has no response column; an FRF needs ax/ay/az or dx/dy/dz"
        )));
    }
    Ok(())
}

/// Overlap and DFT length in range.
fn check_options(opts: &FrfOptions) -> Result<()> {
    if !(0.0..0.95).contains(&opts.overlap) {
        return Err(Error::BadInput(format!(
            "overlap {} must be in [0, 0.95)",
            opts.overlap
        )));
    }
    if let Some(n) = opts.nfft {
        if n < 8 {
            return Err(Error::BadInput(format!(
                "nfft {n} is too small (at least 8)"
            )));
        }
    }
    Ok(())
}

/// The excitation of the records: `Auto` becomes impact or continuous (module docs).
fn resolve_excitation(requested: Excitation, infos: &[RecordInfo]) -> Result<Excitation> {
    Ok(match requested {
        Excitation::Auto => {
            if infos.iter().all(|i| i.impulsive) {
                Excitation::Impact
            } else if infos.iter().all(|i| i.sweep) {
                Excitation::Chirp
            } else if infos.iter().all(|i| !i.impulsive) {
                Excitation::Continuous
            } else {
                return Err(Error::BadInput(
                    "some records look like impact tests and others like continuous excitation; estimate them separately or choose the excitation explicitly".into(),
                ));
            }
        }
        e => e,
    })
}

/// Per-record facts used by every path.
struct RecordInfo {
    inputs: Vec<Axis>,
    strongest: Axis,
    impulsive: bool,
    /// The force is a sweep (its dominant frequency moves monotonically over the record).
    sweep: bool,
    outputs: Vec<Axis>,
}

impl RecordInfo {
    /// From the record and the [`ForceStats`] of its force columns (by axis).
    fn new(r: &TimeSeries, mut stats: [Option<ForceStats>; 3]) -> Result<Self> {
        let rms = stats.each_ref().map(|s| s.as_ref().map_or(0.0, |s| s.rms));
        let mut info = Self::from_stats(&r.source, rms, r.response_axes(), |a| {
            stats[a.index()]
                .as_mut()
                .is_some_and(|s| impulsive(&mut s.subsample, (s.min, s.max)))
        });
        if let Ok(i) = &mut info {
            i.sweep = !i.impulsive
                && (r.force(i.strongest))
                    .zip(stats[i.strongest.index()].as_ref())
                    .is_some_and(|(f, s)| is_sweep(f, &s.parts));
        }
        info
    }

    /// From per-axis force RMS values (0 = no column), the response axes and a test of
    /// the strongest force axis for impulsiveness.
    fn from_stats(
        source: &str,
        rms: [f64; 3],
        outputs: Vec<Axis>,
        impulsive_along: impl FnOnce(Axis) -> bool,
    ) -> Result<Self> {
        let max = rms.iter().cloned().fold(0.0, f64::max);
        if max <= 0.0 {
            return Err(Error::BadInput(format!(
                "{source}: the force is zero (or constant) in every column; nothing excites the structure"
            )));
        }
        let strongest = Axis::ALL
            .into_iter()
            .find(|a| rms[a.index()] == max)
            .unwrap_or(Axis::X);
        let inputs = Axis::ALL
            .into_iter()
            .filter(|a| rms[a.index()] >= INPUT_RMS_FRACTION * max)
            .collect();
        Ok(RecordInfo {
            inputs,
            strongest,
            impulsive: impulsive_along(strongest),
            sweep: false,
            outputs,
        })
    }
}

/// `Σ g(v_i)` in interleaved partial sums, added as [`crate::lanes::sum`] adds them.
fn sum4(v: &[f64], g: impl Fn(f64) -> f64) -> f64 {
    const L: usize = crate::lanes::LANES;
    let mut acc = [0.0f64; L];
    let chunks = v.chunks_exact(L);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..L {
            acc[l] += g(c[l]);
        }
    }
    for &x in rest {
        acc[0] += g(x);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// What every path needs of a force column, from one pass over it: whether it is
/// finite, its mean, RMS and extremes, the systematic subsample a streamed read keeps
/// ([`ColumnStats::subsample`](crate::read::ColumnStats::subsample), stride
/// [`subsample_stride`](crate::read::subsample_stride); a record in memory and the same
/// file streamed are judged alike) and the mean and RMS of each of the
/// [`SWEEP_SEGMENTS`] parts [`is_sweep`] looks at.
struct ForceStats {
    /// False when a sample is NaN or infinite (the other fields are then meaningless).
    finite: bool,
    rms: f64,
    min: f64,
    max: f64,
    subsample: Vec<f64>,
    /// `(start, len, mean, rms)` of each sweep part (none when the parts would be
    /// shorter than 64 samples).
    parts: Vec<(usize, usize, f64, f64)>,
}

/// Samples per block of [`ForceStats::new`]'s pass (a block stays in the L1 cache while
/// its subsample is picked).
const STATS_BLOCK: usize = 4096;

impl ForceStats {
    fn new(f: &[f64]) -> Self {
        let len = f.len();
        let part = (len / SWEEP_SEGMENTS) & !1;
        // the sweep parts, then what is left after them, as pieces of the one pass
        let mut pieces: Vec<(usize, usize)> = if len / SWEEP_SEGMENTS >= 64 {
            (0..SWEEP_SEGMENTS).map(|s| (s * part, part)).collect()
        } else {
            Vec::new()
        };
        let covered = pieces.len() * part;
        if covered < len {
            pieces.push((covered, len - covered));
        }
        let stride = crate::read::subsample_stride(len);
        let mut subsample = Vec::with_capacity(len.div_ceil(stride));
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        // per piece: its shift c (first sample), Σ(v - c), Σ(v - c)², length
        let mut sums = Vec::with_capacity(pieces.len());
        for &(start, n) in &pieces {
            let x = &f[start..start + n];
            let c = x[0];
            let (mut s1, mut s2) = (0.0, 0.0);
            for (b, block) in x.chunks(STATS_BLOCK).enumerate() {
                let [d, q, l, h] = shifted_sums(block, c);
                (s1, s2, lo, hi) = (s1 + d, s2 + q, lo.min(l), hi.max(h));
                let first = start + b * STATS_BLOCK;
                let skip = (stride - first % stride) % stride;
                let picked = block.get(skip..).unwrap_or(&[]).iter().step_by(stride);
                subsample.extend(picked.copied());
            }
            sums.push((c, s1, s2, n as f64));
        }
        let finite = sums
            .iter()
            .all(|&(_, s1, s2, _)| s1.is_finite() && s2.is_finite())
            || f.iter().all(|x| x.is_finite()); // sums overflowed, samples fine
        let total = len.max(1) as f64;
        let mean = sums.iter().map(|&(c, s1, _, n)| s1 + n * c).sum::<f64>() / total;
        // Σ(v - m)² of a piece from its shifted sums: S2 - 2 (m - c) S1 + n (m - c)²
        let centred = |m: f64, &(c, s1, s2, n): &(f64, f64, f64, f64)| {
            let d = m - c;
            (s2 - 2.0 * d * s1 + n * d * d).max(0.0)
        };
        let rms = (sums.iter().map(|p| centred(mean, p)).sum::<f64>() / total).sqrt();
        let parts = (pieces.iter().zip(&sums))
            .take(if len / SWEEP_SEGMENTS >= 64 {
                SWEEP_SEGMENTS
            } else {
                0
            })
            .map(|(&(start, n), p)| {
                let m = p.1 / p.3 + p.0;
                (start, n, m, (centred(m, p) / p.3).sqrt())
            })
            .collect();
        ForceStats {
            finite,
            rms,
            min: lo,
            max: hi,
            subsample,
            parts,
        }
    }
}

/// `[Σ(v - c), Σ(v - c)², min v, max v]` in [`crate::lanes::LANES`] interleaved partial
/// sums and running extremes.
fn shifted_sums(v: &[f64], c: f64) -> [f64; 4] {
    const L: usize = crate::lanes::LANES;
    let (mut s1, mut s2) = ([0.0f64; L], [0.0f64; L]);
    let (mut lo, mut hi) = ([f64::INFINITY; L], [f64::NEG_INFINITY; L]);
    let chunks = v.chunks_exact(L);
    let rest = chunks.remainder();
    for x in chunks {
        for l in 0..L {
            let d = x[l] - c;
            s1[l] += d;
            s2[l] += d * d;
            lo[l] = if x[l] < lo[l] { x[l] } else { lo[l] };
            hi[l] = if x[l] > hi[l] { x[l] } else { hi[l] };
        }
    }
    for &x in rest {
        let d = x - c;
        s1[0] += d;
        s2[0] += d * d;
        lo[0] = if x < lo[0] { x } else { lo[0] };
        hi[0] = if x > hi[0] { x } else { hi[0] };
    }
    [
        (s1[0] + s1[1]) + (s1[2] + s1[3]),
        (s2[0] + s2[1]) + (s2[2] + s2[3]),
        lo.into_iter().fold(f64::INFINITY, f64::min),
        hi.into_iter().fold(f64::NEG_INFINITY, f64::max),
    ]
}

/// True when fewer than 2 % of `samples` deviate from their median by more than 20 % of
/// the largest deviation, which is taken from the extremes `(min, max)` of the whole
/// force (`samples` may be a subsample of it).
fn impulsive(samples: &mut [f64], (lo, hi): (f64, f64)) -> bool {
    let base = median_in_place(samples);
    let peak = (hi - base).abs().max((lo - base).abs());
    let above = samples
        .iter()
        .filter(|v| (*v - base).abs() > 0.2 * peak)
        .count();
    (above as f64) < 0.02 * samples.len() as f64
}

/// Longest window (samples) of a part whose dominant line [`is_sweep`] takes.
const SWEEP_WINDOW: usize = 8192;

/// Segments the force is cut into to follow its dominant frequency.
const SWEEP_SEGMENTS: usize = 16;

/// True when the force is a sweep (linear, logarithmic or stepped sine): over
/// [`SWEEP_SEGMENTS`] equal parts of the record, the parts carrying force (RMS at least
/// 10 % of the strongest part's, at least 6 of them) have a dominant frequency (over the
/// middle [`SWEEP_WINDOW`] samples of the part at most) that only rises or only falls,
/// over a span of at least a factor 4. Random force has no steady dominant frequency,
/// milling's stays put; for a sweep the rectangular-window full-record ratio is unbiased
/// where Welch's Hann segments smear the moving line.
///
/// `stats`: `(start, len, mean, rms)` of each part ([`ForceStats::parts`]; none: not a
/// sweep).
fn is_sweep(f: &[f64], stats: &[(usize, usize, f64, f64)]) -> bool {
    let Some(&(_, len, _, _)) = stats.first() else {
        return false;
    };
    // the dominant line of a part from its middle SWEEP_WINDOW samples at most: a moving
    // line is as clear in a short window as in a long one (it crosses fewer lines there),
    // and case a of the peers' benchmark spent 3.5 % of its estimate on three transforms
    // of 24 000 points here
    let n = len.min(SWEEP_WINDOW);
    let parts: Vec<&[f64]> = (stats.iter())
        .map(|&(s, len, _, _)| &f[s + (len - n) / 2..][..n])
        .collect();
    let means: Vec<f64> = stats.iter().map(|p| p.2).collect();
    let rms: Vec<f64> = stats.iter().map(|p| p.3).collect();
    is_sweep_windows(&parts, &means, &rms)
}

/// Where [`is_sweep`] decides: the middle window of each of the [`SWEEP_SEGMENTS`] parts
/// (all of one length), with the mean and RMS of the whole part. A streamed record
/// ([`stream`]) keeps only these windows.
fn is_sweep_windows(parts: &[&[f64]], means: &[f64], rms: &[f64]) -> bool {
    let Some(n) = parts.first().map(|p| p.len()).filter(|&n| n > 0) else {
        return false;
    };
    if parts.iter().any(|p| p.len() != n) {
        return false;
    }
    let top = rms.iter().copied().fold(0.0, f64::max);
    let carrying: Vec<usize> = (0..parts.len()).filter(|&s| rms[s] >= 0.1 * top).collect();
    if carrying.len() < 6 {
        return false;
    }
    // the dominant line of each part carrying force, in order; random force fails the
    // monotony after a few parts, so the transforms stop there
    let r2c = plan(n);
    let (mut buf, mut out, mut scratch) = (
        r2c.make_input_vec(),
        r2c.make_output_vec(),
        r2c.make_scratch_vec(),
    );
    let (mut up, mut down) = (true, true);
    let (mut lo, mut hi, mut last) = (usize::MAX, 0, None);
    for s in carrying {
        let m = means[s];
        for (b, &v) in buf.iter_mut().zip(parts[s]) {
            *b = v - m;
        }
        if r2c
            .process_with_scratch(&mut buf, &mut out, &mut scratch)
            .is_err()
        {
            return false;
        }
        let k = (1..out.len())
            .max_by(|&a, &b| out[a].norm_sqr().total_cmp(&out[b].norm_sqr()))
            .unwrap_or(0);
        if k == 0 {
            return false;
        }
        if let Some(prev) = last {
            up &= k >= prev;
            down &= k <= prev;
            if !(up || down) {
                return false;
            }
        }
        last = Some(k);
        (lo, hi) = (lo.min(k), hi.max(k));
    }
    hi >= 4 * lo
}

/// The median of `v` (the upper one of an even count; 0 when empty).
fn median(v: &[f64]) -> f64 {
    median_in_place(&mut v.to_vec())
}

/// The median of `v` (the upper one of an even count; 0 when empty), reordering `v`.
fn median_in_place(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

struct Ctx<'a> {
    dt: f64,
    opts: &'a FrfOptions,
    warnings: Vec<String>,
    dropped: Vec<String>,
}

impl<'a> Ctx<'a> {
    fn new(dt: f64, opts: &'a FrfOptions) -> Self {
        Ctx {
            dt,
            opts,
            warnings: Vec::new(),
            dropped: Vec::new(),
        }
    }
}

/// DFT lengths whose plan (and Hann window) a thread keeps ([`kept`]).
const PLAN_CACHE: usize = 4;
/// Longest DFT a thread keeps: a chirp record transformed whole (millions of points) is
/// planned for its estimate and dropped with it.
const PLAN_CACHE_MAX_LEN: usize = 1 << 20;

type Plan = Arc<dyn RealToComplex<f64>>;
/// A per-thread cache ([`kept`]): entries by key (a length unless said), most recent last.
type Cache<T, K = usize> = std::cell::RefCell<Vec<(K, T)>>;

thread_local! {
    /// Real-FFT plans of the last [`PLAN_CACHE`] DFT lengths, most recent last.
    static PLANS: Cache<Plan> = const { std::cell::RefCell::new(Vec::new()) };
    /// Inverse real-FFT plans, likewise.
    static INVERSE_PLANS: Cache<Arc<dyn ComplexToReal<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
    /// Periodic Hann windows, likewise.
    static WINDOWS: Cache<Arc<[f64]>> = const { std::cell::RefCell::new(Vec::new()) };
    /// Input and scratch buffers of the Welch transforms ([`Welch::add_segments`]).
    static BUFFERS: std::cell::RefCell<(Vec<f64>, Vec<Complex64>)> = const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// The entry of length `n` of a per-thread cache, made by `make` when missing: a
/// campaign estimates many records of one length, and the twiddle factors and the
/// window of a 65536-point DFT cost about as much as one Welch average.
fn kept<T: Clone>(
    cache: &'static std::thread::LocalKey<Cache<T>>,
    n: usize,
    make: impl FnOnce() -> T,
) -> T {
    kept_by(cache, n, n, make)
}

/// [`kept`] by any key, for an entry of `len` elements (kept up to
/// [`PLAN_CACHE_MAX_LEN`]).
fn kept_by<K: PartialEq + Copy, T: Clone>(
    cache: &'static std::thread::LocalKey<Cache<T, K>>,
    key: K,
    len: usize,
    make: impl FnOnce() -> T,
) -> T {
    if len > PLAN_CACHE_MAX_LEN {
        return make();
    }
    cache.with_borrow_mut(|c| {
        if let Some(i) = c.iter().position(|(m, _)| *m == key) {
            let hit = c.remove(i);
            c.push(hit);
        } else {
            if c.len() == PLAN_CACHE {
                c.remove(0);
            }
            c.push((key, make()));
        }
        c[c.len() - 1].1.clone()
    })
}

/// The forward real-FFT plan of length `n`, kept per thread for the last few lengths: every spectrum in mtwin (Welch,
/// impact, full-record, operating, output error, diagnosis) is planned here, once per
/// length and thread.
pub fn plan(n: usize) -> Plan {
    kept(&PLANS, n, || {
        RealFftPlanner::<f64>::new().plan_fft_forward(n)
    })
}

/// The inverse real-FFT plan of length `n`, kept likewise, beside [`plan`].
pub fn inverse_plan(n: usize) -> Arc<dyn ComplexToReal<f64>> {
    kept(&INVERSE_PLANS, n, || {
        RealFftPlanner::<f64>::new().plan_fft_inverse(n)
    })
}

/// The periodic Hann window of length `n` ([`kept`]).
fn hann_kept(n: usize) -> Arc<[f64]> {
    kept(&WINDOWS, n, || hann(n).into())
}

/// A real-input DFT of fixed length with its buffers (planned once).
struct RealDft {
    plan: Arc<dyn RealToComplex<f64>>,
    buf: Vec<f64>,
    scratch: Vec<Complex64>,
}

impl RealDft {
    fn new(n: usize) -> Self {
        let plan = plan(n);
        RealDft {
            buf: plan.make_input_vec(),
            scratch: plan.make_scratch_vec(),
            plan,
        }
    }

    /// Transforms `self.buf` (filled by the caller) into `dst` ([`transform`]).
    fn run_into(&mut self, dst: &mut Vec<Complex64>, scale: Option<&[Complex64]>) -> Result<()> {
        transform(&*self.plan, &mut self.buf, dst, &mut self.scratch, scale)
    }
}

/// Transforms `buf` (destroyed) into `dst`, the whole half spectrum with line k at index k
/// (the form [`Accumulator::add`] takes), lines `1..=nl` multiplied by `scale[k - 1]` when
/// given.
fn transform(
    plan: &dyn RealToComplex<f64>,
    buf: &mut [f64],
    dst: &mut Vec<Complex64>,
    scratch: &mut [Complex64],
    scale: Option<&[Complex64]>,
) -> Result<()> {
    dst.resize(plan.complex_len(), Complex64::default());
    plan.process_with_scratch(buf, dst, scratch)
        .map_err(|e| Error::Numerical(format!("FFT failed: {e}")))?;
    if let Some(s) = scale {
        for (d, s) in dst[1..=n_lines(plan.len())].iter_mut().zip(s) {
            *d *= s;
        }
    }
    Ok(())
}

/// The half spectra of one segment: every input force and output response, in an
/// accumulator's order.
#[derive(Default)]
struct Spectra {
    fs: Vec<Vec<Complex64>>,
    ys: Vec<Vec<Complex64>>,
}

impl Spectra {
    fn new(inputs: usize, outputs: usize) -> Self {
        Spectra {
            fs: vec![Vec::new(); inputs],
            ys: vec![Vec::new(); outputs],
        }
    }
}

/// Number of lines kept for a DFT of length n: k = 1 .. (n+1)/2 (no DC, no Nyquist).
fn n_lines(n: usize) -> usize {
    n.div_ceil(2) - 1
}

/// Accumulated auto and cross spectra of one input group.
struct Accumulator {
    inputs: Vec<Axis>,
    outputs: Vec<Axis>,
    nl: usize,
    /// `[i][j][k] = Σ conj(F_i) F_j` of several inputs (empty for one input: see
    /// `gff1`)
    gff: Vec<Complex64>,
    /// `[k] = Σ |F|²` of a single input, the real part of `Σ conj(F) F` computed as such
    /// (its imaginary part is zero; the sum in half the memory, empty for several
    /// inputs)
    gff1: Vec<f64>,
    /// `[i][o][k] = Σ conj(F_i) Y_o`
    gfy: Vec<Complex64>,
    /// `[o][k] = Σ |Y_o|²`
    gyy: Vec<f64>,
    averages: usize,
}

/// Sum buffers a thread keeps for its next [`Accumulator`]s (a campaign estimates many
/// records of one length; fresh buffers of a 65536-point estimate cost page faults
/// comparable to an average).
const SUMS_KEPT: usize = 6;

/// The largest sum buffer a thread keeps, in elements.
const SUMS_KEPT_MAX_LEN: usize = 1 << 21;

/// Complex and real sum buffers a thread keeps.
type KeptSums = (Vec<Vec<Complex64>>, Vec<Vec<f64>>);

thread_local! {
    /// Complex and real sum buffers of dropped [`Accumulator`]s, for [`zeroed`].
    static SUMS: std::cell::RefCell<KeptSums> = const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// A buffer of capacity `len` or more this thread kept ([`SUMS_KEPT`]), or a new one.
fn take_kept<T>(pool: &mut Vec<Vec<T>>, len: usize) -> Vec<T> {
    pool.iter()
        .position(|v| v.capacity() >= len)
        .map(|i| pool.swap_remove(i))
        .unwrap_or_default()
}

/// `len` zeros in a buffer this thread kept ([`SUMS_KEPT`]) or a new one.
fn zeroed<T: Copy + Default>(pool: &mut Vec<Vec<T>>, len: usize) -> Vec<T> {
    let mut v = take_kept(pool, len);
    v.clear();
    v.resize(len, T::default());
    v
}

/// `len` elements in a buffer this thread kept ([`SUMS_KEPT`]) or a new one, its old
/// contents left in place (for a caller that writes every element).
fn reused<T: Copy + Default>(pool: &mut Vec<Vec<T>>, len: usize) -> Vec<T> {
    let mut v = take_kept(pool, len);
    v.truncate(len);
    v.resize(len, T::default());
    v
}

/// Gives `v` back to `pool` unless it is full or `v` too large.
fn keep<T>(pool: &mut Vec<Vec<T>>, v: Vec<T>) {
    if pool.len() < SUMS_KEPT && v.capacity() <= SUMS_KEPT_MAX_LEN && v.capacity() > 0 {
        pool.push(v);
    }
}

impl Drop for Accumulator {
    fn drop(&mut self) {
        let (gff, gff1, gfy, gyy) = (
            std::mem::take(&mut self.gff),
            std::mem::take(&mut self.gff1),
            std::mem::take(&mut self.gfy),
            std::mem::take(&mut self.gyy),
        );
        // a thread being torn down keeps nothing
        let _ = SUMS.try_with(|p| {
            let (c, r) = &mut *p.borrow_mut();
            keep(c, gff);
            keep(r, gff1);
            keep(c, gfy);
            keep(r, gyy);
        });
    }
}

impl Accumulator {
    fn new(inputs: Vec<Axis>, outputs: Vec<Axis>, nl: usize) -> Self {
        let (ni, no) = (inputs.len(), outputs.len());
        let single = usize::from(ni == 1);
        let (gff, gff1, gfy, gyy) = SUMS.with_borrow_mut(|(c, r)| {
            (
                zeroed(c, nl * ni * ni * (1 - single)),
                zeroed(r, nl * single),
                zeroed(c, nl * ni * no),
                zeroed(r, nl * no),
            )
        });
        Accumulator {
            gff,
            gff1,
            gfy,
            gyy,
            inputs,
            outputs,
            nl,
            averages: 0,
        }
    }

    /// Adds the input auto and cross spectra `Σ conj(F_i) F_j` of one segment (`fs`:
    /// its input spectra, line k at index k); [`Accumulator::add_output`] adds the rest
    /// of that segment. Each sum gets the same term in the same order as in
    /// [`Accumulator::add`], so both give the same sums bit for bit.
    fn add_inputs(&mut self, fs: &[Vec<Complex64>]) {
        let (ni, nl) = (self.inputs.len(), self.nl);
        for (g, x) in self.gff1.iter_mut().zip(&fs[0][1..]) {
            *g += (x.conj() * x).re;
        }
        for (a, g) in self.gff.chunks_exact_mut(nl.max(1)).enumerate() {
            let (fi, fj) = (&fs[a / ni][1..=nl], &fs[a % ni][1..=nl]);
            for ((g, x), y) in g.iter_mut().zip(fi).zip(fj) {
                *g += x.conj() * y;
            }
        }
    }

    /// Adds output `o`'s sums `Σ conj(F_i) Y_o` and `Σ |Y_o|²` of one segment: `y` its
    /// spectrum (line k at index k), multiplied line by line by `scale` (line k by
    /// `scale[k - 1]`) on the way, `fs` the segment's input spectra. The caller counts
    /// the segment in [`Accumulator::averages`].
    ///
    /// With one input, the first output's pass also adds the force's auto spectrum
    /// (`Σ |F|²`) unless `inputs_added` says [`Accumulator::add_inputs`] did.
    fn add_output(
        &mut self,
        o: usize,
        fs: &[Vec<Complex64>],
        y: &[Complex64],
        scale: Option<&[Complex64]>,
        inputs_added: bool,
    ) {
        let (ni, no, nl) = (self.inputs.len(), self.outputs.len(), self.nl);
        let y = &y[1..=nl];
        let gyy = &mut self.gyy[o * nl..][..nl];
        if ni == 1 && o == 0 && !inputs_added {
            // the common case in one pass over the lines, the force's auto spectrum too
            let (f, gfy, gff) = (&fs[0][1..=nl], &mut self.gfy[..nl], &mut self.gff1[..nl]);
            let lines = gfy.iter_mut().zip(gyy).zip(gff).zip(f).zip(y);
            match scale {
                Some(s) => {
                    for (((((g, q), a), x), &y), s) in lines.zip(s) {
                        let y = y * s;
                        *a += (x.conj() * x).re;
                        *g += x.conj() * y;
                        *q += y.norm_sqr();
                    }
                }
                None => {
                    for ((((g, q), a), x), y) in lines {
                        *a += (x.conj() * x).re;
                        *g += x.conj() * y;
                        *q += y.norm_sqr();
                    }
                }
            }
        } else if ni == 1 {
            // the common case in one pass over the lines
            let (f, gfy) = (&fs[0][1..=nl], &mut self.gfy[o * nl..][..nl]);
            match scale {
                Some(s) => {
                    for ((((g, q), x), &y), s) in gfy.iter_mut().zip(gyy).zip(f).zip(y).zip(s) {
                        let y = y * s;
                        *g += x.conj() * y;
                        *q += y.norm_sqr();
                    }
                }
                None => {
                    for (((g, q), x), y) in gfy.iter_mut().zip(gyy).zip(f).zip(y) {
                        *g += x.conj() * y;
                        *q += y.norm_sqr();
                    }
                }
            }
        } else {
            let scaled: Vec<Complex64>;
            let y = match scale {
                Some(s) => {
                    scaled = y.iter().zip(s).map(|(y, s)| y * s).collect();
                    &scaled[..]
                }
                None => y,
            };
            for (q, y) in gyy.iter_mut().zip(y) {
                *q += y.norm_sqr();
            }
            for (i, f) in fs.iter().enumerate() {
                let g = &mut self.gfy[(i * no + o) * nl..][..nl];
                for ((g, x), y) in g.iter_mut().zip(&f[1..=nl]).zip(y) {
                    *g += x.conj() * y;
                }
            }
        }
    }

    /// Index of line `k` of the spectrum `a` (`a` = `i * ni + j` in `gff`, `i * no + o` in
    /// `gfy`, `o` in `gyy`): channel-major, so that adding a segment runs along the lines.
    #[inline]
    fn at(&self, a: usize, k: usize) -> usize {
        a * self.nl + k
    }

    /// Adds one average per segment of `batch`. Each line's sums run over the segments
    /// in order, so a batch adds exactly what its segments added one by one would; the
    /// lines are split into chunks summed in parallel (rayon), and each chunk of every
    /// spectrum is added to all the sums it enters while it is in the core's cache.
    fn add(&mut self, batch: &[Spectra]) {
        let (ni, no, nl) = (self.inputs.len(), self.outputs.len(), self.nl);
        self.averages += batch.len();
        if nl == 0 {
            return;
        }
        // chunk c of every row of the three sums, for one task per chunk of lines
        let mut chunks: Vec<LineChunk> = (0..nl.div_ceil(LINE_CHUNK))
            .map(|_| LineChunk::default())
            .collect();
        for row in self.gff.chunks_mut(nl) {
            for (c, part) in chunks.iter_mut().zip(row.chunks_mut(LINE_CHUNK)) {
                c.gff.push(part);
            }
        }
        for (c, part) in chunks.iter_mut().zip(self.gff1.chunks_mut(LINE_CHUNK)) {
            c.gff1 = part;
        }
        for row in self.gfy.chunks_mut(nl) {
            for (c, part) in chunks.iter_mut().zip(row.chunks_mut(LINE_CHUNK)) {
                c.gfy.push(part);
            }
        }
        for row in self.gyy.chunks_mut(nl) {
            for (c, part) in chunks.iter_mut().zip(row.chunks_mut(LINE_CHUNK)) {
                c.gyy.push(part);
            }
        }
        chunks
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut chunk)| {
                let k0 = 1 + c * LINE_CHUNK;
                let k = k0..k0 + LINE_CHUNK.min(nl - (k0 - 1));
                for s in batch {
                    chunk.add(s, ni, no, k.clone());
                }
            });
    }

    /// Lines `(lo, hi)` (1-based line numbers k, frequency k·df) of the contiguous range
    /// around the peak of the force auto-spectrum (trace of Gff) within 20 dB of it.
    fn force_band(&self) -> Option<(usize, usize)> {
        self.force_band_within(self.averages > 1, 0.01)
    }

    /// The contiguous lines around the force auto-spectrum's peak where it stays above
    /// `lim` times the peak, the spectrum smoothed over ±1/12 octave first when `smooth`.
    fn force_band_within(&self, smooth: bool, lim: f64) -> Option<(usize, usize)> {
        let ni = self.inputs.len();
        let raw = |k: usize| -> f64 {
            if ni == 1 {
                // (a sum of one term is that term)
                self.gff1[k]
            } else {
                (0..ni).map(|i| self.gff[self.at(i * ni + i, k)].re).sum()
            }
        };
        // averaged estimates smoothed over ±1/12 octave: a random force's spectrum from a
        // few averages dips 20 dB below its largest line at random lines, and a comb from
        // a double hit has notches; neither ends the band (measured: a flat 10-4096 Hz
        // random force gave bands of 1.1-2.9 kHz before). A single deterministic record (a
        // sweep) is not: its band ends where its spectrum does, and smoothing carried a
        // linear chirp's band into the anti-alias filter's noise (99.8 -> 94 % vs truth).
        // Each smoothed line is computed once, into a buffer this thread keeps (the
        // search for the peak reads every line, the walk to the band's ends most of them
        // again).
        if smooth {
            let s = if ni == 1 {
                OctaveSmoother::new(self.gff1[..self.nl].iter().copied(), 1.0 / 12.0)
            } else {
                OctaveSmoother::new((0..self.nl).map(raw), 1.0 / 12.0)
            };
            SUMS.with_borrow_mut(|(_, kept)| {
                // (every line is written below: no zeros first)
                let mut v = reused(kept, self.nl);
                for (k, x) in v.iter_mut().enumerate() {
                    *x = s.at(k + 1);
                }
                let band = band_around_peak(self.nl, |k| v[k], lim);
                keep(kept, v);
                band
            })
        } else {
            band_around_peak(self.nl, raw, lim)
        }
    }

    /// FRF channels (per output, per input) and how many lines were singular.
    fn finish(&self, est: Estimator) -> Result<(Vec<FrfChannel>, usize)> {
        let (ni, no, nl) = (self.inputs.len(), self.outputs.len(), self.nl);
        if ni > 1 && est != Estimator::H1 {
            return Err(Error::BadInput(format!(
                "{est:?} needs a single force direction but these records excite {} axes at once; use H1 (MIMO)",
                ni
            )));
        }
        if ni == 1 && est == Estimator::H1 {
            // the usual case in straight-line code (the compiler vectorises it)
            let gff = &self.gff1[..nl];
            let singular = gff.iter().filter(|&&g| g <= 0.0).count() * no;
            let chans = self
                .outputs
                .iter()
                .enumerate()
                .map(|(o, &out)| {
                    let (gyy, gfy) = (&self.gyy[o * nl..][..nl], &self.gfy[o * nl..][..nl]);
                    // written once each (no zeroed buffers first), each in a loop of its
                    // own of known length (the compiler vectorises the divisions)
                    let h = (gff.iter().zip(gfy))
                        .map(|(&g, &gfy)| h1_line(g, gfy, 0.0).0)
                        .collect();
                    let coh = (gff.iter().zip(gyy).zip(gfy))
                        .map(|((&g, &gyy), &gfy)| h1_line(g, gfy, gyy).1)
                        .collect();
                    FrfChannel {
                        channel: Channel::new(out, self.inputs[0]),
                        h,
                        coherence: Some(coh),
                    }
                })
                .collect();
            return Ok((chans, singular));
        }
        if ni == 1 {
            // one input: each channel's lines in one pass over its sums
            let mut singular = 0;
            let chans = self
                .outputs
                .iter()
                .enumerate()
                .map(|(o, &out)| {
                    let (gyy, gfy) = (&self.gyy[o * nl..][..nl], &self.gfy[o * nl..][..nl]);
                    let mut h = Vec::with_capacity(nl);
                    let mut coh = Vec::with_capacity(nl);
                    for ((&g, &gyy), &gfy) in self.gff1[..nl].iter().zip(gyy).zip(gfy) {
                        let (hk, ck) = siso_line(est, g, gfy, gyy);
                        singular += usize::from(g <= 0.0);
                        h.push(hk);
                        coh.push(ck);
                    }
                    FrfChannel {
                        channel: Channel::new(out, self.inputs[0]),
                        h,
                        coherence: Some(coh),
                    }
                })
                .collect();
            return Ok((chans, singular));
        }
        let mut chans: Vec<FrfChannel> = Vec::with_capacity(ni * no);
        for &o in &self.outputs {
            for &i in &self.inputs {
                chans.push(FrfChannel {
                    channel: Channel::new(o, i),
                    h: Vec::with_capacity(nl),
                    coherence: Some(Vec::with_capacity(nl)),
                });
            }
        }
        let mut singular = 0;
        let mut a = vec![Complex64::default(); ni * ni];
        let mut b = vec![Complex64::default(); ni];
        let mut h = vec![Complex64::default(); ni];
        for k in 0..nl {
            for o in 0..no {
                let gyy = self.gyy[self.at(o, k)];
                let mut coh = 0.0;
                h.fill(Complex64::default());
                for (ij, aij) in a.iter_mut().enumerate() {
                    *aij = self.gff[self.at(ij, k)];
                }
                for (i, bi) in b.iter_mut().enumerate() {
                    *bi = self.gfy[self.at(i * no + o, k)];
                }
                if solve_in_place(&mut a, &mut b, ni) {
                    h.copy_from_slice(&b);
                    let explained: f64 = (0..ni)
                        .map(|i| (self.gfy[self.at(i * no + o, k)].conj() * h[i]).re)
                        .sum();
                    if gyy > 0.0 {
                        coh = (explained / gyy).clamp(0.0, 1.0);
                    }
                } else {
                    singular += 1;
                }
                for (i, hi) in h.iter().enumerate() {
                    let c = &mut chans[o * ni + i];
                    c.h.push(*hi);
                    if let Some(g) = c.coherence.as_mut() {
                        g.push(coh);
                    }
                }
            }
        }
        Ok((chans, singular))
    }
}

/// Lines `(lo, hi)` (1-based) of the contiguous range around the largest of the `n`
/// values `p(0..n)` (the last of equal ones) where they stay at least `lim` times it;
/// `None` when there are none or the largest is not positive.
fn band_around_peak(n: usize, p: impl Fn(usize) -> f64, lim: f64) -> Option<(usize, usize)> {
    if n == 0 {
        return None;
    }
    // the largest as `Iterator::max_by` by `total_cmp` finds it (a later equal one
    // wins), in a loop that keeps the running maximum in registers
    let (mut kmax, mut pmax) = (0, p(0));
    for k in 1..n {
        let v = p(k);
        if v.total_cmp(&pmax) != std::cmp::Ordering::Less {
            (kmax, pmax) = (k, v);
        }
    }
    if pmax <= 0.0 {
        return None;
    }
    let lim = lim * pmax;
    let mut lo = kmax;
    while lo > 0 && p(lo - 1) >= lim {
        lo -= 1;
    }
    let mut hi = kmax;
    while hi + 1 < n && p(hi + 1) >= lim {
        hi += 1;
    }
    Some((lo + 1, hi + 1))
}

/// [`crate::plan::smooth_octave`] on the lines `1, 2, …, n`, line by line from the
/// prefix sums of the values: each window's ends are counted from its edge frequencies
/// instead of walked to (the walk's branches are taken at random on a fine grid), and
/// kept per thread for the last few `(n, octaves)` ([`window_ends`]: a campaign smooths
/// many spectra of one length, and the ends cost two divisions and three conversions a
/// line, more than the smoothing itself).
struct OctaveSmoother {
    /// `ends[k - 1]` = `[a, b]`: line k's window is the lines `a + 1 ..= b`.
    ends: Ends,
    /// `pre[j]` = sum of the first `j` values.
    pre: Vec<f64>,
}

/// Window ends of [`OctaveSmoother`], by line count and octaves (their bits).
type Ends = Arc<[[usize; 2]]>;

thread_local! {
    /// The window ends of [`OctaveSmoother`] of the last [`PLAN_CACHE`] lengths.
    static WINDOW_ENDS: Cache<Ends, (usize, u64)> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The window ends of [`OctaveSmoother`] on the lines `1..=n` ([`kept_by`]).
fn window_ends(n: usize, octaves: f64) -> Ends {
    kept_by(&WINDOW_ENDS, (n, octaves.to_bits()), n, || {
        let r = 2f64.powf(octaves);
        (1..=n)
            .map(|k| {
                // the conversions through i64 (one instruction each, exact: line numbers
                // and counts are far below 2^53, and lo > 0)
                let f = k as i64 as f64;
                // a = #{lines j < f / r}, b = #{lines j ≤ f · r}, lines j = 1..=n
                let lo = f / r;
                let t = lo as i64; // ⌊lo⌋ (lo > 0)
                let a = ((t - i64::from(t as f64 == lo)) as usize).min(n);
                let b = ((f * r) as i64 as usize).min(n);
                [a, b]
            })
            .collect()
    })
}

impl OctaveSmoother {
    fn new(v: impl ExactSizeIterator<Item = f64>, octaves: f64) -> Self {
        let n = v.len();
        // (written into place: the running sum stays in a register)
        let mut pre = vec![0.0; n + 1];
        let mut last = 0.0;
        for (p, x) in pre[1..].iter_mut().zip(v) {
            last += x;
            *p = last;
        }
        OctaveSmoother {
            ends: window_ends(n, octaves),
            pre,
        }
    }

    /// The smoothed value of line `k` (1-based, `k ≤ n`).
    #[inline]
    fn at(&self, k: usize) -> f64 {
        let [a, b] = self.ends[k - 1];
        (self.pre[b] - self.pre[a]) / (b - a).max(1) as i64 as f64
    }
}

/// [`crate::plan::smooth_octave`] of `v` on the lines `1, 2, …, v.len()`, the same
/// numbers ([`OctaveSmoother`]).
#[cfg(test)]
fn smooth_octave_lines(v: &[f64], octaves: f64) -> Vec<f64> {
    let s = OctaveSmoother::new(v.iter().copied(), octaves);
    (1..=v.len()).map(|k| s.at(k)).collect()
}

/// [`siso_line`] for [`Estimator::H1`], the same numbers without branches.
#[inline(always)]
fn h1_line(gff: f64, gfy: Complex64, gyy: f64) -> (Complex64, f64) {
    let c = (gfy.norm_sqr() / (gff * gyy)).clamp(0.0, 1.0);
    let h = gfy / gff;
    let coh = if gff > 0.0 && gyy > 0.0 { c } else { 0.0 };
    let h = if gff > 0.0 { h } else { Complex64::default() };
    (h, coh)
}

/// H and coherence of one line of a single-input channel from its sums `Gff`, `Gfy`,
/// `Gyy` (H = 0 where `Gff` ≤ 0: a singular line).
fn siso_line(est: Estimator, gff: f64, gfy: Complex64, gyy: f64) -> (Complex64, f64) {
    let coh = if gff > 0.0 && gyy > 0.0 {
        (gfy.norm_sqr() / (gff * gyy)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let h = match est {
        _ if gff <= 0.0 => Complex64::default(),
        Estimator::H1 => gfy / gff,
        Estimator::H2 if gfy.norm_sqr() > 0.0 => gyy / gfy.conj(),
        Estimator::Hv if gfy.norm_sqr() > 0.0 => {
            // (Gyy - Gff + S) / (2 Gyf), S = sqrt((Gff-Gyy)² + 4|Gfy|²),
            // in the form without cancellation for either sign.
            let d = gff - gyy;
            let s = (d * d + 4.0 * gfy.norm_sqr()).sqrt();
            if d >= 0.0 {
                2.0 * gfy / (d + s)
            } else {
                (s - d) / (2.0 * gfy.conj())
            }
        }
        _ => Complex64::default(),
    };
    (h, coh)
}

/// Lines per chunk of [`Accumulator::add`] (a chunk of every spectrum of a segment and of
/// every sum stays in the core's cache while the batch's segments are added into it).
const LINE_CHUNK: usize = 2048;

/// The lines `k0..k0 + LINE_CHUNK` of every row of an [`Accumulator`]'s sums.
#[derive(Default)]
struct LineChunk<'a> {
    gff: Vec<&'a mut [Complex64]>,
    /// The lines of [`Accumulator`]'s `gff1` (empty for several inputs).
    gff1: &'a mut [f64],
    gfy: Vec<&'a mut [Complex64]>,
    gyy: Vec<&'a mut [f64]>,
}

impl LineChunk<'_> {
    /// Adds the lines `k` (spectrum indices, line k at index k) of one segment's spectra.
    fn add(&mut self, s: &Spectra, ni: usize, no: usize, k: std::ops::Range<usize>) {
        if let Some(f) = s.fs.first().filter(|_| !self.gff1.is_empty()) {
            for (g, x) in self.gff1.iter_mut().zip(&f[k.clone()]) {
                *g += (x.conj() * x).re;
            }
        }
        for (a, g) in self.gff.iter_mut().enumerate() {
            let (fi, fj) = (&s.fs[a / ni][k.clone()], &s.fs[a % ni][k.clone()]);
            for ((g, x), y) in g.iter_mut().zip(fi).zip(fj) {
                *g += x.conj() * y;
            }
        }
        for (a, g) in self.gfy.iter_mut().enumerate() {
            let (fi, yo) = (&s.fs[a / no][k.clone()], &s.ys[a % no][k.clone()]);
            for ((g, x), y) in g.iter_mut().zip(fi).zip(yo) {
                *g += x.conj() * y;
            }
        }
        for (o, g) in self.gyy.iter_mut().enumerate() {
            for (g, y) in g.iter_mut().zip(&s.ys[o][k.clone()]) {
                *g += y.norm_sqr();
            }
        }
    }
}

/// The lines of two consecutive segments of one input ([`half::add_pair`]): `gfy += conj(f) y`, `gyy += |y|²` and,
/// when `gff` is not empty, `gff += |f|²`, segment `a`'s term before `b`'s, `y` through
/// `scale` (line index, spectrum) on the way. (Written for two segments: a loop over a
/// group of them, unrolled by the compiler, measured 5 % slower; four segments per
/// pass were slower still: their spectra no longer stay in the cache.)
#[inline(always)]
fn pair_pass(
    gfy: &mut [Complex64],
    gyy: &mut [f64],
    gff: &mut [f64],
    [fa, fb]: [&[Complex64]; 2],
    [ya, yb]: [&[Complex64]; 2],
    scale: impl Fn(usize, Complex64) -> Complex64,
) {
    let n = gfy.len().min(gyy.len());
    let (fa, fb, ya, yb) = (&fa[..n], &fb[..n], &ya[..n], &yb[..n]);
    if gff.is_empty() {
        for k in 0..n {
            let (ya, yb) = (scale(k, ya[k]), scale(k, yb[k]));
            gfy[k] = gfy[k] + fa[k].conj() * ya + fb[k].conj() * yb;
            gyy[k] = gyy[k] + ya.norm_sqr() + yb.norm_sqr();
        }
    } else {
        let gff = &mut gff[..n];
        for k in 0..n {
            let (ya, yb) = (scale(k, ya[k]), scale(k, yb[k]));
            gff[k] = gff[k] + (fa[k].conj() * fa[k]).re + (fb[k].conj() * fb[k]).re;
            gfy[k] = gfy[k] + fa[k].conj() * ya + fb[k].conj() * yb;
            gyy[k] = gyy[k] + ya.norm_sqr() + yb.norm_sqr();
        }
    }
}

/// [`pair_pass`] for two outputs at once: the force spectra `fa`, `fb` read once for both
/// (`g*0`: output 0's sums, `g*1`: output 1's; `gff` as in [`pair_pass`]); each sum gets
/// the same terms in the same order as two [`pair_pass`] calls would add.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pair_pass2(
    (gfy0, gyy0): (&mut [Complex64], &mut [f64]),
    (gfy1, gyy1): (&mut [Complex64], &mut [f64]),
    gff: &mut [f64],
    [fa, fb]: [&[Complex64]; 2],
    [ya0, yb0]: [&[Complex64]; 2],
    [ya1, yb1]: [&[Complex64]; 2],
    scale: impl Fn(usize, Complex64) -> Complex64,
) {
    let n = gfy0.len().min(gyy0.len()).min(gfy1.len()).min(gyy1.len());
    let (fa, fb) = (&fa[..n], &fb[..n]);
    let (ya0, yb0, ya1, yb1) = (&ya0[..n], &yb0[..n], &ya1[..n], &yb1[..n]);
    let (gfy0, gyy0, gfy1, gyy1) = (
        &mut gfy0[..n],
        &mut gyy0[..n],
        &mut gfy1[..n],
        &mut gyy1[..n],
    );
    let gff = &mut gff[..n];
    for k in 0..n {
        let (fa, fb) = (fa[k], fb[k]);
        gff[k] = gff[k] + (fa.conj() * fa).re + (fb.conj() * fb).re;
        let (ya, yb) = (scale(k, ya0[k]), scale(k, yb0[k]));
        gfy0[k] = gfy0[k] + fa.conj() * ya + fb.conj() * yb;
        gyy0[k] = gyy0[k] + ya.norm_sqr() + yb.norm_sqr();
        let (ya, yb) = (scale(k, ya1[k]), scale(k, yb1[k]));
        gfy1[k] = gfy1[k] + fa.conj() * ya + fb.conj() * yb;
        gyy1[k] = gyy1[k] + ya.norm_sqr() + yb.norm_sqr();
    }
}

/// Solves `A x = b` (n ≤ 3, row-major `a`) by Gaussian elimination with partial pivoting;
/// `b` becomes `x`. False when `A` is (numerically) singular.
fn solve_in_place(a: &mut [Complex64], b: &mut [Complex64], n: usize) -> bool {
    let scale = (0..n).map(|i| a[i * n + i].norm()).fold(0.0, f64::max);
    if scale <= 0.0 {
        return false;
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| a[x * n + c].norm().total_cmp(&a[y * n + c].norm()))
            .unwrap_or(c);
        if a[p * n + c].norm() <= 1e-10 * scale {
            return false;
        }
        if p != c {
            for j in 0..n {
                a.swap(p * n + j, c * n + j);
            }
            b.swap(p, c);
        }
        for r in c + 1..n {
            let m = a[r * n + c] / a[c * n + c];
            for j in c..n {
                let v = a[c * n + j];
                a[r * n + j] -= m * v;
            }
            let v = b[c];
            b[r] -= m * v;
        }
    }
    for c in (0..n).rev() {
        let mut s = b[c];
        for j in c + 1..n {
            s -= a[c * n + j] * b[j];
        }
        b[c] = s / a[c * n + c];
    }
    true
}

/// Per-line factor turning a response spectrum into displacement: `1/(jω+σ)²` for
/// acceleration, `None` (factor 1) for displacement.
fn to_displacement(
    kind: Option<ResponseKind>,
    n: usize,
    dt: f64,
    sigma: f64,
) -> Option<Vec<Complex64>> {
    if kind == Some(ResponseKind::Displacement) {
        return None;
    }
    Some(
        (1..=n_lines(n))
            .map(|k| {
                let s = Complex64::new(sigma, 2.0 * PI * k as f64 / (n as f64 * dt));
                1.0 / (s * s)
            })
            .collect(),
    )
}

/// Groups records by their input axes (sorted by inputs), with the outputs common to all
/// records of the group.
fn groups(
    infos: &[RecordInfo],
    warnings: &mut Vec<String>,
) -> Vec<(Vec<Axis>, Vec<Axis>, Vec<usize>)> {
    let mut keys: Vec<Vec<Axis>> = infos.iter().map(|i| i.inputs.clone()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .map(|key| {
            let members: Vec<usize> = (0..infos.len()).filter(|&r| infos[r].inputs == key).collect();
            let outputs: Vec<Axis> = Axis::ALL
                .into_iter()
                .filter(|a| members.iter().all(|&r| infos[r].outputs.contains(a)))
                .collect();
            if members.iter().any(|&r| infos[r].outputs.len() != outputs.len()) {
                warnings.push(format!(
                    "records excited along {} have different response axes; only the common ones ({}) are estimated",
                    axes_name(&key),
                    axes_name(&outputs)
                ));
            }
            (key, outputs, members)
        })
        .collect()
}

fn axes_name(a: &[Axis]) -> String {
    a.iter().map(|a| a.letter()).collect()
}

/// Turns accumulators into the estimate (grid, fmax, warnings, duplicates).
fn assemble(
    accs: Vec<Accumulator>,
    n: usize,
    ctx: &mut Ctx,
    method: String,
    sigma: Option<f64>,
) -> Result<FrfEstimate> {
    let df = 1.0 / (n as f64 * ctx.dt);
    let nl = n_lines(n);
    let keep = match ctx.opts.fmax_hz {
        Some(fmax) => (1..=nl).take_while(|&k| k as f64 * df <= fmax).count(),
        None => nl,
    };
    if keep == 0 {
        return Err(Error::BadInput(format!(
            "no frequency line below fmax = {:?} Hz at resolution {df} Hz; raise fmax or use longer records",
            ctx.opts.fmax_hz
        )));
    }
    let mut channels: Vec<FrfChannel> = Vec::new();
    let mut used = 0;
    let mut per_channel = usize::MAX;
    let mut band = (0.0f64, f64::INFINITY);
    for acc in &accs {
        if let Some((lo, hi)) = acc.force_band() {
            band = (band.0.max(lo as f64 * df), band.1.min(hi as f64 * df));
        }
        if acc.averages == 1 {
            ctx.warnings.push(format!(
                "excitation along {}: a single average, coherence is 1 by construction and says nothing about noise",
                axes_name(&acc.inputs)
            ));
        }
        used += acc.averages;
        per_channel = per_channel.min(acc.averages);
        let (chans, singular) = acc.finish(ctx.opts.estimator)?;
        if singular > 0 {
            ctx.warnings.push(format!(
                "excitation along {}: {} without usable force (H set to 0, coherence 0); the force does not excite these frequencies or the force axes are fully correlated",
                axes_name(&acc.inputs),
                crate::axis::count(singular, "line")
            ));
        }
        for mut c in chans {
            if channels.iter().any(|o| o.channel == c.channel) {
                return Err(Error::BadInput(format!(
                    "channel {} would come from records with different force directions; estimate single-axis and multi-axis records separately",
                    c.channel
                )));
            }
            c.h.truncate(keep);
            if let Some(g) = c.coherence.as_mut() {
                g.truncate(keep);
                let low = g.iter().filter(|&&v| v < 0.8).count();
                if acc.averages > 1 && low * 5 > keep {
                    ctx.warnings.push(format!(
                        "channel {}: coherence below 0.8 on {:.0} % of the lines (noise, nonlinearity or unmeasured forces)",
                        c.channel,
                        100.0 * low as f64 / keep as f64
                    ));
                }
            }
            channels.push(c);
        }
    }
    channels.sort_by_key(|c| (c.channel.input, c.channel.output));
    let excitation_band_hz = (band.1.is_finite() && band.1 >= band.0).then_some(band);
    if let Some((lo, hi)) = excitation_band_hz {
        let top = keep as f64 * df;
        if hi < 0.9 * top {
            ctx.warnings.push(format!(
                "the force is more than 20 dB below its peak outside {lo:.1}..{hi:.1} Hz; lines up to {top:.1} Hz outside that band are unreliable (identify's automatic band stops there)"
            ));
        }
    }
    Ok(FrfEstimate {
        frf: Frf {
            freqs_hz: (1..=keep).map(|k| k as f64 * df).collect(),
            channels,
        },
        warnings: std::mem::take(&mut ctx.warnings),
        hits_used: used,
        averages_per_channel: if per_channel == usize::MAX {
            used
        } else {
            per_channel
        },
        hits_dropped: std::mem::take(&mut ctx.dropped),
        exp_window_sigma: sigma,
        method,
        df_hz: df,
        hit_record_s: None,
        excitation_band_hz,
        coherence_dof: None,
    })
}

/// A single sweep's band: where its force auto-spectrum (smoothed over ±1/12 octave)
/// is within this fraction (40 dB) of its peak.
const SWEEP_BAND_POWER: f64 = 1e-4;

/// Lines on each side over which [`scatter_coherence`] estimates noise and signal.
pub const SCATTER_HALF_WIDTH: usize = 32;

/// The number of averages whose noise-only coherence level matches that of
/// [`scatter_coherence`]: on a channel of pure noise it exceeds 0.36 on 1 % and 0.45 on
/// 0.1 % of the lines (its windows overlap, so neighbouring values are not independent);
/// ten averages put the level at 0.40.
pub const SCATTER_EQUIVALENT_AVERAGES: usize = 10;

/// Coherence of a single-record FRF from its line-to-line scatter: a structure's FRF is
/// smooth on a fine grid (a whole-record DFT of a 10 s sweep has 0.1 Hz lines; a mode of
/// 1 % damping at 50 Hz spans ten), while the noise of an estimate from one record is
/// independent from line to line. The noise variance at each line is the median of
/// `|H[k−1] − 2H[k] + H[k+1]|² / 6` over ±[`SCATTER_HALF_WIDTH`] lines (divided by ln 2:
/// the median of a complex Gaussian's squared magnitude), the data power the mean of
/// `|H|²` there, and `γ² = 1 − σ²/E|H|²` as for an H1 (a pure-noise channel sits near 0,
/// a clean one near 1). Replaces the coherence of 1 that a single average gives by
/// construction.
pub fn scatter_coherence(h: &[Complex64]) -> Vec<f64> {
    let n = h.len();
    if n < 8 {
        return vec![1.0; n];
    }
    let d2: Vec<f64> = (0..n)
        .map(|k| {
            let (a, b) = (k.max(1) - 1, (k + 1).min(n - 1));
            let k = k.clamp(1, n - 2);
            let (a, b) = (a.min(k - 1), b.max(k + 1));
            (h[a] - 2.0 * h[k] + h[b]).norm_sqr() / 6.0
        })
        .collect();
    let p: Vec<f64> = h.iter().map(|v| v.norm_sqr()).collect();
    let w = SCATTER_HALF_WIDTH;
    let mut buf = Vec::with_capacity(2 * w + 1);
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(w), (k + w + 1).min(n));
            buf.clear();
            buf.extend_from_slice(&d2[a..b]);
            let m = buf.len() / 2;
            buf.select_nth_unstable_by(m, f64::total_cmp);
            let noise = buf[m] / std::f64::consts::LN_2;
            let power = p[a..b].iter().sum::<f64>() / (b - a) as f64;
            if power > 0.0 {
                (1.0 - noise / power).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// Welch segment hop and count for a record of `len` samples.
pub fn welch_segments(len: usize, nfft: usize, overlap: f64) -> (usize, usize) {
    let hop = (nfft - (overlap * nfft as f64).round() as usize).max(1);
    let count = if len >= nfft {
        (len - nfft) / hop + 1
    } else {
        0
    };
    (hop, count)
}

/// The Hann-windowed real FFTs of every Welch segment of every column of a record, and
/// nothing else: the floor under any H1 estimate with these settings (window, plan and
/// buffers made once, in [`FftFloor::new`]). For benchmarks: [`estimate_frf`]'s time is
/// judged against [`FftFloor::run`]'s (`cargo bench -p identify --bench spectra`,
/// `cargo run --release --example bench_peers`).
pub struct FftFloor<'a> {
    cols: Vec<&'a [f64]>,
    hop: usize,
    segs: usize,
    window: Vec<f64>,
    plan: Plan,
    buf: Vec<f64>,
    out: Vec<Complex64>,
    scratch: Vec<Complex64>,
}

impl<'a> FftFloor<'a> {
    /// The floor of a Welch estimate of `rec` with segments of `nfft` points overlapping
    /// by the fraction `overlap`.
    pub fn new(rec: &'a TimeSeries, nfft: usize, overlap: f64) -> Self {
        let cols: Vec<&[f64]> = Axis::ALL
            .into_iter()
            .filter_map(|a| rec.force(a))
            .chain(Axis::ALL.into_iter().filter_map(|a| rec.response(a)))
            .collect();
        let (hop, segs) = welch_segments(rec.len(), nfft, overlap);
        let plan = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(nfft);
        FftFloor {
            cols,
            hop,
            segs,
            window: hann(nfft),
            buf: plan.make_input_vec(),
            out: plan.make_output_vec(),
            scratch: plan.make_scratch_vec(),
            plan,
        }
    }

    /// The number of FFTs a run does.
    pub fn count(&self) -> usize {
        self.segs * self.cols.len()
    }

    /// Windows and transforms every segment of every column into one buffer; returns a
    /// line of the last spectrum (so that the work cannot be optimised away).
    pub fn run(&mut self) -> Complex64 {
        for s in 0..self.segs {
            for c in &self.cols {
                for ((b, x), w) in self
                    .buf
                    .iter_mut()
                    .zip(&c[s * self.hop..])
                    .zip(&self.window)
                {
                    *b = x * w;
                }
                if self
                    .plan
                    .process_with_scratch(&mut self.buf, &mut self.out, &mut self.scratch)
                    .is_err()
                {
                    return Complex64::default();
                }
            }
        }
        self.out.get(1).copied().unwrap_or_default()
    }
}

impl std::fmt::Debug for FftFloor<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FftFloor")
            .field("columns", &self.cols.len())
            .field("segments", &self.segs)
            .field("nfft", &self.window.len())
            .finish()
    }
}

/// Periodic Hann window of length n.
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos())
        .collect()
}

/// Automatic Welch length (module docs).
fn welch_nfft(lens: &[usize], opts: &FrfOptions) -> Option<usize> {
    let segs = |l: usize| -> usize {
        lens.iter()
            .map(|&n| welch_segments(n, l, opts.overlap).1)
            .sum()
    };
    (5..=16)
        .rev()
        .map(|p| 1usize << p)
        .find(|&l| segs(l) >= opts.min_averages)
        .or_else(|| (5..=16).rev().map(|p| 1usize << p).find(|&l| segs(l) >= 1))
}

/// Welch segment length for records of `lens` samples: `opts.nfft` or the rule.
fn welch_length(lens: &[usize], opts: &FrfOptions) -> Result<usize> {
    match opts.nfft {
        Some(n) => Ok(n),
        None => welch_nfft(lens, opts).ok_or_else(|| {
            Error::BadInput(format!(
                "records too short for Welch averaging (longest {} samples, need at least 32)",
                lens.iter().max().copied().unwrap_or(0)
            ))
        }),
    }
}

/// Segments per Welch batch on few threads ([`Welch::batch`]).
const MIN_BATCH: usize = 4;

/// The spectra a batch of Welch segments may hold, in bytes (a segment larger than this
/// is transformed alone).
const BATCH_BYTES: usize = 64 << 20;

/// The Welch core shared by the in-memory and the streamed estimate: window, planned
/// DFT and the spectra of a batch of segments.
///
/// The segments of a batch are windowed and transformed in parallel (rayon) and added by
/// [`Accumulator::add`], which sums every line in segment order: the estimate is the
/// same, bit for bit, for any batch size and number of threads.
struct Welch {
    window: Arc<[f64]>,
    plan: Arc<dyn RealToComplex<f64>>,
    spectra: Vec<Spectra>,
}

impl Welch {
    fn new(n: usize) -> Self {
        Welch {
            window: hann_kept(n),
            plan: plan(n),
            spectra: KEPT_SPECTRA.take(),
        }
    }

    /// Segments per batch for an estimate in memory of `channels` forces and responses:
    /// one per thread but at least [`MIN_BATCH`] (each batch reads and writes every sum
    /// once, which for long segments costs as much memory traffic as a segment's
    /// spectra), as many as [`BATCH_BYTES`] of spectra allow, at least one.
    fn batch(n: usize, channels: usize) -> usize {
        let per_segment = channels * (n / 2 + 1) * std::mem::size_of::<Complex64>();
        (rayon::current_num_threads().max(MIN_BATCH))
            .min(BATCH_BYTES / per_segment.max(1))
            .max(1)
    }

    /// Windows and transforms a batch of segments and adds them to `acc` in order. Each
    /// segment is its `n` samples of every input force (the first `inputs` slices) and
    /// output response, in the accumulator's order; `conv` turns response spectra into
    /// displacement ([`to_displacement`]). False when a response sample is NaN or
    /// infinite (the sums are then meaningless); the callers have checked the forces.
    fn add_segments(
        &mut self,
        acc: &mut Accumulator,
        conv: Option<&[Complex64]>,
        inputs: usize,
        segments: &[Vec<&[f64]>],
    ) -> Result<bool> {
        let (plan, window) = (&*self.plan, &*self.window);
        if rayon::current_num_threads() == 1 {
            return self.add_one_by_one(acc, conv, inputs, segments);
        }
        if self.spectra.len() < segments.len() {
            self.spectra.resize_with(segments.len(), Spectra::default);
        }
        let mut jobs = Vec::new();
        for (seg, sp) in segments.iter().zip(&mut self.spectra) {
            sp.fs.resize_with(inputs, Vec::new);
            sp.ys.resize_with(seg.len() - inputs, Vec::new);
            let dsts =
                (sp.fs.iter_mut().map(|d| (d, None))).chain(sp.ys.iter_mut().map(|d| (d, conv)));
            jobs.extend(
                (seg.iter().zip(dsts).enumerate()).map(|(i, (x, (d, c)))| (*x, d, c, i < inputs)),
            );
        }
        let finite = jobs
            .into_par_iter()
            .map(|(x, dst, scale, force)| {
                BUFFERS.with_borrow_mut(|(buf, scratch)| {
                    buf.resize(window.len(), 0.0);
                    scratch.resize(plan.get_scratch_len(), Complex64::default());
                    // (the callers checked the forces)
                    let finite = if force {
                        fill_windowed_unchecked(buf, x, window)
                    } else {
                        fill_windowed(buf, x, window)
                    };
                    let done = transform(plan, buf, dst, scratch, scale);
                    if window.len() > PLAN_CACHE_MAX_LEN {
                        // kept per thread only up to the cached plans' length
                        (*buf, *scratch) = (Vec::new(), Vec::new());
                    }
                    done.map(|()| finite)
                })
            })
            .try_reduce(|| true, |a, b| Ok(a && b))?;
        if finite {
            acc.add(&self.spectra[..segments.len()]);
        }
        Ok(finite)
    }
}

thread_local! {
    /// The spectra buffers of this thread's last [`Welch`] (segments up to
    /// [`PLAN_CACHE_MAX_LEN`] points).
    static KEPT_SPECTRA: std::cell::Cell<Vec<Spectra>> = const { std::cell::Cell::new(Vec::new()) };
}

impl Drop for Welch {
    fn drop(&mut self) {
        if self.window.len() <= PLAN_CACHE_MAX_LEN {
            let spectra = std::mem::take(&mut self.spectra);
            // a thread being torn down keeps nothing
            let _ = KEPT_SPECTRA.try_with(|k| k.set(spectra));
        }
    }
}

impl Welch {
    /// [`Welch::add_segments`] on one thread: each segment's spectra in turn, each
    /// output's sums added right after its transform, while its spectrum is in the
    /// cache (the same sums, bit for bit, as the batches in parallel).
    fn add_one_by_one(
        &mut self,
        acc: &mut Accumulator,
        conv: Option<&[Complex64]>,
        inputs: usize,
        segments: &[Vec<&[f64]>],
    ) -> Result<bool> {
        let (plan, window) = (&*self.plan, &*self.window);
        if self.spectra.is_empty() {
            self.spectra.push(Spectra::default());
        }
        if inputs == 1
            && segments.iter().all(|s| s.len() > 1)
            && segments.len() >= 2
            && half::HalfDft::fits(window.len())
        {
            return self.add_in_pairs(acc, conv, segments);
        }
        let sp = &mut self.spectra[0];
        let done = BUFFERS.with_borrow_mut(|(buf, scratch)| {
            buf.resize(window.len(), 0.0);
            scratch.resize(plan.get_scratch_len(), Complex64::default());
            for seg in segments {
                let (forces, responses) = seg.split_at(inputs);
                sp.fs.resize_with(inputs, Vec::new);
                sp.ys.resize_with(sp.ys.len().max(1), Vec::new);
                for (x, dst) in forces.iter().zip(&mut sp.fs) {
                    // (the callers checked the forces)
                    fill_windowed_unchecked(buf, x, window);
                    transform(plan, buf, dst, scratch, None)?;
                }
                // one input: its auto spectrum goes with the first output's pass
                let inputs_added = inputs > 1 || responses.is_empty();
                if inputs_added {
                    acc.add_inputs(&sp.fs);
                }
                for (o, x) in responses.iter().enumerate() {
                    if !fill_windowed(buf, x, window) {
                        return Ok(false);
                    }
                    transform(plan, buf, &mut sp.ys[0], scratch, None)?;
                    acc.add_output(o, &sp.fs, &sp.ys[0], conv, inputs_added);
                }
                acc.averages += 1;
            }
            Ok(true)
        });
        if window.len() > PLAN_CACHE_MAX_LEN {
            BUFFERS.with_borrow_mut(|b| *b = Default::default());
        }
        done
    }
}

impl Welch {
    /// [`Welch::add_one_by_one`] for one input and a segment length that is a multiple
    /// of 4 ([`half::HalfDft::fits`]), two segments at a time: each channel of both
    /// segments windowed straight into its spectrum's buffer and transformed in place by
    /// the complex FFT of half the length, then one pass over the lines that
    /// post-processes them as realfft does and adds them ([`half::add_pair`]: outputs 0
    /// and 1 with the force's auto spectrum, the force spectra read once for both; any
    /// further output in a pass of its own); an odd last segment alone. Each sum is read
    /// and written once per pair, realfft's own post-processing pass and the spectra's
    /// second read are saved, and there is no input buffer beside the spectra: on case a
    /// of the peers' benchmark the estimate went from 1.36-1.41 to 1.32-1.34 times its FFT
    /// floor (realfft's transforms), on-CPU; the same sums, bit for bit.
    fn add_in_pairs(
        &mut self,
        acc: &mut Accumulator,
        conv: Option<&[Complex64]>,
        segments: &[Vec<&[f64]>],
    ) -> Result<bool> {
        let window = &*self.window;
        let n = window.len();
        let dft = half::HalfDft::new(n);
        if self.spectra.len() < 2 {
            self.spectra.resize_with(2, Spectra::default);
        }
        let pairs = segments.chunks_exact(2);
        let last = pairs.remainder();
        let sp = &mut self.spectra[..2];
        let nl = acc.nl;
        let done = half::SCRATCH.with_borrow_mut(|scratch| {
            scratch.resize(dft.scratch_len(), Complex64::default());
            // x windowed straight into the spectrum's buffer and transformed in place (the
            // same numbers as out of place, with one buffer fewer in the cache: case a of
            // the peers' benchmark 1.40-1.43 -> 1.32-1.35 times its floor); false: a
            // sample not finite
            let run =
                |x: &[f64], dst: &mut Vec<Complex64>, check: bool, scratch: &mut [Complex64]| {
                    dst.resize(n / 2, Complex64::default());
                    let samples = half::as_samples(dst);
                    let finite = if check {
                        fill_windowed(samples, x, window)
                    } else {
                        fill_windowed_unchecked(samples, x, window)
                    };
                    dft.fft.process_with_scratch(dst, scratch);
                    finite
                };
            for pair in pairs {
                let outputs = pair[0].len() - 1;
                for (seg, sp) in pair.iter().zip(sp.iter_mut()) {
                    sp.fs.resize_with(1, Vec::new);
                    sp.ys.resize_with(sp.ys.len().max(outputs.min(2)), Vec::new);
                    // (the callers checked the forces)
                    run(seg[0], &mut sp.fs[0], false, scratch);
                    for o in 0..outputs.min(2) {
                        if !run(seg[1 + o], &mut sp.ys[o], true, scratch) {
                            return false;
                        }
                    }
                }
                let fs = [&sp[0].fs[0][..], &sp[1].fs[0][..]];
                let y = |o: usize| [&sp[0].ys[o][..], &sp[1].ys[o][..]];
                let (gfy, gyy) = (&mut acc.gfy[..], &mut acc.gyy[..]);
                let gff = &mut acc.gff1[..nl];
                if outputs >= 2 {
                    let (gfy0, gfy1) = gfy.split_at_mut(nl);
                    let (gyy0, gyy1) = gyy.split_at_mut(nl);
                    let outs = &mut [(gfy0, gyy0), (&mut gfy1[..nl], &mut gyy1[..nl])];
                    half::add_pair(&dft, gff, outs, fs, &[y(0), y(1)], conv);
                } else {
                    let outs = &mut [(&mut gfy[..nl], &mut gyy[..nl])];
                    half::add_pair(&dft, gff, outs, fs, &[y(0)], conv);
                }
                for o in 2..outputs {
                    for (seg, sp) in pair.iter().zip(sp.iter_mut()) {
                        if !run(seg[1 + o], &mut sp.ys[0], true, scratch) {
                            return false;
                        }
                    }
                    let fs = [&sp[0].fs[0][..], &sp[1].fs[0][..]];
                    let ys = [[&sp[0].ys[0][..], &sp[1].ys[0][..]]];
                    let outs = &mut [(&mut acc.gfy[o * nl..][..nl], &mut acc.gyy[o * nl..][..nl])];
                    half::add_pair(&dft, &mut [], outs, fs, &ys, conv);
                }
                acc.averages += 2;
            }
            true
        });
        if n > PLAN_CACHE_MAX_LEN {
            half::SCRATCH.with_borrow_mut(|b| *b = Default::default());
        }
        match done {
            true if !last.is_empty() => self.add_one_by_one(acc, conv, 1, last),
            d => Ok(d),
        }
    }
}

/// A record shorter than one Welch segment (listed in [`FrfEstimate::hits_dropped`]).
fn too_short_for_segment(source: &str, len: usize, n: usize) -> String {
    format!("{source}: {len} samples, shorter than one segment of {n}; not used")
}

/// Checks a group's Welch averages: none is an error, few a warning.
fn check_averages(acc: &Accumulator, n: usize, ctx: &mut Ctx) -> Result<()> {
    if acc.averages == 0 {
        return Err(Error::BadInput(format!(
            "no record excited along {} is longer than the segment length {n}; use longer records or a smaller nfft",
            axes_name(&acc.inputs)
        )));
    }
    if acc.averages < ctx.opts.min_averages {
        ctx.warnings.push(format!(
            "excitation along {}: only {} Welch averages (aim for at least {}); the estimate is noisy, measure longer",
            axes_name(&acc.inputs),
            acc.averages,
            ctx.opts.min_averages
        ));
    }
    Ok(())
}

/// The Welch estimate from its accumulators.
fn welch_estimate(accs: Vec<Accumulator>, n: usize, ctx: &mut Ctx) -> Result<FrfEstimate> {
    let df = 1.0 / (n as f64 * ctx.dt);
    let method = format!(
        "{:?}, Welch: Hann window, nfft {n}, {:.0} % overlap, df {df:.4} Hz",
        ctx.opts.estimator,
        ctx.opts.overlap * 100.0
    );
    assemble(accs, n, ctx, method, None)
}

/// Runs `f` on a worker of the current rayon pool (on the calling thread when it is
/// one): the Welch batches' parallel parts inside then fork there, instead of handing
/// each one to the pool from outside and waiting for it.
fn on_worker<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

/// Streams records segment by segment into per-group accumulators.
fn continuous(records: &[TimeSeries], infos: &[RecordInfo], ctx: &mut Ctx) -> Result<FrfEstimate> {
    let lens: Vec<usize> = records.iter().map(TimeSeries::len).collect();
    let n = welch_length(&lens, ctx.opts)?;
    let mut welch = Welch::new(n);
    let nl = n_lines(n);
    let mut accs = Vec::new();
    for (inputs, outputs, members) in groups(infos, &mut ctx.warnings) {
        let mut acc = Accumulator::new(inputs.clone(), outputs.clone(), nl);
        for &r in &members {
            let rec = &records[r];
            let conv = to_displacement(rec.response_kind, n, ctx.dt, 0.0);
            let (hop, count) = welch_segments(rec.len(), n, ctx.opts.overlap);
            // the responses are checked for NaN/Inf as they are windowed, except what no
            // segment covers (the forces were checked before)
            let covered = if count == 0 { 0 } else { (count - 1) * hop + n };
            for a in rec.response_axes() {
                let v = rec.response(a).unwrap_or(&[]);
                let from = if outputs.contains(&a) { covered } else { 0 };
                check_finite(rec, "response", &v[from..])
                    .map_err(|_| not_finite(rec, "response", v))?;
            }
            if count == 0 {
                ctx.dropped
                    .push(too_short_for_segment(&rec.source, rec.len(), n));
                continue;
            }
            let starts: Vec<usize> = (0..count).map(|s| s * hop).collect();
            for batch in starts.chunks(Welch::batch(n, inputs.len() + outputs.len())) {
                let segments: Vec<Vec<&[f64]>> = batch
                    .iter()
                    .map(|&s| {
                        let seg = s..s + n;
                        (inputs.iter().map(|&a| rec.force(a)))
                            .chain(outputs.iter().map(|&a| rec.response(a)))
                            .map(|x| &x.unwrap_or(&[])[seg.clone()])
                            .collect()
                    })
                    .collect();
                if !welch.add_segments(&mut acc, conv.as_deref(), inputs.len(), &segments)? {
                    let v = (rec.response_axes().into_iter())
                        .filter_map(|a| rec.response(a))
                        .find(|v| v.iter().any(|x| !x.is_finite()))
                        .unwrap_or(&[]);
                    return Err(not_finite(rec, "response", v));
                }
            }
        }
        check_averages(&acc, n, ctx)?;
        accs.push(acc);
    }
    welch_estimate(accs, n, ctx)
}

/// `buf = x · w` sample by sample; false when a sample of `x` is NaN or infinite (checked
/// on the way: the samples are loaded anyway).
fn fill_windowed(buf: &mut [f64], x: &[f64], w: &[f64]) -> bool {
    // the products summed: a NaN or infinite sample makes its product NaN or infinite
    // (w is finite, 0·Inf is NaN) and so the sum, which no finite term brings back; a
    // sum that overflowed from finite products is told apart by a look at the samples.
    // 8 partial sums keep the adds off the critical path
    const L: usize = 8;
    let mut chk = [0.0f64; L];
    let n = buf.len().min(x.len()).min(w.len());
    let (buf, x, w) = (&mut buf[..n], &x[..n], &w[..n]);
    let mut bs = buf.chunks_exact_mut(L);
    let (mut xs, mut ws) = (x.chunks_exact(L), w.chunks_exact(L));
    for ((b, x), w) in (&mut bs).zip(&mut xs).zip(&mut ws) {
        for l in 0..L {
            b[l] = x[l] * w[l];
            chk[l] += b[l];
        }
    }
    for ((b, &v), &wi) in bs
        .into_remainder()
        .iter_mut()
        .zip(xs.remainder())
        .zip(ws.remainder())
    {
        *b = v * wi;
        chk[0] += *b;
    }
    chk.iter().sum::<f64>().is_finite() || x.iter().all(|v| v.is_finite())
}

/// `buf = x · w` sample by sample, for samples known to be finite (true).
fn fill_windowed_unchecked(buf: &mut [f64], x: &[f64], w: &[f64]) -> bool {
    for ((b, x), w) in buf.iter_mut().zip(x).zip(w) {
        *b = x * w;
    }
    true
}

/// Rectangular-window DFT ratio for deterministic excitation.
fn chirp(records: &[TimeSeries], infos: &[RecordInfo], ctx: &mut Ctx) -> Result<FrfEstimate> {
    let min_len = records.iter().map(TimeSeries::len).min().unwrap_or(0);
    let (n, periods) = match ctx.opts.nfft {
        Some(n) => (n, true),
        None => (min_len, false),
    };
    if n < 8 || min_len < n {
        return Err(Error::BadInput(format!(
            "chirp period/record length {n} does not fit the shortest record ({min_len} samples)"
        )));
    }
    if !periods && records.iter().any(|r| r.len() != min_len) {
        ctx.warnings.push(format!(
            "records have different lengths; all cut to the shortest ({min_len} samples)"
        ));
    }
    let mut dft = RealDft::new(n);
    let nl = n_lines(n);
    let mut accs = Vec::new();
    let mut several = false;
    for (inputs, outputs, members) in groups(infos, &mut ctx.warnings) {
        let mut acc = Accumulator::new(inputs.clone(), outputs.clone(), nl);
        let mut sp = Spectra::new(inputs.len(), outputs.len());
        several |= members.len() > 1;
        for &r in &members {
            let rec = &records[r];
            let conv = to_displacement(rec.response_kind, n, ctx.dt, 0.0);
            let count = if periods { rec.len() / n } else { 1 };
            for s in 0..count {
                let start = s * n;
                for (i, &a) in inputs.iter().enumerate() {
                    dft.buf
                        .copy_from_slice(&rec.force(a).unwrap_or(&[])[start..start + n]);
                    dft.run_into(&mut sp.fs[i], None)?;
                }
                for (o, &a) in outputs.iter().enumerate() {
                    dft.buf
                        .copy_from_slice(&rec.response(a).unwrap_or(&[])[start..start + n]);
                    dft.run_into(&mut sp.ys[o], conv.as_deref())?;
                }
                acc.add(std::slice::from_ref(&sp));
            }
        }
        accs.push(acc);
    }
    let df = 1.0 / (n as f64 * ctx.dt);
    let method = format!(
        "{:?}, chirp: rectangular window, DFT length {n} ({}), df {df:.4} Hz",
        ctx.opts.estimator,
        if periods {
            "periods averaged"
        } else {
            "whole record"
        }
    );
    let single = !periods && !several;
    // a single sweep's line spectrum ripples (its Fresnel ripples dip 20 dB below the
    // peak at random lines): smoothed over ±1/12 octave and within 40 dB of the peak,
    // the lines the sweep covers; the scatter coherence then says which of them hold
    // a trustworthy FRF
    let sweep_band = accs
        .iter()
        .filter_map(|a| a.force_band_within(true, SWEEP_BAND_POWER))
        .fold(None, |b: Option<(usize, usize)>, (lo, hi)| match b {
            None => Some((lo, hi)),
            Some((a, c)) => Some((a.max(lo), c.min(hi))),
        });
    let mut est = assemble(accs, n, ctx, method, None)?;
    if single {
        // one record per force direction: the coherence is 1 by construction; take it
        // from the line-to-line scatter instead, and let it (not the force's 20 dB
        // band, which a logarithmic sweep's falling force spectrum leaves long before
        // the sweep ends) say where the FRF is trustworthy
        for c in &mut est.frf.channels {
            c.coherence = Some(scatter_coherence(&c.h));
        }
        est.warnings.retain(|w| {
            !w.contains("coherence is 1 by construction") && !w.contains("20 dB below its peak")
        });
        est.method.push_str(&format!(
            "; coherence from the FRF's line-to-line scatter (±{SCATTER_HALF_WIDTH} lines)"
        ));
        est.coherence_dof = Some(SCATTER_EQUIVALENT_AVERAGES);
        let df = est.df_hz;
        est.excitation_band_hz = sweep_band
            .filter(|(lo, hi)| lo < hi)
            .map(|(lo, hi)| (lo as f64 * df, hi as f64 * df));
    }
    Ok(est)
}

mod half;
mod impact;
pub mod operating;
mod ringing;
pub use ringing::{HitSeparation, RINGING_LEVEL};
mod stream;
pub use stream::{estimate_frf_streamed, excitation_of_scan};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_cache_keeps_the_last_few_short_lengths_only() {
        for n in [64, 128, 256, 512, 1024, 64] {
            let p = plan(n);
            assert_eq!(p.len(), n);
        }
        let kept: Vec<usize> = PLANS.with_borrow(|c| c.iter().map(|(n, _)| *n).collect());
        assert_eq!(
            kept,
            vec![256, 512, 1024, 64],
            "least recent dropped, hit moved last"
        );
        let long = PLAN_CACHE_MAX_LEN + 2;
        assert_eq!(plan(long).len(), long);
        assert_eq!(hann_kept(long).len(), long);
        assert!(PLANS.with_borrow(|c| c.iter().all(|(n, _)| *n <= PLAN_CACHE_MAX_LEN)));
        assert!(WINDOWS.with_borrow(|c| c.iter().all(|(n, _)| *n <= PLAN_CACHE_MAX_LEN)));
    }

    #[test]
    fn welch_batches_and_buffers_stay_bounded() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        pool.install(|| {
            assert_eq!(Welch::batch(4096, 3), 4, "one segment per thread");
            // 4 channels of 2^22 points: 134 MB of spectra a segment, more than a batch
            assert_eq!(Welch::batch(1 << 22, 4), 1);
            // 2^19 points: 16.8 MB a segment, three fit in a batch
            assert_eq!(Welch::batch(1 << 19, 4), 3);
        });
        // a transform longer than the cached plans leaves no buffer behind
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        // (one segment: realfft's transform; two of a multiple of 4: the half-length one)
        let lengths = [(1024, true), (PLAN_CACHE_MAX_LEN + 2, false)];
        for ((n, kept), segments) in lengths.into_iter().flat_map(|c| [(c, 1), (c, 2)]) {
            let n = if segments == 2 { n + n % 4 } else { n };
            let x = vec![1.0; n];
            let held = one.install(|| {
                // (what earlier cases of smaller lengths kept is not this one's)
                BUFFERS.with_borrow_mut(|b| *b = Default::default());
                half::SCRATCH.with_borrow_mut(|b| *b = Default::default());
                let mut welch = Welch::new(n);
                let mut acc = Accumulator::new(vec![Axis::X], vec![Axis::X], n_lines(n));
                let seg = vec![&x[..], &x[..]];
                welch
                    .add_segments(&mut acc, None, 1, &vec![seg; segments])
                    .unwrap();
                assert_eq!(acc.averages, segments);
                BUFFERS.with_borrow(|(b, s)| b.capacity() + s.capacity())
                    + half::SCRATCH.with_borrow(Vec::capacity)
            });
            assert_eq!(held > 0, kept, "n {n}: {held} buffer elements held");
        }
    }

    #[test]
    fn solver_matches_known_solution() {
        let a0 = [
            Complex64::new(4.0, 0.0),
            Complex64::new(1.0, 1.0),
            Complex64::new(0.0, -2.0),
            Complex64::new(1.0, -1.0),
            Complex64::new(3.0, 0.0),
            Complex64::new(0.5, 0.0),
            Complex64::new(0.0, 2.0),
            Complex64::new(0.5, 0.0),
            Complex64::new(5.0, 0.0),
        ];
        let x = [
            Complex64::new(1.0, 2.0),
            Complex64::new(-1.0, 0.5),
            Complex64::new(0.3, -0.7),
        ];
        let mut b: Vec<Complex64> = (0..3)
            .map(|i| (0..3).map(|j| a0[i * 3 + j] * x[j]).sum())
            .collect();
        let mut a = a0.to_vec();
        assert!(solve_in_place(&mut a, &mut b, 3));
        for i in 0..3 {
            assert!((b[i] - x[i]).norm() < 1e-12);
        }
    }

    #[test]
    fn one_thread_in_pairs_equals_the_parallel_batches_bit_for_bit() {
        // one force, one, two and three responses (the first two added in one pass, a
        // third alone), an odd number of segments (the last one alone), with and without
        // the acceleration-to-displacement scale; segments of a multiple of 4 (realfft's
        // transform opened up, `half`) and of 2 modulo 4 (one segment at a time)
        let n = 5 * 512 + 37;
        let noise = |seed: u64| -> Vec<f64> {
            let mut x = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            (0..n)
                .map(|_| {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                })
                .collect()
        };
        let f = noise(1);
        // responses: the force smoothed, plus noise
        let y = |seed: u64, a: f64| -> Vec<f64> {
            let e = noise(seed);
            (0..n)
                .map(|i| a * (f[i] + 0.5 * f[i.saturating_sub(3)]) + 0.1 * e[i])
                .collect()
        };
        let kinds = [ResponseKind::Displacement, ResponseKind::Acceleration];
        let cases = (kinds.into_iter().flat_map(|k| [(k, 1), (k, 2), (k, 3)]))
            .flat_map(|c| [(c, 1024), (c, 1026)]);
        for ((kind, outputs), nfft) in cases {
            let rec = TimeSeries {
                dt: 1e-3,
                force: [Some(f.clone()), None, None],
                response: [
                    Some(y(2, 1.0)),
                    (outputs >= 2).then(|| y(3, -0.3)),
                    (outputs == 3).then(|| y(4, 0.7)),
                ],
                response_kind: Some(kind),
                ..TimeSeries::default()
            };
            let opts = FrfOptions {
                nfft: Some(nfft),
                excitation: Excitation::Continuous,
                ..FrfOptions::default()
            };
            let on = |threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| estimate_frf(std::slice::from_ref(&rec), &opts).unwrap())
            };
            let (one, three) = (on(1), on(3));
            assert_eq!(one.frf.channels.len(), outputs);
            for (a, b) in one.frf.channels.iter().zip(&three.frf.channels) {
                let bits = |c: &FrfChannel| -> Vec<u64> {
                    (c.h.iter().flat_map(|h| [h.re, h.im]))
                        .chain(c.coherence.iter().flatten().copied())
                        .map(f64::to_bits)
                        .collect()
                };
                assert_eq!(bits(a), bits(b), "{kind:?}, {outputs} outputs, nfft {nfft}");
            }
        }
    }

    #[test]
    fn flat_top_detects_clipping() {
        assert!(impact::flat_top(&[0.0, 1.0, 5.0, 5.0, 5.0, 2.0]));
        assert!(!impact::flat_top(&[0.0, 1.0, 5.0, 4.9, 5.0 - 1e-3, 2.0]));
        assert!(impact::flat_top(&[0.0, -5.0, -5.0, -5.0]));
    }

    #[test]
    fn octave_smoothing_on_lines_equals_the_general_one() {
        for n in [0, 1, 2, 17, 18, 100, 1000, 4097] {
            let v: Vec<f64> = (0..n).map(|k| ((k * 7919 % 1013) as f64).sin()).collect();
            let lines: Vec<f64> = (1..=n).map(|k| k as f64).collect();
            for oct in [1.0 / 12.0, 1.0 / 3.0, 1.0] {
                let (a, b) = (
                    smooth_octave_lines(&v, oct),
                    crate::plan::smooth_octave(&lines, &v, oct),
                );
                assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
                assert_eq!(a.len(), b.len());
            }
        }
    }

    #[test]
    fn windowing_flags_exactly_the_non_finite_samples() {
        let w = hann(64);
        let mut buf = vec![0.0; 64];
        let ok: Vec<f64> = (0..64).map(|i| (i as f64).sin()).collect();
        assert!(fill_windowed(&mut buf, &ok, &w));
        assert!(buf.iter().zip(&ok).zip(&w).all(|((b, x), w)| *b == x * w));
        // finite samples whose products overflow the check's sum
        assert!(fill_windowed(&mut buf, &[1.7e308; 64], &w));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for at in [0, 5, 63] {
                let mut x = ok.clone();
                x[at] = bad;
                assert!(!fill_windowed(&mut buf, &x, &w), "{bad} at {at}");
            }
        }
    }

    #[test]
    fn force_band_equals_the_band_of_the_buffered_smoothing() {
        // the band as it was found before: smoothed lines in a buffer, then the walk
        fn buffered(raw: &[f64], smooth: bool, lim: f64) -> Option<(usize, usize)> {
            let p = if smooth {
                smooth_octave_lines(raw, 1.0 / 12.0)
            } else {
                raw.to_vec()
            };
            let (kmax, &pmax) = p.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
            if pmax <= 0.0 {
                return None;
            }
            let lim = lim * pmax;
            let (mut lo, mut hi) = (kmax, kmax);
            while lo > 0 && p[lo - 1] >= lim {
                lo -= 1;
            }
            while hi + 1 < p.len() && p[hi + 1] >= lim {
                hi += 1;
            }
            Some((lo + 1, hi + 1))
        }
        for n in [0, 1, 7, 100, 4097] {
            for shape in 0..3 {
                let raw: Vec<f64> = (0..n)
                    .map(|k| match shape {
                        0 => ((k * 7919 % 1013) as f64).sin().abs() * (-(k as f64) / 500.0).exp(),
                        1 => 0.0,
                        _ => 1.0,
                    })
                    .collect();
                let mut acc = Accumulator::new(vec![Axis::X], vec![Axis::Y], n);
                acc.gff1.copy_from_slice(&raw);
                for smooth in [false, true] {
                    for lim in [0.01, 1e-4] {
                        assert_eq!(
                            acc.force_band_within(smooth, lim),
                            buffered(&raw, smooth, lim),
                            "n {n} shape {shape} smooth {smooth} lim {lim}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn welch_segment_count() {
        assert_eq!(welch_segments(100, 32, 0.5), (16, 5));
        assert_eq!(welch_segments(31, 32, 0.5).1, 0);
        assert_eq!(welch_segments(97, 97, 0.5), (48, 1));
    }
}
