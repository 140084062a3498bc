//! A measurement campaign becomes a twin: records grouped by pose, one FRF matrix and
//! one fit per pose (in parallel), modes tracked across poses, leave-one-pose-out
//! accuracy of the interpolation.

use crate::error::{Error, Result};
use crate::frf::{fit_percent, Frf};
use crate::interpolate::{Method, TwinEvaluator};
use crate::model::ModalModel;
use crate::plan::{
    campaign_exclusions, plan_pose, select_channels, Bands, EstimateFacts, PosePlan,
};
use crate::rational_fit::{fit_frf_steered, refine_from, FitOptions, Weighting};
use crate::spectra::{estimate_frf, FrfOptions};
use crate::stabilization::StabilizationDiagram;
use crate::timeseries::TimeSeries;
use crate::twin::{
    now_unix, ChannelFit, HistoryEntry, InterpolationInfo, LooEntry, OrderInfo, PoseModel, Twin,
};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

/// Options of [`identify_campaign`].
#[derive(Debug, Clone)]
pub struct CampaignOptions {
    /// FRF estimation.
    pub frf: FrfOptions,
    /// Rational fit (order, band, weighting).
    pub fit: FitOptions,
    /// Records whose mean positions agree within this distance \[m\] share a pose.
    pub pose_tol_m: f64,
    /// Name written into the twin.
    pub name: String,
    /// With the default coherence weighting, also fit each pose with the inverse-variance
    /// (maximum-likelihood) weighting and keep the model that fits the measured FRF better
    /// (channel fits in the band). Coherence weighting is robust on real impact data with
    /// model error; the ML weighting recovers weak modes far below the largest peak.
    pub try_ml_weighting: bool,
    /// Impact tests whose hits ring into the next (a mode the data see keeps more than
    /// [`crate::spectra::RINGING_LEVEL`] when the next hit comes): estimate again with
    /// each hit's response separated from the others' ([`crate::spectra::HitSeparation`])
    /// and identify again. Default on.
    pub separate_ringing_hits: bool,
}

impl Default for CampaignOptions {
    fn default() -> Self {
        CampaignOptions {
            frf: FrfOptions::default(),
            fit: FitOptions::default(),
            pose_tol_m: 1e-3,
            name: "machine".into(),
            try_ml_weighting: true,
            separate_ringing_hits: true,
        }
    }
}

/// Records measured at one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseGroup {
    /// Mean axis position of the records \[m\].
    pub pose: [f64; 3],
    /// Indices into the record list.
    pub records: Vec<usize>,
}

/// Groups records by their mean axis position (within `tol` metres).
pub fn group_by_pose(records: &[TimeSeries], tol: f64) -> Vec<PoseGroup> {
    let mut groups: Vec<PoseGroup> = Vec::new();
    for (i, r) in records.iter().enumerate() {
        let p = r.mean_position();
        let hit = groups.iter_mut().find(|g| {
            (0..3)
                .map(|a| (g.pose[a] - p[a]).powi(2))
                .sum::<f64>()
                .sqrt()
                <= tol
        });
        match hit {
            Some(g) => g.records.push(i),
            None => groups.push(PoseGroup {
                pose: p,
                records: vec![i],
            }),
        }
    }
    // stable order: by z, then y, then x
    groups.sort_by(|a, b| {
        (a.pose[2], a.pose[1], a.pose[0])
            .partial_cmp(&(b.pose[2], b.pose[1], b.pose[0]))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    groups
}

/// What [`identify_campaign`] found.
#[derive(Debug, Clone)]
pub struct CampaignResult {
    /// The twin (one pose model per pose group, tracked modes).
    pub twin: Twin,
    /// Warnings from FRF estimation and tracking, per pose.
    pub warnings: Vec<String>,
    /// The stabilization diagram of every pose, in the order of `twin.poses`.
    pub diagrams: Vec<StabilizationDiagram>,
}

#[derive(Clone)]
struct PoseFit {
    pose: [f64; 3],
    frf: Frf,
    /// `frf` with the channels the plan uses (what the fit saw).
    fitted: Frf,
    plan: PosePlan,
    options: FitOptions,
    model: ModalModel,
    order: OrderInfo,
    sigma: Option<f64>,
    sources: Vec<String>,
    warnings: Vec<String>,
    diagram: StabilizationDiagram,
    /// With the force directions fitted separately ([`separate_directions`]): one
    /// model per direction, over that direction's channels of `fitted`.
    parts: Vec<DirectionFit>,
    /// Channels the campaign keeps that this pose's data show no coherent response in:
    /// not in `fitted`, stored with zero numerators.
    held: Vec<crate::axis::Channel>,
    /// `model` at the pose's own automatic order (kept when the campaign fits it again at
    /// a common order; [`local_modes`]).
    own: ModalModel,
}

/// The fit of one force direction of a pose (see [`separate_directions`]).
#[derive(Clone)]
struct DirectionFit {
    fitted: Frf,
    model: ModalModel,
    diagram: StabilizationDiagram,
    /// `model` at the pose's own automatic order (see [`PoseFit::own`]).
    own: ModalModel,
}

/// The force directions a campaign fits with separate poles: all of them when every
/// cross channel between two hammered directions carries no coherent response at most
/// poses (the directions do not couple, as on a machine whose x and y modes are
/// independent), none otherwise. Common poles over decoupled directions must serve
/// modes of both: where an x mode and a y mode lie close together (137 Hz in x and
/// 137 Hz in y), one pole pair lands between them and fits neither, and the stopping
/// rule, judging all channels at once, ends before the order both directions need.
fn separate_directions(
    plans: &[PosePlan],
    excluded: &[crate::axis::Channel],
) -> Vec<crate::axis::Axis> {
    let mut inputs: Vec<crate::axis::Axis> = plans
        .iter()
        .flat_map(|p| p.used_channels())
        .map(|c| c.input)
        .collect();
    inputs.sort_by_key(|a| a.index());
    inputs.dedup();
    if inputs.len() < 2 {
        return Vec::new();
    }
    let measured = |c: crate::axis::Channel| {
        plans
            .iter()
            .any(|p| p.channels.iter().any(|d| d.channel == c))
    };
    let mut any_cross = false;
    for &a in &inputs {
        for &b in &inputs {
            if a == b {
                continue;
            }
            let c = crate::axis::Channel {
                output: b,
                input: a,
            };
            if !measured(c) {
                continue;
            }
            any_cross = true;
            if !excluded.contains(&c) {
                return Vec::new();
            }
        }
    }
    if any_cross {
        inputs
    } else {
        Vec::new()
    }
}

/// Adds `channels` to `model` with zero numerators and residual, in the channel order of
/// every pose model (by input, then output).
fn add_zero_channels(model: &mut ModalModel, channels: &[crate::axis::Channel]) {
    for &channel in channels {
        if model.channel_index(channel).is_none() {
            model.channels.push(crate::model::ChannelModel {
                channel,
                num: vec![crate::model::ModeNum { b0: 0.0, b1: 0.0 }; model.modes.len()],
                d: 0.0,
            });
        }
    }
    model
        .channels
        .sort_by_key(|c| (c.channel.input.index(), c.channel.output.index()));
}

/// One model of the modes of every part, in part order (the modes of part 0, then of
/// part 1, ...), each channel's numerators taken from the part that has the channel and
/// zero for the other parts' modes.
fn concat_models(parts: &[ModalModel]) -> ModalModel {
    let modes: Vec<crate::model::Mode> = parts.iter().flat_map(|p| p.modes.clone()).collect();
    let mut channels = Vec::new();
    let mut offset = 0;
    for p in parts {
        for cm in &p.channels {
            let mut num = vec![crate::model::ModeNum { b0: 0.0, b1: 0.0 }; modes.len()];
            num[offset..offset + p.modes.len()].copy_from_slice(&cm.num);
            channels.push(crate::model::ChannelModel {
                channel: cm.channel,
                num,
                d: cm.d,
            });
        }
        offset += p.modes.len();
    }
    ModalModel { modes, channels }
}

/// Below this fit \[%\] of a channel against its measured FRF in the band, the campaign
/// tries the alternative fits (inverse-variance weighting, a deeper stabilization
/// diagram) and keeps the best.
pub const TRY_ALTERNATIVES_BELOW: f64 = 97.0;
/// Below this fit \[%\] of a channel against its measured FRF in the band, identify
/// warns loudly (pose, channel, number, what to try).
pub const QUALITY_WARNING_BELOW: f64 = 90.0;

/// A channel whose fit is within this many points of what its noise allows
/// ([`ChannelFit::noise_limit_pct`]) gets no quality warning.
pub const NOISE_LIMIT_MARGIN: f64 = 5.0;

/// A pose's residue matrices made rank one (modal consistency, `consistency.rs`) are kept
/// while no direct channel's fit of its measured FRF drops by more than this \[points\].
pub const RANK_ONE_TOLERANCE_PCT: f64 = 0.5;

fn band_of(frf: &Frf, opts: &FitOptions) -> Bands {
    let lo = frf.freqs_hz.first().copied().unwrap_or(0.0);
    let hi = frf.freqs_hz.last().copied().unwrap_or(0.0);
    Bands::whole(
        opts.band_hz
            .map_or((lo, hi), |(a, b)| (a.max(lo), b.min(hi))),
    )
}

/// Per-channel agreement of `model` with `frf` within `band`, averaged over the octaves
/// of the band (the last one extended to the band's end): every part of the band counts
/// alike, whatever the FRF's dynamic range (a receptance from an accelerometer spans
/// decades, and one fit over the whole band only sees its low end). Each octave scores
/// `100 (1 − ‖H − F‖ / ‖H‖)`, its relative error: unlike the paper's fit against the
/// octave's mean, a nearly flat octave (a mass or stiffness line) that the model follows
/// to 1 % scores 99 %, not an arbitrary number set by how flat it is.
pub fn octave_fits(
    model: &ModalModel,
    frf: &Frf,
    bands: &Bands,
    averages: Option<usize>,
) -> Vec<ChannelFit> {
    let band = bands.pose;
    let lo = band.0.max(
        frf.freqs_hz
            .iter()
            .copied()
            .find(|f| *f > 0.0)
            .unwrap_or(1.0),
    );
    let mut edges = vec![lo];
    while edges.last().copied().unwrap_or(lo) * 2.0 < band.1 {
        let e = edges.last().copied().unwrap_or(lo) * 2.0;
        edges.push(e);
    }
    if edges.len() > 1 && band.1 / edges.last().copied().unwrap_or(lo) < 1.5 {
        edges.pop();
    }
    edges.push(band.1);
    let parts: Vec<Vec<ChannelFit>> = edges
        .windows(2)
        .map(|e| relative_fits(model, frf, &bands.within((e[0], e[1])), averages))
        .filter(|f| !f.is_empty())
        .collect();
    let Some(first) = parts.first() else {
        return Vec::new();
    };
    first
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let v: Vec<f64> = parts
                .iter()
                .filter_map(|p| p.get(ci).map(|x| x.fit_pct))
                .filter(|x| x.is_finite())
                .collect();
            ChannelFit {
                channel: c.channel,
                fit_pct: if v.is_empty() {
                    f64::NAN
                } else {
                    v.iter().sum::<f64>() / v.len() as f64
                },
                noise_limit_pct: None,
                noise_free_fit_pct: None,
                band_hz: bands.own(c.channel),
            }
        })
        .collect()
}

/// Variance of an H1 line `h` of coherence estimate `g` from `n` averages:
/// `|H|² (1−γ²)/(n γ²)` (real and imaginary parts together), with the estimate's upward
/// bias removed, `γ² ≈ (n γ̂² − 1)/(n − 1)`, and `|Ĥ|² ≈ |H|² (1 + r)` for
/// `r = (1−γ²)/(n γ²)`, so a line of pure noise has the variance of its own value.
fn h1_variance(h: Complex64, g: f64, n: usize) -> f64 {
    let nf = n as f64;
    let g = ((nf * g - 1.0) / (nf - 1.0)).clamp(0.0, 1.0);
    let r = (1.0 - g) / (g * nf).max(1e-300);
    h.norm_sqr() * r / (1.0 + r)
}

/// Per-channel `100 − mean_k |H − F|² / σ_k²` over the lines of `band`, with `σ_k²` the
/// H1 variance of each line ([`h1_variance`]): the likelihood of `model` given the
/// estimate, as a score (a model within the noise scores about 99).
fn noise_scores(model: &ModalModel, frf: &Frf, bands: &Bands, n: usize) -> Vec<ChannelFit> {
    let b = frf.band(bands.pose.0, bands.pose.1);
    b.channels
        .iter()
        .filter_map(|c| {
            let ci = model.channel_index(c.channel)?;
            let g = c.coherence.as_ref()?;
            let peak = c.h.iter().map(|h| h.norm_sqr()).fold(0.0, f64::max);
            let (mut chi2, mut lines) = (0.0, 0usize);
            let (lo, hi) = bands.of(c.channel);
            for (k, &f) in b.freqs_hz.iter().enumerate() {
                if f < lo || f > hi {
                    continue;
                }
                let var = h1_variance(c.h[k], g[k], n).max(1e-12 * peak);
                if var > 0.0 {
                    chi2 += (c.h[k] - model.eval_hz(ci, f)).norm_sqr() / var;
                    lines += 1;
                }
            }
            Some(ChannelFit {
                channel: c.channel,
                fit_pct: if lines > 0 {
                    100.0 - chi2 / lines as f64
                } else {
                    f64::NAN
                },
                noise_limit_pct: None,
                noise_free_fit_pct: None,
                band_hz: bands.own(c.channel),
            })
        })
        .collect()
}

/// Per-channel `100 (1 − √(‖H − F‖² − E‖noise‖²) / ‖H‖)` of `model` against `frf` within
/// `band`: the relative error, less what the estimate's noise accounts for (from its
/// coherence and `averages`, when both are known) — a model is not scored on the noise.
fn relative_fits(
    model: &ModalModel,
    frf: &Frf,
    bands: &Bands,
    averages: Option<usize>,
) -> Vec<ChannelFit> {
    let b = frf.band(bands.pose.0, bands.pose.1);
    b.channels
        .iter()
        .filter_map(|c| {
            let ci = model.channel_index(c.channel)?;
            let (mut err, mut norm, mut noise) = (0.0, 0.0, 0.0);
            let (lo, hi) = bands.of(c.channel);
            for (k, &f) in b.freqs_hz.iter().enumerate() {
                if f < lo || f > hi {
                    continue;
                }
                err += (c.h[k] - model.eval_hz(ci, f)).norm_sqr();
                norm += c.h[k].norm_sqr();
                if let (Some(g), Some(n)) = (&c.coherence, averages) {
                    if n > 1 {
                        noise += h1_variance(c.h[k], g[k], n);
                    }
                }
            }
            Some(ChannelFit {
                channel: c.channel,
                fit_pct: if norm > 0.0 {
                    100.0 * (1.0 - ((err - noise).max(0.0) / norm).sqrt())
                } else {
                    f64::NAN
                },
                noise_limit_pct: None,
                noise_free_fit_pct: None,
                band_hz: bands.own(c.channel),
            })
        })
        .collect()
}

/// Per-channel fit of `model` against `frf` within `band`, both multiplied by `(jω)^power`
/// first (1: mobility, 2: accelerance): the fit on the FRF the sensor measured.
pub fn channel_fits_as(
    model: &ModalModel,
    frf: &Frf,
    bands: &Bands,
    power: i32,
    averages: Option<usize>,
) -> Vec<ChannelFit> {
    frf.channels
        .iter()
        .filter_map(|c| {
            let ci = model.channel_index(c.channel)?;
            let (lo, hi) = bands.of(c.channel);
            let lines: Vec<usize> = (0..frf.freqs_hz.len())
                .filter(|&k| frf.freqs_hz[k] >= lo && frf.freqs_hz[k] <= hi)
                .collect();
            let jw = |f: f64| Complex64::new(0.0, 2.0 * std::f64::consts::PI * f).powi(power);
            let h: Vec<_> = lines
                .iter()
                .map(|&k| c.h[k] * jw(frf.freqs_hz[k]))
                .collect();
            let m: Vec<_> = lines
                .iter()
                .map(|&k| model.eval_hz(ci, frf.freqs_hz[k]) * jw(frf.freqs_hz[k]))
                .collect();
            // the noise's share of the FRF's scatter (variance summed over the lines) and
            // the scatter itself
            let noise = match (&c.coherence, averages) {
                (Some(g), Some(n)) if n > 1 => {
                    let vars: Vec<f64> = h
                        .iter()
                        .zip(&lines)
                        .map(|(h, &k)| h1_variance(*h, g[k], n))
                        .collect();
                    let var = vars.iter().sum::<f64>() * line_noise_scale(&h, &vars);
                    let mean = h.iter().sum::<Complex64>() / h.len().max(1) as f64;
                    let spread: f64 = h.iter().map(|v| (v - mean).norm_sqr()).sum();
                    (spread > 0.0).then_some((var, spread))
                }
                _ => None,
            };
            let noise_limit_pct = noise.map(|(var, spread)| 100.0 * (1.0 - (var / spread).sqrt()));
            // the model's fit to the noise-free FRF, estimated: the misfit's power less the
            // noise's (model error and noise are independent), over the scatter less the
            // noise's; a model within the noise scores 100 %
            let noise_free_fit_pct = noise.map(|(var, spread)| {
                let err: f64 = h.iter().zip(&m).map(|(a, b)| (a - b).norm_sqr()).sum();
                let signal = (spread - var).max(0.05 * spread);
                100.0 * (1.0 - ((err - var).max(0.0) / signal).sqrt())
            });
            Some(ChannelFit {
                channel: c.channel,
                fit_pct: fit_percent(&h, &m),
                noise_limit_pct,
                noise_free_fit_pct,
                band_hz: bands.own(c.channel),
            })
        })
        .collect()
}

/// How much larger the scatter of an estimate from line to line is than its coherence
/// predicts (≥ 1): the median of `|H_k − (H_{k−1} + H_{k+1})/2|² / (1.5 σ_k²)` over the
/// lines, divided by ln 2 (the median of an exponential variable of unit mean). The
/// coherence sees only noise that differs between averages; leakage between hits that
/// ring into each other, or a window's bias, scatter the estimate too (measured on the
/// tryout campaign: its H1 misses the truth by about √3 times the coherence's σ, and this
/// factor finds 2.5–3). A smooth FRF's curvature reaches the median only when most lines
/// sit on sharp peaks. Returns 1 when it cannot tell (fewer than 9 lines).
pub(crate) fn line_noise_scale(h: &[Complex64], vars: &[f64]) -> f64 {
    if h.len() < 9 {
        return 1.0;
    }
    let mut r: Vec<f64> = (1..h.len() - 1)
        .filter(|&k| vars[k] > 0.0)
        .map(|k| (h[k] - (h[k - 1] + h[k + 1]) * 0.5).norm_sqr() / (1.5 * vars[k]))
        .collect();
    if r.len() < 7 {
        return 1.0;
    }
    let mid = r.len() / 2;
    let (_, m, _) = r.select_nth_unstable_by(mid, f64::total_cmp);
    (*m / std::f64::consts::LN_2).max(1.0)
}

/// A channel's constant residual `d` (the receptance of the modes above the band) fitted
/// to noise on a weak channel is invisible in the receptance but dominates the measured
/// accelerance or mobility at the top of the band (`ω² d`). Where the FRF the sensor
/// measured is fitted better without it, it is set to zero in `model` and `windowed`
/// (the same model before the window's damping was removed); one note per channel.
fn drop_unsupported_residuals(
    model: &mut ModalModel,
    windowed: &mut ModalModel,
    frf: &Frf,
    band: &Bands,
    power: i32,
) -> Vec<String> {
    let mut notes = Vec::new();
    let with = channel_fits_as(windowed, frf, band, power, None);
    for c in with {
        let Some(ci) = windowed.channel_index(c.channel) else {
            continue;
        };
        if windowed.channels[ci].d == 0.0 {
            continue;
        }
        let mut trial = windowed.clone();
        trial.channels[ci].d = 0.0;
        let without = channel_fits_as(&trial, frf, band, power, None)
            .into_iter()
            .find(|x| x.channel == c.channel)
            .map_or(f64::NEG_INFINITY, |x| x.fit_pct);
        if without > c.fit_pct {
            notes.push(format!(
                "channel {}: constant residual dropped (fit of the measured FRF {:.1} % -> {:.1} %)",
                c.channel, c.fit_pct, without
            ));
            windowed.channels[ci].d = 0.0;
            if let Some(mi) = model.channel_index(c.channel) {
                model.channels[mi].d = 0.0;
            }
        }
    }
    notes
}

/// Per-channel fit of `model` against `frf` within `band`.
pub fn channel_fits(model: &ModalModel, frf: &Frf, band: (f64, f64)) -> Vec<ChannelFit> {
    channel_fits_as(model, frf, &Bands::whole(band), 0, None)
}

/// The mean fit \[%\] of `model` (a model of pose `p`, or one changed from it) to the FRF
/// that pose was identified from, over its direct channels in its band (the automatic
/// exponential window's pole shift taken off first).
pub fn direct_data_fit(p: &crate::twin::PoseModel, model: &ModalModel) -> f64 {
    let mut w = model.clone();
    if let Some(s) = p.frf_exp_window_sigma {
        w.shift_poles(-s);
    }
    let fits = channel_fits(&w, &p.frf, (p.band_hz[0], p.band_hz[1]));
    let d: Vec<f64> = fits
        .iter()
        .filter(|c| c.channel.output == c.channel.input && c.fit_pct.is_finite())
        .map(|c| c.fit_pct)
        .collect();
    d.iter().sum::<f64>() / d.len().max(1) as f64
}

/// A measured FRF matrix at one pose: the input of [`identify_frfs`].
#[derive(Debug, Clone)]
pub struct MeasuredFrf {
    /// Axis position \[m\].
    pub pose: [f64; 3],
    /// Receptance FRFs (m/N), with coherence when known.
    pub frf: Frf,
    /// Decay rate \[1/s\] of an exponential window applied to the records, when one
    /// was (its added damping is removed from the fitted poles).
    pub exp_window_sigma: Option<f64>,
    /// Where the FRF came from (file names).
    pub sources: Vec<String>,
    /// Warnings from its estimation.
    pub warnings: Vec<String>,
    /// What the estimate says about the excitation (band, averages, estimator), for the
    /// plan ([`crate::plan`]).
    pub facts: EstimateFacts,
}

impl MeasuredFrf {
    /// A measured FRF file ([`crate::io::measured::read_frf_file`]) as one pose (at the
    /// origin when neither the file nor the caller gave one).
    pub fn from_file(path: &std::path::Path, file: crate::io::measured::FrfFile) -> Self {
        let notes = file.notes;
        MeasuredFrf {
            facts: EstimateFacts {
                measured_as: file.measured_as,
                excitation_band_hz: notes.force_band_hz,
                averages: notes.averages,
                averages_per_channel: notes.averages,
                coherence_dof: notes.coherence_dof,
                method: format!(
                    "not known (measured FRFs given, no time series to recognise it from){}",
                    notes.exp_window_sigma.map_or(String::new(), |s| format!(
                        "; made with an exponential window of {s:.3} 1/s, which the file \
                         states (estimate = H(s + sigma))"
                    ))
                ),
            },
            pose: file.pose.unwrap_or([0.0; 3]),
            frf: file.frf,
            exp_window_sigma: notes.exp_window_sigma,
            sources: vec![path.display().to_string()],
            warnings: Vec::new(),
        }
    }
}

/// Drops the FRF estimate's hint about identify's automatic band from `warnings`: it
/// does not apply when the caller gave the band's top (`--fmax`).
pub fn drop_automatic_band_hint(warnings: &mut [String]) {
    for w in warnings {
        if let Some(i) = w.find(" (identify's automatic band stops there)") {
            w.truncate(i);
        }
    }
}

/// Identifies a twin from a measurement campaign (one or many poses).
///
/// `progress(done, total)` is called as poses finish (from worker threads).
pub fn identify_campaign(
    records: &[TimeSeries],
    opts: &CampaignOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<CampaignResult> {
    if records.is_empty() {
        return Err(Error::BadInput("no data files given".into()));
    }
    let groups = group_by_pose(records, opts.pose_tol_m);
    let estimate = |g: &PoseGroup,
                    sep: Option<&crate::spectra::HitSeparation>|
     -> Result<(MeasuredFrf, Option<f64>)> {
        let recs: Vec<TimeSeries> = g.records.iter().map(|&i| records[i].clone()).collect();
        let mut frf_opts = opts.frf.clone();
        frf_opts.impact.separation = sep.cloned();
        let mut est = estimate_frf(&recs, &frf_opts)?;
        // the sensor's mass loading removed where the records state it and the
        // caller asks for it (mass_loading; in the frequency domain: the impact
        // estimate's force window would cut a force f − m·a corrected in time)
        if let Some(m) = crate::mass_loading::common_sensor_mass_kg(&recs)
            .filter(|_| crate::mass_loading::enabled())
        {
            crate::mass_loading::unload_frf(&mut est.frf, m, est.exp_window_sigma.unwrap_or(0.0));
            est.warnings.push(format!(
                "mass loading removed: the records state a sensor mass of {:.1} g at the \
                 tool (sensor_mass={m}); the twin is of the structure without it",
                m * 1e3
            ));
        }
        let hit_record_s = est.hit_record_s;
        Ok((
            MeasuredFrf {
                facts: EstimateFacts {
                    excitation_band_hz: est.excitation_band_hz,
                    coherence_dof: est.coherence_dof,
                    averages: Some(est.hits_used),
                    averages_per_channel: Some(est.averages_per_channel),
                    method: est.method.clone(),
                    measured_as: recs.first().and_then(|r| match r.response_kind {
                        Some(crate::timeseries::ResponseKind::Acceleration) => {
                            Some(crate::plan::MeasuredAs::Accelerance)
                        }
                        Some(crate::timeseries::ResponseKind::Displacement) => {
                            Some(crate::plan::MeasuredAs::Receptance)
                        }
                        None => None,
                    }),
                },
                pose: g.pose,
                frf: est.frf,
                exp_window_sigma: est.exp_window_sigma,
                sources: recs.iter().map(|r| r.source.clone()).collect(),
                warnings: est.warnings,
            },
            hit_record_s,
        ))
    };
    let first: Vec<(MeasuredFrf, Option<f64>)> = groups
        .par_iter()
        .map(|g| estimate(g, None))
        .collect::<Result<_>>()?;
    let record_s: Vec<Option<f64>> = first.iter().map(|m| m.1).collect();
    let measured: Vec<MeasuredFrf> = first.into_iter().map(|m| m.0).collect();
    let mut res = identify_frfs(measured.clone(), opts, progress)?;
    // hits that ring into the next (a mode the data see keeps more than RINGING_LEVEL of
    // its amplitude when the next hit comes): the poses estimated again with each hit's
    // response separated from the others' over the first fit's poles, and the campaign
    // identified again (a second round was measured to change nothing: the first fit's
    // poles are right, its residues are what the ringing biases)
    let ringing: Vec<(usize, crate::spectra::HitSeparation, String)> = groups
        .iter()
        .enumerate()
        .filter(|_| opts.separate_ringing_hits)
        .filter_map(|(i, g)| {
            let t = record_s[i]?;
            let pm = res
                .twin
                .poses
                .iter()
                .find(|p| (0..3).all(|k| (p.pose[k] - g.pose[k]).abs() <= opts.pose_tol_m))?;
            ringing_modes(&pm.model, &pm.frf, pm.band_hz, t).map(|(sep, why)| (i, sep, why))
        })
        .collect();
    if !ringing.is_empty() {
        let again: Vec<(usize, MeasuredFrf, String)> = ringing
            .par_iter()
            .map(|(i, sep, why)| Ok((*i, estimate(&groups[*i], Some(sep))?.0, why.clone())))
            .collect::<Result<_>>()?;
        let mut measured = measured;
        for (i, mut m, why) in again {
            m.facts.method = format!("{}; {why}", m.facts.method);
            measured[i] = m;
        }
        res = identify_frfs(measured, opts, progress)?;
    }
    if let Some(h) = res.twin.history.last_mut() {
        h.summary = format!(
            "a-priori twin from {} at {}",
            crate::axis::count(records.len(), "record"),
            crate::axis::count(res.twin.poses.len(), "pose")
        );
    }
    Ok(res)
}

/// Half-width (a frequency ratio, 1/6 octave) of the neighbourhood in which
/// [`ringing_modes`] looks for a mode's clear coherence.
const NEIGHBOURHOOD: f64 = 1.122_462_048_309_373;

/// The poles to separate hits with when a mode of `model` inside `band` keeps more
/// than [`crate::spectra::RINGING_LEVEL`] of its amplitude after `record_s` and the
/// measured `frf` sees it clearly (a direct channel's coherence, smoothed over 1/6
/// octave, at least [`crate::plan::MAX_TRUST_COHERENCE`] at its frequency or within
/// [`NEIGHBOURHOOD`] of it, since the ringing makes it dip at the resonance: where noise
/// hides a mode, its decay cannot be told from the noise either), with the evidence
/// (every stable mode's pole: the free decays are fitted over all of them); `None`
/// otherwise.
fn ringing_modes(
    model: &ModalModel,
    frf: &Frf,
    band: [f64; 2],
    record_s: f64,
) -> Option<(crate::spectra::HitSeparation, String)> {
    let stable: Vec<&crate::model::Mode> = model
        .modes
        .iter()
        .filter(|m| m.wn > 0.0 && m.zeta > 0.0 && m.zeta < 1.0)
        .collect();
    let clear: Vec<Vec<f64>> = frf
        .channels
        .iter()
        .filter(|c| c.channel.input == c.channel.output)
        .filter_map(|c| c.coherence.as_ref())
        .map(|g| crate::plan::smooth_octave(&frf.freqs_hz, g, 1.0 / 12.0))
        .collect();
    // ... at its frequency or within 1/6 octave of it: the ringing itself makes the
    // coherence dip at the resonance (each hit's record holds a different share of the
    // previous hits' decay; vmachine, hits 0.35 s apart, a 77.6 Hz mode at 0.5 % keeping
    // 42 %: 0.84 smoothed at its peak, 0.98 a sixth of an octave below)
    let seen = |f: f64| {
        let (lo, hi) = (f / NEIGHBOURHOOD, f * NEIGHBOURHOOD);
        let near: Vec<usize> = (0..frf.freqs_hz.len())
            .filter(|&k| frf.freqs_hz[k] >= lo && frf.freqs_hz[k] <= hi)
            .collect();
        clear.iter().any(|g| {
            near.iter().any(|&k| {
                g.get(k)
                    .is_some_and(|&v| v >= crate::plan::MAX_TRUST_COHERENCE)
            })
        })
    };
    // what each mode keeps of its amplitude when the next hit comes, where it rings
    let left: Vec<Option<f64>> = stable
        .iter()
        .map(|m| {
            let left = (-m.zeta * m.wn * record_s).exp();
            ((band[0]..=band[1]).contains(&m.freq_hz())
                && seen(m.freq_hz())
                && left > crate::spectra::RINGING_LEVEL)
                .then_some(left)
        })
        .collect();
    let continued: Vec<bool> = left.iter().map(Option::is_some).collect();
    let ringing: Vec<String> = stable
        .iter()
        .zip(&left)
        .filter_map(|(m, l)| l.map(|l| format!("{:.0} Hz keeps {:.1} %", m.freq_hz(), 100.0 * l)))
        .collect();
    if ringing.is_empty() {
        return None;
    }
    Some((
        crate::spectra::HitSeparation {
            poles: stable.iter().map(|m| m.pole()).collect(),
            continued,
        },
        format!(
            "hits ring into the next ({} after the {:.3} s between hits): each hit's response separated from the others' free decays (over the poles of a first fit) and identified again",
            ringing.join(", "),
            record_s
        ),
    ))
}

/// Identifies a twin from FRFs already measured (e.g. read from UFF dataset 58 or an FRF
/// CSV): one fit per pose (in parallel), modes tracked across poses, leave-one-pose-out
/// accuracy of the interpolation. Entries at the same pose (within
/// [`CampaignOptions::pose_tol_m`]) are not merged: give each pose once.
pub fn identify_frfs(
    measured: Vec<MeasuredFrf>,
    opts: &CampaignOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<CampaignResult> {
    if measured.is_empty() {
        return Err(Error::BadInput("no FRFs given".into()));
    }
    for (i, a) in measured.iter().enumerate() {
        for b in &measured[i + 1..] {
            let d = (0..3)
                .map(|k| (a.pose[k] - b.pose[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if d <= opts.pose_tol_m {
                return Err(Error::BadInput(format!(
                    "{} and {} are both at pose {}: give each pose once (merge the \
                     channels into one file) or set distinct poses",
                    a.sources.join("+"),
                    b.sources.join("+"),
                    crate::axis::PoseText(a.pose)
                )));
            }
        }
    }
    let total = measured.len();
    let n_sources: usize = measured.iter().map(|m| m.sources.len()).sum();
    let all_sources: Vec<String> = measured.iter().flat_map(|m| m.sources.clone()).collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    // the plan: band and channels per pose, channels decided over the campaign
    let first: Vec<PosePlan> = measured
        .iter()
        .map(|m| plan_pose(&m.frf, &m.facts, opts.fit.band_hz, &[], total == 1))
        .collect();
    let excluded = campaign_exclusions(&first);
    // one band for the campaign: poses whose own bands start at 42 Hz and at 138 Hz see
    // different modes (the 73 Hz mode is in one band, a mass line in the other), and
    // tracking cannot pair modes that only some poses hold
    let common_band = if total > 1 {
        let extended: Vec<PosePlan> = measured
            .iter()
            .map(|m| plan_pose(&m.frf, &m.facts, opts.fit.band_hz, &[], true))
            .collect();
        Some(campaign_band(&first, &extended))
    } else {
        None
    };
    let directions = if total > 1 && opts.fit.n_modes.is_none() {
        separate_directions(&first, &excluded)
    } else {
        Vec::new()
    };
    let fits: Vec<Result<PoseFit>> = measured
        .into_par_iter()
        .map(|m| {
            let mut plan = plan_pose(&m.frf, &m.facts, opts.fit.band_hz, &excluded, total == 1);
            let held = if total > 1 {
                crate::plan::hold_campaign_channels(&mut plan, &first, &excluded)
            } else {
                Vec::new()
            };
            if let Some((lo, hi, q)) = common_band {
                let (a, b) = (
                    lo.max(*m.frf.freqs_hz.first().unwrap_or(&lo)),
                    hi.min(*m.frf.freqs_hz.last().unwrap_or(&hi)),
                );
                if a < b && (a, b) != (plan.band_hz[0], plan.band_hz[1]) {
                    plan.band_evidence.push(format!(
                        "campaign: one band for every pose, {a:.1}-{b:.1} Hz ({q}; this \
                         pose's own {:.1}-{:.1} Hz), so every pose model holds the same modes",
                        plan.band_hz[0], plan.band_hz[1]
                    ));
                    plan.band_hz = [a, b];
                }
            }
            // which channels steer the poles: for a single pose the plan's steering channels
            // (on the second generator's poses alone this raised xx/yy vs truth from 69-98
            // to 93-98.6 %); in a campaign all the used ones, whose shapes the tracking pairs
            // across poses (with the rule there, its x direction's measured poses fell from
            // 87-97 to 83-96 %)
            // what the fit sees: the used channels, less those held at zero
            let mut fitting = plan.used_channels();
            fitting.retain(|c| !held.contains(c));
            let steer = if total == 1 {
                for d in plan.channels.iter_mut() {
                    if d.used && !crate::plan::steers(d) {
                        d.reason.push_str(
                            "; does not steer the poles (coherent in part of the band only): \
                             its numerators are fitted with the poles of the others held",
                        );
                    }
                }
                crate::plan::steering_channels(&plan)
            } else {
                fitting.clone()
            };
            let fitted = select_channels(&m.frf, &fitting);
            let options = FitOptions {
                band_hz: Some((plan.band_hz[0], plan.band_hz[1])),
                // a windowed Welch estimate biases sharp peaks: no local order check there
                sharp_peaks: opts.fit.sharp_peaks && !m.facts.method.contains("Welch"),
                ..opts.fit.clone()
            };
            // one pole set per force direction only for a single pose: a campaign's
            // tracking and interpolation pair common poles (forced at every pose of the
            // second generator's campaign, per-direction sets raised the measured poses
            // from 85.9 to 94.8 % vs truth and broke the interpolation between them)
            let per_input = if total == 1 && opts.fit.n_modes.is_none() {
                PerInput::Try
            } else {
                PerInput::Never
            };
            let mut warnings = m.warnings;
            let mut parts = Vec::new();
            let (res, plan) = if directions.is_empty() {
                fit_pose(&fitted, &options, plan, opts, m.pose, per_input, &steer)?
            } else {
                // one fit per force direction, tracked apart (see separate_directions)
                let mut merged_plan = plan.clone();
                merged_plan.alternatives.push(format!(
                    "force directions {} fitted with separate poles: the cross channels \
                     between them carry no coherent response at most poses (the directions \
                     do not couple)",
                    directions
                        .iter()
                        .map(|a| a.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
                let mut first_res = None;
                for a in &directions {
                    let chans: Vec<crate::axis::Channel> = fitted
                        .channels
                        .iter()
                        .map(|c| c.channel)
                        .filter(|c| c.input == *a)
                        .collect();
                    if chans.is_empty() {
                        continue;
                    }
                    let sub = select_channels(&fitted, &chans);
                    let sub_options = FitOptions {
                        direct_at_noise: true,
                        ..options.clone()
                    };
                    let (r, p) = fit_pose(
                        &sub,
                        &sub_options,
                        plan.clone(),
                        opts,
                        m.pose,
                        per_input,
                        &steer,
                    )?;
                    merged_plan.alternatives.extend(
                        p.alternatives
                            .into_iter()
                            .map(|t| format!("force {a}: {t}")),
                    );
                    let mut model = r.model.clone();
                    if let Some(s) = m.exp_window_sigma {
                        model.shift_poles(s);
                        warnings.extend(repair_window_damping(&mut model, s));
                    }
                    parts.push(DirectionFit {
                        fitted: sub,
                        own: model.clone(),
                        model,
                        diagram: r.diagram.clone(),
                    });
                    if first_res.is_none() {
                        first_res = Some(r);
                    }
                }
                let mut r = first_res.ok_or_else(|| {
                    Error::BadInput(format!(
                        "pose {}: no channel to fit",
                        crate::axis::PoseText(m.pose)
                    ))
                })?;
                // the merged model is already unwindowed: no second shift below
                r.model = concat_models(&parts.iter().map(|p| p.model.clone()).collect::<Vec<_>>());
                r.automatic_order = parts.len() > 1 || r.automatic_order;
                (r, merged_plan)
            };
            let mut model = res.model;
            if parts.is_empty() {
                if let Some(s) = m.exp_window_sigma {
                    model.shift_poles(s);
                    warnings.extend(repair_window_damping(&mut model, s));
                }
            }
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(n, total);
            Ok(PoseFit {
                own: model.clone(),
                pose: m.pose,
                order: OrderInfo {
                    modes: model.modes.len(),
                    // an order raised by the alternatives is still the automatic choice
                    automatic: res.automatic_order || opts.fit.n_modes.is_none(),
                    stable_freqs_hz: res.diagram.stable_freqs_hz(),
                },
                frf: m.frf,
                fitted,
                plan,
                options,
                model,
                sigma: m.exp_window_sigma,
                sources: m.sources,
                warnings,
                diagram: res.diagram,
                parts,
                held,
            })
        })
        .collect();
    let mut fits: Vec<PoseFit> = fits.into_iter().collect::<Result<_>>()?;
    fits.sort_by(|a, b| {
        (a.pose[2], a.pose[1], a.pose[0])
            .partial_cmp(&(b.pose[2], b.pose[1], b.pose[0]))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let build = |fits: Vec<PoseFit>, judge: Judge| {
        build_twin(fits, &directions, opts, &all_sources, n_sources, judge)
    };
    if total < 3 || opts.fit.n_modes.is_some() {
        return build(fits, Judge::AllChannels);
    }
    // Tracking one mode set over poses whose own automatic orders differ can cost the
    // measured poses their fit (lumped machines: 61-91 % vs the truth where the poses
    // alone reach 95-98 %), and which remedy helps depends on the machine. So the twin
    // is built three ways and the one whose measured poses fit their own measured
    // receptance best (direct channels; on five lumped machines this picked the variant
    // closest to the truth) is kept: the poses' own orders, the poses fitted again at
    // the campaign's common order, and that with the tracking judged by the direct
    // channels only.
    let mut common = fits.clone();
    let refitted = refit_at_common_order(&mut common, opts)?;
    let mut variants = vec![("own orders", build(fits, Judge::AllChannels)?)];
    if refitted > 0 {
        variants.push(("common order", build(common.clone(), Judge::AllChannels)?));
    }
    // judged by the direct channels, tracking differs only where the fit saw others
    let cross = (common.iter())
        .any(|f| (f.fitted.channels.iter()).any(|c| c.channel.output != c.channel.input));
    if cross {
        variants.push((
            if refitted > 0 {
                "common order, tracking judged by the direct channels"
            } else {
                "tracking judged by the direct channels"
            },
            build(common, Judge::Direct)?,
        ));
    }
    if variants.len() == 1 {
        return Ok(variants.swap_remove(0).1);
    }
    // the mean, the worst pose and the leave-one-pose-out mean count alike: a variant that
    // gains a point on average but wrecks one pose (lumped seed 4: worst 87 -> 73 % vs the
    // truth), or whose interpolation between the poses fails (lumped seed 1: leave-one-
    // pose-out -1e9 %), is not kept
    let figures: Vec<(f64, f64, f64)> = variants
        .iter()
        .map(|(_, r)| measured_direct_fit(r))
        .collect();
    let scores: Vec<f64> = (figures.iter())
        .map(|(m, w, b)| m + w + if b.is_finite() { *b } else { 0.5 * (m + w) })
        .collect();
    // another variant replaces the poses' own orders only for a clear gain (they coincide
    // when every pose has the common order and the tracking keeps the same models)
    let mut best = 0;
    for i in 1..variants.len() {
        let margin = if best == 0 { VARIANT_MIN_GAIN } else { 0.0 };
        if scores[i] > scores[best] + margin || !scores[best].is_finite() {
            best = i;
        }
    }
    let note = format!(
        "campaign built {} ways, judged by the direct channels' fit of their measured \
         receptance at the measured poses (mean, worst pose) and between them: {}; kept: {}",
        variants.len(),
        variants
            .iter()
            .zip(&figures)
            .map(|((name, _), (m, w, b))| format!(
                "{name} {m:.2} / {w:.2} % (leave-one-pose-out {b:.2} %)"
            ))
            .collect::<Vec<_>>()
            .join(", "),
        variants[best].0
    );
    let mut keep = variants.swap_remove(best).1;
    for p in keep.twin.poses.iter_mut() {
        if let Some(pl) = p.plan.as_mut() {
            pl.alternatives.push(note.clone());
        }
    }
    Ok(keep)
}

/// The least gain \[points of the summed score\] for which a campaign variant replaces the
/// poses' own orders (the vmachine FMU fixture's variants score within 0.02 points).
const VARIANT_MIN_GAIN: f64 = 1.0;

/// How well a twin's measured poses fit the FRFs measured there: its direct channels'
/// fit of the receptance (each channel in its band), the mean over the poses and the
/// worst pose; and the leave-one-pose-out mean of the direct channels (each pose at
/// least -100 %; NaN without).
fn measured_direct_fit(r: &CampaignResult) -> (f64, f64, f64) {
    let fits: Vec<f64> = (r.twin.poses.iter())
        .filter_map(|p| {
            let plan = p.plan.as_ref()?;
            let mut w = p.model.clone();
            if let Some(s) = p.frf_exp_window_sigma {
                w.shift_poles(-s);
            }
            let bands = plan.bands((p.band_hz[0], p.band_hz[1]));
            let f = direct_mean_fit(&channel_fits_as(&w, &p.frf, &bands, 0, None));
            f.is_finite().then_some(f.max(-100.0))
        })
        .collect();
    if fits.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mean = fits.iter().sum::<f64>() / fits.len() as f64;
    let loo = &r.twin.interpolation.leave_one_out;
    let between = if loo.is_empty() {
        f64::NAN
    } else {
        loo.iter()
            .map(|e| direct_mean_fit(&e.fit).max(-100.0))
            .sum::<f64>()
            / loo.len() as f64
    };
    (
        mean,
        fits.iter().cloned().fold(f64::INFINITY, f64::min),
        between,
    )
}

/// A campaign's twin from its pose fits (tracking judged as `judge` says).
fn build_twin(
    fits: Vec<PoseFit>,
    directions: &[crate::axis::Axis],
    opts: &CampaignOptions,
    all_sources: &[String],
    n_sources: usize,
    judge: Judge,
) -> Result<CampaignResult> {
    // a tracked mode that departs from a smooth trend over the poses gets one pole for
    // every pose unless that costs a measured pose its fit; where it does, both twins are
    // built and the one that fits better where measured and between the poses is kept
    let guarded = finish_campaign(
        fits.clone(),
        directions,
        opts,
        all_sources,
        n_sources,
        Freeze::Guarded,
        judge,
    )?;
    if !guarded.refused_freeze {
        return Ok(guarded.result);
    }
    let all = finish_campaign(
        fits,
        directions,
        opts,
        all_sources,
        n_sources,
        Freeze::All,
        judge,
    )?;
    let score = |r: &CampaignResult| {
        let measured = r.twin.poses.iter().map(|p| mean_fit(&p.fit)).sum::<f64>()
            / r.twin.poses.len().max(1) as f64;
        let loo = &r.twin.interpolation.leave_one_out;
        let between = if loo.is_empty() {
            measured
        } else {
            loo.iter()
                .map(|e| mean_fit(&e.fit).max(-100.0))
                .sum::<f64>()
                / loo.len() as f64
        };
        measured + between.max(-100.0)
    };
    let (keep, other) = if score(&all.result) > score(&guarded.result) {
        (all.result, guarded.result)
    } else {
        (guarded.result, all.result)
    };
    let mut keep = keep;
    let note = format!(
        "modes that do not follow a smooth trend over the poses: {} (mean fit where measured \
         plus leave-one-pose-out mean: {:.1} vs {:.1} for the other choice)",
        if keep
            .twin
            .poses
            .iter()
            .any(|p| p.plan.as_ref().is_some_and(|pl| pl
                .alternatives
                .iter()
                .any(|a| a.starts_with("tracked mode"))))
        {
            "kept as tracked at each pose"
        } else {
            "one pole for every pose"
        },
        score(&keep),
        score(&other)
    );
    for p in keep.twin.poses.iter_mut() {
        if let Some(pl) = p.plan.as_mut() {
            pl.alternatives.push(note.clone());
        }
    }
    Ok(keep)
}

/// The median of `counts` (the upper one of an even count): the mode count
/// [`track_modes`] tracks. Not the largest count (24 pairs at one pose where the others
/// hold 8 carry noise pairs to every pose, and interpolation between them fails), and not
/// the most frequent one: over a wide spread of the poses' own orders that flips with one
/// pose (lumped random machine 2, x direction, own orders 5-15: three 7s and three 10s
/// gave 10, a band 4 Hz lower five 7s and 7, and the twin lost the pose-dependent
/// 139/167 Hz mode at half the poses) where the median stays at 9. Measured poses vs the
/// analytic truth, xx 150-2500 Hz, that campaign: mean 93.6 -> 96.9 %, worst 92.1 ->
/// 93.7 %; random machine 5's yy 87.6 -> 96.0 % (worst 64.5 -> 92.5 %), random machine
/// 4's xx 91.6 -> 88.7 % (worst 88.2 -> 80.1 %, its yy 92.7 -> 94.6 %); the nominal
/// machine's campaigns (dumps 1 and 2) and the tryout campaign keep the same order and
/// twin.
fn common_count(counts: &[usize]) -> usize {
    let mut c = counts.to_vec();
    c.sort_unstable();
    c.get(c.len() / 2).copied().unwrap_or(0)
}

/// Fits again, at the campaign's common order ([`common_count`], per force direction when
/// the directions are fitted apart), every pose whose own automatic order differs: from
/// its own data, with the plan it had. Tracking would otherwise carry a neighbour's modes
/// to such a pose and refine them there, which stalls far from the pose's optimum when
/// the orders differ much (lumped random machine, y direction: own orders 3-20, common
/// 7; the carried models fitted the measured receptance at -237 to 81 % where the poses'
/// own fits reached 27-95 %). Tracking still keeps the carried model where it fits better.
fn refit_at_common_order(fits: &mut [PoseFit], opts: &CampaignOptions) -> Result<usize> {
    use rayon::prelude::*;
    if fits.len() < 3 {
        return Ok(0);
    }
    let n_parts = fits[0].parts.len();
    if fits.iter().any(|f| f.parts.len() != n_parts) {
        return Ok(0);
    }
    // (pose, part or None for the whole model, fitted FRF, options)
    let mut jobs: Vec<(usize, Option<usize>, usize)> = Vec::new();
    if n_parts == 0 {
        let m = common_count(&fits.iter().map(|f| f.model.modes.len()).collect::<Vec<_>>());
        jobs.extend(
            (0..fits.len())
                .filter(|&i| fits[i].model.modes.len() != m)
                .map(|i| (i, None, m)),
        );
    } else {
        for d in 0..n_parts {
            let m = common_count(
                &fits
                    .iter()
                    .map(|f| f.parts[d].model.modes.len())
                    .collect::<Vec<_>>(),
            );
            jobs.extend(
                (0..fits.len())
                    .filter(|&i| fits[i].parts[d].model.modes.len() != m)
                    .map(|i| (i, Some(d), m)),
            );
        }
    }
    let done: Vec<Result<(ModalModel, Vec<String>)>> = jobs
        .par_iter()
        .map(|&(i, d, m)| {
            let f = &fits[i];
            let (fitted, options) = match d {
                Some(d) => (
                    &f.parts[d].fitted,
                    FitOptions {
                        n_modes: Some(m),
                        direct_at_noise: true,
                        ..f.options.clone()
                    },
                ),
                None => (
                    &f.fitted,
                    FitOptions {
                        n_modes: Some(m),
                        ..f.options.clone()
                    },
                ),
            };
            let steer: Vec<crate::axis::Channel> =
                fitted.channels.iter().map(|c| c.channel).collect();
            let (r, _) = fit_pose(
                fitted,
                &options,
                f.plan.clone(),
                opts,
                f.pose,
                PerInput::Never,
                &steer,
            )?;
            let mut model = r.model;
            let mut notes = Vec::new();
            if let Some(s) = f.sigma {
                model.shift_poles(s);
                notes.extend(repair_window_damping(&mut model, s));
            }
            Ok((model, notes))
        })
        .collect();
    for (&(i, d, m), r) in jobs.iter().zip(done) {
        let (model, notes) = r?;
        let f = &mut fits[i];
        let own = match d {
            Some(d) => f.parts[d].model.modes.len(),
            None => f.model.modes.len(),
        };
        let what = match d {
            Some(d) => f.parts[d]
                .fitted
                .channels
                .first()
                .map_or(String::new(), |c| format!("force {}: ", c.channel.input)),
            None => String::new(),
        };
        f.plan.alternatives.push(format!(
            "{what}fitted again at the campaign's common order, {} (its own automatic \
             order: {own})",
            crate::axis::count(m, "mode")
        ));
        f.warnings.extend(notes);
        match d {
            Some(d) => f.parts[d].model = model,
            None => f.model = model,
        }
    }
    if n_parts > 0 {
        for f in fits.iter_mut() {
            f.model = concat_models(&f.parts.iter().map(|p| p.model.clone()).collect::<Vec<_>>());
            f.order.modes = f.model.modes.len();
        }
    } else {
        for f in fits.iter_mut() {
            f.order.modes = f.model.modes.len();
        }
    }
    Ok(jobs.len())
}

/// Which channels [`track_modes`] judges a carried model against the pose's own fit by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Judge {
    /// All fitted channels (a cross channel near its noise floor scores its noise).
    AllChannels,
    /// The direct channels (response along the force) when there are any.
    Direct,
}

/// How [`common_residual_poles`] treats tracked modes off their trend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Freeze {
    /// One pole for every pose unless a measured pose's fit drops by more than
    /// [`RESIDUAL_MAX_FIT_DROP`].
    Guarded,
    /// One pole for every pose, always.
    All,
}

/// A campaign's twin built from its pose fits, and whether a freeze was refused.
struct Finished {
    result: CampaignResult,
    refused_freeze: bool,
}

/// Modes tracked across the poses of `fits` (by frequency and shape, then by smooth
/// trends), coincident modes split again, and residual poles pooled: the notes for
/// every pose's plan, and whether a frozen common pole set was refused.
fn track_across_poses(
    fits: &mut [PoseFit],
    freeze: Freeze,
    judge: Judge,
    warnings: &mut Vec<String>,
) -> Result<(Vec<String>, bool)> {
    let own: Vec<ModalModel> = fits.iter().map(|f| f.model.clone()).collect();
    warnings.extend(track_modes(fits, judge)?);
    let mut notes = assign_by_trends(fits, &own);
    warnings.extend(resplit_coincident_modes(fits));
    let (pooled, refused) = common_residual_poles(fits, freeze)?;
    notes.extend(pooled);
    damp_unresolved_outside(fits)?;
    notes.extend(local_modes(fits)?);
    Ok((notes, refused))
}

/// How much better \[points\] a pose's own fit (at its own automatic order) must fit its
/// FRF than the tracked model for [`local_modes`] to look for the modes it lost.
const LOCAL_MODE_MIN_GAIN: f64 = 2.0;
/// An own mode within this factor of a tracked mode's frequency is held by the tracked
/// model ([`local_modes`]).
const LOCAL_MODE_MATCH: f64 = 1.05;
/// The most modes [`local_modes`] adds at one pose.
const LOCAL_MODE_MAX: usize = 3;
/// Added modes of two poses within this factor of each other share one slot
/// ([`local_modes`]).
const LOCAL_MODE_SLOT: f64 = 1.1;

/// Modes that a pose's own data hold but the tracked models lost there (a mode that only
/// some poses show, or one that moves too far over the poses for the tracking to carry
/// it: the second generator's nominal machine, records of `dump --seed 2`, holds a
/// 127-131 Hz x mode at z = 0.25 m that its z = 0.05 m poses do not, and the tracked
/// models put a pole common to every pose at 147 Hz there, fitting those poses 48-59 %
/// vs the truth (xx, 30-2500 Hz) where the pose identified alone reaches 85 %; with the
/// added mode 53-67 %, and 38-72 % where 17-38 % on the six poses at x = 0.4 m of test
/// `lumped_campaign_keeps_a_mode_that_only_some_poses_hold`). Where the pose's own fit
/// beats the tracked model's by
/// [`LOCAL_MODE_MIN_GAIN`], its own modes that no tracked mode holds
/// ([`LOCAL_MODE_MATCH`]) are added there with its numerators solved anew (kept when the
/// pose fits its FRF better by half that); every other pose gets the same modes with
/// zero numerators (the pole of the nearest pose that has them), so that the twin
/// between poses fades them in.
fn local_modes(fits: &mut [PoseFit]) -> Result<Vec<String>> {
    let n = fits.len();
    let n_modes = fits.first().map_or(0, |f| f.model.modes.len());
    if n < 2 || fits.iter().any(|f| f.model.modes.len() != n_modes) {
        return Ok(Vec::new());
    }
    let pose_fit = |f: &PoseFit, m: &ModalModel| direct_mean_fit(&pose_channel_fits(f, m));
    // per pose: the model solved with the modes added there appended (after `n_modes`)
    let mut added: Vec<Option<ModalModel>> = vec![None; n];
    let mut notes = Vec::new();
    for (p, f) in fits.iter().enumerate() {
        if f.own.modes.is_empty() {
            continue;
        }
        let cur = pose_fit(f, &f.model);
        let own = pose_fit(f, &f.own);
        if !(own - cur > LOCAL_MODE_MIN_GAIN) {
            continue;
        }
        let band = band_of(&f.frf, &f.options).pose;
        let lost: Vec<crate::model::Mode> = (f.own.modes.iter())
            .filter(|o| {
                // well inside the band (a pole near its edge also stands for the modes
                // beyond it, and its static compliance carries off below: the second
                // generator's random machine 3, a 67.6 Hz mode added at one pose whose
                // band starts at 71 Hz took its yy receptance vs the truth from 91 to
                // -13 %)
                let hz = o.freq_hz();
                hz * RESIDUAL_BAND_FACTOR >= band.0
                    && hz <= RESIDUAL_BAND_FACTOR * band.1
                    && o.zeta <= RESIDUAL_ZETA
                    && f.model
                        .modes
                        .iter()
                        .all(|m| (m.wn / o.wn).ln().abs() > LOCAL_MODE_MATCH.ln())
            })
            .copied()
            .collect();
        if lost.is_empty() {
            continue;
        }
        // greedily, the lost mode that raises the pose's fit most, while each raises it by
        // half LOCAL_MODE_MIN_GAIN (a few modes: numerators solved for many free poles
        // fit the noise with residues that cancel, and the twin between poses inherits
        // them)
        let mut kept: Vec<crate::model::Mode> = Vec::new();
        let mut best: Option<(ModalModel, f64)> = None;
        let mut level = cur;
        while kept.len() < LOCAL_MODE_MAX {
            let mut top: Option<(usize, ModalModel, f64)> = None;
            for (i, o) in lost.iter().enumerate() {
                if kept
                    .iter()
                    .any(|k| (k.wn / o.wn).ln().abs() <= LOCAL_MODE_MATCH.ln())
                {
                    continue;
                }
                let mut m = f.model.clone();
                m.modes.extend(kept.iter().chain(std::iter::once(o)));
                for c in &mut m.channels {
                    c.num
                        .extend((0..=kept.len()).map(|_| crate::model::ModeNum::default()));
                }
                let solved = resolve_numerators(f, m)?;
                let after = pose_fit(f, &solved);
                if top.as_ref().is_none_or(|t| after > t.2) {
                    top = Some((i, solved, after));
                }
            }
            match top {
                Some((i, solved, after)) if after - level >= 0.5 * LOCAL_MODE_MIN_GAIN => {
                    kept.push(lost[i]);
                    level = after;
                    best = Some((solved, after));
                }
                _ => break,
            }
        }
        if let Some((solved, after)) = best {
            notes.push(format!(
                "pose {}: {} Hz ({cur:.1} -> {after:.1} %)",
                crate::axis::PoseText(f.pose),
                kept.iter()
                    .map(|m| format!("{:.1}", m.freq_hz()))
                    .collect::<Vec<_>>()
                    .join(", "),
            ));
            added[p] = Some(solved);
        }
    }
    if added.iter().all(Option::is_none) {
        return Ok(Vec::new());
    }
    // the `j`-th mode added at pose `q`
    let added_mode = |q: usize, j: usize| added[q].as_ref().map(|m| m.modes[n_modes + j]);
    // slots: modes of different poses within LOCAL_MODE_SLOT of each other share one;
    // per slot, the pose and index (in that pose's added modes) where it is active
    let mut slots: Vec<Vec<(usize, usize)>> = Vec::new();
    for (p, a) in added.iter().enumerate() {
        let Some(solved) = a else { continue };
        for (i, m) in solved.modes[n_modes..].iter().enumerate() {
            let hz = m.freq_hz();
            let slot = slots.iter().position(|s| {
                s.iter().all(|&(q, _)| q != p)
                    && s.iter().any(|&(q, j)| {
                        let other = added_mode(q, j).map_or(0.0, |m| m.freq_hz());
                        (hz / other).ln().abs() <= LOCAL_MODE_SLOT.ln()
                    })
            });
            match slot {
                Some(s) => slots[s].push((p, i)),
                None => slots.push(vec![(p, i)]),
            }
        }
    }
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let poses: Vec<[f64; 3]> = fits.iter().map(|f| f.pose).collect();
    for (p, f) in fits.iter_mut().enumerate() {
        let mut m = match &added[p] {
            Some(solved) => {
                let mut base = solved.clone();
                base.modes.truncate(n_modes);
                for c in &mut base.channels {
                    c.num.truncate(n_modes);
                }
                base
            }
            None => f.model.clone(),
        };
        for slot in &slots {
            if let Some(&(_, i)) = slot.iter().find(|&&(q, _)| q == p) {
                let solved = added[p].as_ref().expect("active pose");
                m.modes.push(solved.modes[n_modes + i]);
                for (c, sc) in m.channels.iter_mut().zip(&solved.channels) {
                    c.num.push(sc.num[n_modes + i]);
                }
            } else {
                let &(q, j) = slot
                    .iter()
                    .min_by(|a, b| {
                        dist(poses[a.0], poses[p]).total_cmp(&dist(poses[b.0], poses[p]))
                    })
                    .expect("a slot has an active pose");
                let pole = added_mode(q, j).expect("active pose");
                m.modes.push(pole);
                for c in &mut m.channels {
                    c.num.push(crate::model::ModeNum::default());
                }
            }
        }
        f.model = m;
    }
    Ok(vec![format!(
        "modes that a pose's own fit holds and the tracked models lost there, added at that \
         pose ({}; zero at the other poses, faded in between)",
        notes.join("; ")
    )])
}

/// Pose `f`'s numerators (and residuals) solved again for the poles of `model` (unwindowed,
/// as pose models are kept): fitted in the windowed domain of the pose's FRF.
fn resolve_numerators(f: &PoseFit, mut model: ModalModel) -> Result<ModalModel> {
    if let Some(s) = f.sigma {
        model.shift_poles(-s);
    }
    let w = crate::rational_fit::weights(&f.fitted, &f.options);
    let mut solved = crate::rational_fit::solve_numerators(&model, &f.fitted, &w, &f.options)?;
    if let Some(s) = f.sigma {
        solved.shift_poles(s);
    }
    Ok(solved)
}

/// A tracked mode that the refinement carried outside its pose's band with a half-power
/// band narrower than one line is not fixed by any line: as an out-of-band term it gets
/// the damping of a one-line half-power band (`ζ = Δf / 2f`), and that pose's numerators
/// are solved again for it. Without it a slot tracked at 129-137 Hz elsewhere sat at one
/// pose of the second generator's campaign at 65 Hz with ζ = 0.001 %, just below that
/// pose's band: a peak 10⁴ times the truth's (30-2500 Hz vs truth −159 %) that no
/// in-band check sees.
fn damp_unresolved_outside(fits: &mut [PoseFit]) -> Result<()> {
    let tau = 2.0 * std::f64::consts::PI;
    for f in fits.iter_mut() {
        let band = band_of(&f.frf, &f.options).pose;
        let Some(df) = (f.frf.freqs_hz.windows(2))
            .map(|w| w[1] - w[0])
            .find(|d| *d > 0.0)
        else {
            continue;
        };
        let mut m = f.model.clone();
        let mut changed = Vec::new();
        for md in m.modes.iter_mut() {
            let hz = md.wn / tau;
            if (hz < band.0 || hz > band.1) && 2.0 * md.zeta * hz < df {
                let zeta = (df / (2.0 * hz)).min(1.0);
                changed.push(format!(
                    "{hz:.1} Hz ({:.4} % -> {:.2} %)",
                    100.0 * md.zeta,
                    100.0 * zeta
                ));
                md.zeta = zeta;
            }
        }
        if changed.is_empty() {
            continue;
        }
        f.model = resolve_numerators(f, m)?;
        f.plan.alternatives.push(format!(
            "tracked mode(s) outside the band narrower than one line ({:.2} Hz), which no line \
             fixes: damped to a one-line half-power band, numerators solved again: {}",
            df,
            changed.join(", ")
        ));
    }
    Ok(())
}

/// Modal consistency of pose `f` ([`crate::consistency`]): each isolated mode's residues
/// between the hammered directions made rank one while no direct channel's fit of the
/// measured FRF (as measured, `power`) drops by more than [`RANK_ONE_TOLERANCE_PCT`]
/// from the pose's own fit. True when the model changed (the plan says which modes).
fn modal_consistency(f: &mut PoseFit, band: (f64, f64), power: i32) -> bool {
    let bands = f.plan.bands(band);
    let direct = |m: &ModalModel| {
        let mut w = m.clone();
        if let Some(s) = f.sigma {
            w.shift_poles(-s);
        }
        channel_fits_as(
            &w,
            &f.frf,
            &bands,
            power,
            f.plan.averages_per_channel.or(f.plan.averages),
        )
        .into_iter()
        .filter(|c| c.channel.output == c.channel.input)
        .map(|c| c.fit_pct)
        .collect::<Vec<f64>>()
    };
    let before = direct(&f.model);
    let mut model = f.model.clone();
    let notes = crate::consistency::rank_one_residues(&mut model, band, |m| {
        before
            .iter()
            .zip(direct(m))
            .all(|(a, b)| b >= a - RANK_ONE_TOLERANCE_PCT)
    });
    if notes.is_empty() {
        return false;
    }
    f.model = model;
    f.plan.alternatives.push(format!(
        "modal consistency: the residues of {} between the hammered directions made rank \
         one (one mode shape; the stray residue a free fit leaves in the other direction \
         removed): {}",
        crate::axis::count(notes.len(), "isolated mode"),
        notes.join(", ")
    ));
    true
}

/// Tracking, mode assignment, residual poles and the twin, from the pose fits.
fn finish_campaign(
    mut fits: Vec<PoseFit>,
    directions: &[crate::axis::Axis],
    opts: &CampaignOptions,
    all_sources: &[String],
    n_sources: usize,
    freeze: Freeze,
    judge: Judge,
) -> Result<Finished> {
    let mut refused_freeze = false;
    let mut warnings: Vec<String> = fits
        .iter()
        .flat_map(|f| {
            f.warnings
                .iter()
                .map(move |w| format!("pose {}: {w}", crate::axis::PoseText(f.pose)))
        })
        .collect();
    if fits.len() > 1
        && !directions.is_empty()
        && fits.iter().all(|f| f.parts.len() == fits[0].parts.len())
    {
        // each force direction tracked on its own, then the parts joined again
        for d in 0..fits[0].parts.len() {
            let mut sub: Vec<PoseFit> = fits
                .iter()
                .map(|f| PoseFit {
                    frf: f.parts[d].fitted.clone(),
                    fitted: f.parts[d].fitted.clone(),
                    model: f.parts[d].model.clone(),
                    own: f.parts[d].own.clone(),
                    diagram: f.parts[d].diagram.clone(),
                    parts: Vec::new(),
                    warnings: Vec::new(),
                    ..f.clone()
                })
                .collect();
            let (notes, refused) = track_across_poses(&mut sub, freeze, judge, &mut warnings)?;
            refused_freeze |= refused;
            for f in fits.iter_mut() {
                f.plan.alternatives.extend(notes.iter().cloned());
            }
            for (f, s) in fits.iter_mut().zip(sub) {
                f.parts[d].model = s.model;
            }
        }
        for f in fits.iter_mut() {
            f.model = concat_models(&f.parts.iter().map(|p| p.model.clone()).collect::<Vec<_>>());
            f.order.modes = f.model.modes.len();
        }
    } else if fits.len() > 1 {
        let (notes, refused) = track_across_poses(&mut fits, freeze, judge, &mut warnings)?;
        refused_freeze |= refused;
        for f in fits.iter_mut() {
            f.plan.alternatives.extend(notes.iter().cloned());
        }
    }
    for f in fits.iter_mut().filter(|f| !f.held.is_empty()) {
        add_zero_channels(&mut f.model, &f.held);
    }
    let diagrams: Vec<StabilizationDiagram> = fits.iter().map(|f| f.diagram.clone()).collect();
    let poses: Vec<PoseModel> = fits
        .into_iter()
        .map(|mut f| {
            let band = band_of(&f.frf, &f.options);
            let mut windowed = f.model.clone();
            if let Some(s) = f.sigma {
                windowed.shift_poles(-s);
            }
            let power = f.plan.measured_as.map_or(0, |m| m.power());
            if modal_consistency(&mut f, band.pose, power) {
                windowed = f.model.clone();
                if let Some(s) = f.sigma {
                    windowed.shift_poles(-s);
                }
            }
            if power > 0 {
                let notes = drop_unsupported_residuals(
                    &mut f.model,
                    &mut windowed,
                    &f.frf,
                    &f.plan.bands(band.pose),
                    power,
                );
                f.plan.alternatives.extend(notes);
            }
            let fit = channel_fits_as(
                &windowed,
                &f.frf,
                &f.plan.bands(band.pose),
                power,
                f.plan.averages_per_channel.or(f.plan.averages),
            );
            f.plan.quality_warnings = quality_warnings(f.pose, &fit, band.pose, f.plan.measured_as);
            warnings.extend(f.plan.quality_warnings.iter().cloned());
            PoseModel {
                pose: f.pose,
                fit,
                plan: Some(f.plan),
                band_hz: [band.pose.0, band.pose.1],
                model: f.model,
                frf: f.frf,
                order: f.order,
                sources: f.sources,
                frf_exp_window_sigma: f.sigma,
            }
        })
        .collect();
    let mut twin = Twin::new(&opts.name, poses);
    twin.interpolation = interpolation_info(&twin)?;
    twin.history.push(HistoryEntry {
        unix_time: now_unix(),
        kind: "identify".into(),
        files: all_sources.to_vec(),
        summary: format!(
            "a-priori twin from {} at {}",
            crate::axis::count(n_sources, "measured FRF file"),
            crate::axis::count(twin.poses.len(), "pose")
        ),
        figures: Default::default(),
        previous_poses: Vec::new(),
    });
    Ok(Finished {
        result: CampaignResult {
            twin,
            warnings,
            diagrams,
        },
        refused_freeze,
    })
}

/// Residue vector of mode `k` over `channels` (b0 and ωn·b1 per channel), unit length.
fn shape_vector(m: &ModalModel, k: usize, channels: &[crate::axis::Channel]) -> Vec<f64> {
    let mut v = Vec::with_capacity(2 * channels.len());
    for ch in channels {
        if let Some(ci) = m.channel_index(*ch) {
            let n = m.channels[ci].num[k];
            v.push(n.b0);
            v.push(n.b1 * m.modes[k].wn);
        } else {
            v.extend([0.0, 0.0]);
        }
    }
    let nrm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if nrm > 0.0 {
        v.iter_mut().for_each(|x| *x /= nrm);
    }
    v
}

/// Reorders the modes of `m` so that mode `k` is the physical mode `k` of `reference`:
/// a greedy assignment on frequency distance plus mode-shape dissimilarity (1 − MAC of
/// the residue vectors), so crossing modes keep their identity.
pub fn match_modes(reference: &ModalModel, m: &ModalModel) -> ModalModel {
    let n = reference.modes.len();
    if m.modes.len() != n || n == 0 {
        return m.clone();
    }
    let chans: Vec<crate::axis::Channel> = reference.channels.iter().map(|c| c.channel).collect();
    let rs: Vec<Vec<f64>> = (0..n).map(|k| shape_vector(reference, k, &chans)).collect();
    let ms: Vec<Vec<f64>> = (0..n).map(|k| shape_vector(m, k, &chans)).collect();
    let mut pairs = Vec::with_capacity(n * n);
    for k in 0..n {
        for l in 0..n {
            let dfreq = (m.modes[l].wn / reference.modes[k].wn).ln().abs() / 0.05;
            let dot: f64 = rs[k].iter().zip(&ms[l]).map(|(a, b)| a * b).sum();
            let mac = dot * dot;
            pairs.push((dfreq + 3.0 * (1.0 - mac), k, l));
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut of_ref = vec![usize::MAX; n];
    let mut used = vec![false; n];
    for (_, k, l) in pairs {
        if of_ref[k] == usize::MAX && !used[l] {
            of_ref[k] = l;
            used[l] = true;
        }
    }
    let mut out = m.clone();
    for k in 0..n {
        let l = of_ref[k];
        out.modes[k] = m.modes[l];
        for (co, ci) in out.channels.iter_mut().zip(&m.channels) {
            co.num[k] = ci.num[l];
        }
    }
    out
}

/// A tracked mode counts as a residual term (the tail of modes outside the band, or a
/// pair of real poles) when at some pose its natural frequency lies this far outside the
/// pose's band (a factor) or its damping ratio exceeds [`RESIDUAL_ZETA`].
const RESIDUAL_BAND_FACTOR: f64 = 0.9;
/// See [`RESIDUAL_BAND_FACTOR`].
const RESIDUAL_ZETA: f64 = 0.5;
/// A tracked mode whose natural frequency departs from its best affine trend over the
/// poses (`ln ωn ≈ a + b·x + c·y + d·z`) by more than this (relative) at some pose is
/// not one physical mode followed across the workspace: tracking paired different modes
/// at different poses (a 485 Hz mode at some, a 562 Hz one at others: 12 %). It is
/// treated as a residual term too: one pole, numerators per pose. Physical modes that
/// shift by 27 % over the workspace follow their trend within 1.7 % (vmachine).
const RESIDUAL_IRREGULAR: f64 = 0.05;

/// The largest departure of mode `k`'s `ln ωn` from its least-squares affine trend over
/// the poses (0 with fewer than 6 poses: too few to tell).
fn irregular_over_poses(fits: &[PoseFit], k: usize) -> f64 {
    let n = fits.len();
    if n < 6 {
        return 0.0;
    }
    let a = nalgebra::DMatrix::from_fn(n, 4, |i, j| if j == 0 { 1.0 } else { fits[i].pose[j - 1] });
    let b = nalgebra::DVector::from_fn(n, |i, _| fits[i].model.modes[k].wn.max(1e-300).ln());
    let Ok(c) = a.clone().svd(true, true).solve(&b, 1e-12) else {
        return 0.0;
    };
    (b - a * c).amax()
}

/// `m` with its modes (and their numerators) in the order `perm` (mode `k` of the
/// result is mode `perm[k]` of `m`).
fn reorder_modes(m: &ModalModel, perm: &[usize]) -> ModalModel {
    let mut out = m.clone();
    for (k, &l) in perm.iter().enumerate() {
        out.modes[k] = m.modes[l];
        for (co, ci) in out.channels.iter_mut().zip(&m.channels) {
            co.num[k] = ci.num[l];
        }
    }
    out
}

/// Σ over the modes of the departure of `ln ωn` from its affine trend over the poses
/// ([`irregular_over_poses`]): how far an assignment of modes to poses is from modes
/// that each move smoothly with the pose.
fn total_irregularity(fits: &[PoseFit]) -> f64 {
    let n = fits.first().map_or(0, |f| f.model.modes.len());
    (0..n).map(|k| irregular_over_poses(fits, k)).sum()
}

/// A quantity of mode `k` of a model (its log frequency, damping or peak).
type ModeQuantity = dyn Fn(&ModalModel, usize) -> f64;

/// Random starts of [`assign_by_trends`] besides the frequency and the tracking order.
const TREND_RESTARTS: usize = 12;

/// Largest mode count whose permutations are searched exhaustively per pose.
const TREND_EXHAUSTIVE_MODES: usize = 7;

/// Tracking from neighbour to neighbour can swap two close modes at some poses (a
/// 260 Hz and a 280 Hz mode that both shift by 10 % over the workspace): a mode
/// then jumps between two trends and [`common_residual_poles`] must freeze it. When
/// most poses' own fits (`own`, before tracking) have the tracked mode count, their
/// modes (the tracked ones at the other poses) are assigned again, to the modes' affine trends in `ln ωn` over the poses: start from
/// each pose's modes in frequency order, fit one trend per mode, give each pose the
/// permutation nearest the trends (frequency, and damping loosely), and repeat; modes
/// whose trends cross are followed through the crossing. Kept only when the modes then
/// follow their trends more closely than the tracking's (less total irregularity).
fn assign_by_trends(fits: &mut [PoseFit], own: &[ModalModel]) -> Vec<String> {
    let n = fits.len();
    let m = fits.first().map_or(0, |f| f.model.modes.len());
    // a pose whose own fit has another count keeps its tracked model (re-ordered)
    if n < 6 || m < 2 || 2 * own.iter().filter(|o| o.modes.len() == m).count() < n {
        return Vec::new();
    }
    let before = total_irregularity(fits);
    if before <= 0.5 * RESIDUAL_IRREGULAR {
        return Vec::new();
    }
    let a = nalgebra::DMatrix::from_fn(n, 4, |i, j| if j == 0 { 1.0 } else { fits[i].pose[j - 1] });
    let svd = a.clone().svd(true, true);
    let ln_wn = |mm: &ModalModel, k: usize| mm.modes[k].wn.max(1e-300).ln();
    let ln_zeta = |mm: &ModalModel, k: usize| mm.modes[k].zeta.max(1e-6).ln();
    // the mode's resonance peak summed over the channels (its modal flexibility)
    let ln_peak = |mm: &ModalModel, k: usize| {
        let p: f64 = (0..mm.channels.len()).map(|ci| mm.mode_peak(ci, k)).sum();
        p.max(1e-300).ln()
    };
    // starts: each pose's modes in frequency order, the tracking's order, and the
    // frequency order with close neighbours (within 15 %) swapped at random poses (modes
    // that cross: a local optimum of the assignment keeps them swapped otherwise)
    let sorted: Vec<PoseFit> = fits
        .iter()
        .zip(own)
        .map(|(f, o)| {
            let o = if o.modes.len() == m { o } else { &f.model };
            let mut perm: Vec<usize> = (0..m).collect();
            perm.sort_by(|&a, &b| o.modes[a].wn.total_cmp(&o.modes[b].wn));
            PoseFit {
                model: reorder_modes(o, &perm),
                ..f.clone()
            }
        })
        .collect();
    let mut starts = vec![sorted.clone(), fits.to_vec()];
    let mut rng = StdRng::seed_from_u64(0x7e4d);
    for _ in 0..TREND_RESTARTS {
        let mut t = sorted.clone();
        for f in t.iter_mut() {
            let mut perm: Vec<usize> = (0..m).collect();
            for k in 0..m - 1 {
                let (a, b) = (f.model.modes[perm[k]].wn, f.model.modes[perm[k + 1]].wn);
                if (b / a).ln().abs() < 0.15 && rng.gen_bool(0.3) {
                    perm.swap(k, k + 1);
                }
            }
            f.model = reorder_modes(&f.model, &perm);
        }
        starts.push(t);
    }
    let terms: [(&ModeQuantity, f64); 3] = [(&ln_wn, 0.02), (&ln_zeta, 0.3), (&ln_peak, 1.0)];
    // per pose and candidate mode: its three values (fixed; only the order changes)
    let mut best: Option<(f64, Vec<PoseFit>)> = None;
    for mut trial in starts {
        let mut cost_total = f64::INFINITY;
        for _ in 0..8 {
            // one trend per mode and quantity (affine in the pose)
            let mut trends = vec![vec![nalgebra::DVector::zeros(n); m]; terms.len()];
            let mut total = 0.0;
            for (q, (vals, scale)) in terms.iter().enumerate() {
                for k in 0..m {
                    let b = nalgebra::DVector::from_fn(n, |i, _| vals(&trial[i].model, k));
                    let Ok(c) = svd.solve(&b, 1e-12) else {
                        return Vec::new();
                    };
                    trends[q][k] = &a * c;
                    total += ((b - &trends[q][k]).norm() / scale).powi(2);
                }
            }
            cost_total = total;
            let mut changed = false;
            for i in 0..n {
                let cur = trial[i].model.clone();
                let vals: Vec<Vec<f64>> = terms
                    .iter()
                    .map(|(v, _)| (0..m).map(|l| v(&cur, l)).collect())
                    .collect();
                let matrix: Vec<Vec<f64>> = (0..m)
                    .map(|k| {
                        (0..m)
                            .map(|l| {
                                terms
                                    .iter()
                                    .enumerate()
                                    .map(|(q, (_, scale))| {
                                        ((vals[q][l] - trends[q][k][i]) / scale).powi(2)
                                    })
                                    .sum()
                            })
                            .collect()
                    })
                    .collect();
                let perm = best_permutation(m, &|k, l| matrix[k][l]);
                if perm.iter().enumerate().any(|(k, &l)| k != l) {
                    trial[i].model = reorder_modes(&cur, &perm);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        if best.as_ref().is_none_or(|b| cost_total < b.0) {
            best = Some((cost_total, trial));
        }
    }
    let Some((_, trial)) = best else {
        return Vec::new();
    };
    let after = total_irregularity(&trial);
    if after >= before {
        return Vec::new();
    }
    for (f, t) in fits.iter_mut().zip(trial) {
        f.model = t.model;
    }
    vec![format!(
        "modes assigned across the poses by their trends over the workspace (the poses' own \
         fits), not by tracking from neighbour to neighbour: largest departures from the \
         trends summed over the modes {:.1} % instead of {:.1} %",
        100.0 * after,
        100.0 * before
    )]
}

/// The assignment `perm` (mode `k` ← candidate `perm[k]`) of least total `cost(k, l)`:
/// exhaustive up to [`TREND_EXHAUSTIVE_MODES`] modes, else greedy on the sorted costs.
fn best_permutation(m: usize, cost: &dyn Fn(usize, usize) -> f64) -> Vec<usize> {
    if m <= TREND_EXHAUSTIVE_MODES {
        let mut best = (f64::INFINITY, (0..m).collect::<Vec<usize>>());
        let mut perm: Vec<usize> = (0..m).collect();
        // Heap's algorithm over all permutations
        let mut c = vec![0usize; m];
        let eval = |p: &[usize], best: &mut (f64, Vec<usize>)| {
            let t: f64 = p.iter().enumerate().map(|(k, &l)| cost(k, l)).sum();
            if t < best.0 {
                *best = (t, p.to_vec());
            }
        };
        eval(&perm, &mut best);
        let mut i = 0;
        while i < m {
            if c[i] < i {
                if i % 2 == 0 {
                    perm.swap(0, i);
                } else {
                    perm.swap(c[i], i);
                }
                eval(&perm, &mut best);
                c[i] += 1;
                i = 0;
            } else {
                c[i] = 0;
                i += 1;
            }
        }
        return best.1;
    }
    let mut pairs: Vec<(f64, usize, usize)> = (0..m)
        .flat_map(|k| (0..m).map(move |l| (k, l)))
        .map(|(k, l)| (cost(k, l), k, l))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut perm = vec![usize::MAX; m];
    let mut used = vec![false; m];
    for (_, k, l) in pairs {
        if perm[k] == usize::MAX && !used[l] {
            perm[k] = l;
            used[l] = true;
        }
    }
    perm
}

/// A band edge of the campaign moves to the poses' isolated resonances beyond it only when
/// most poses see one: this factor beyond the plain median edge.
const CAMPAIGN_EXTENSION_FACTOR: f64 = 1.2;

/// One band for every pose of a campaign: per end, the median of the poses' own edges
/// (`plain`: the trusted range), or the median of their edges grown to isolated coherent
/// resonances (`extended`, see [`crate::plan::plan_pose`]) when more than half the poses
/// reach [`CAMPAIGN_EXTENSION_FACTOR`] beyond the plain median edge. A resonance that
/// most poses hold enters every pose model (the second generator's 73 Hz mode, its
/// largest receptance peak: 30-2500 Hz vs the truth, nominal dump 1, measured poses xx 43 -> 82 %, yy
/// 43 -> 88 %); a few poses' resonances never move the median edge by a few hertz
/// (which flipped the variant a campaign kept and cost a random machine 9 points).
fn campaign_band(plain: &[PosePlan], extended: &[PosePlan]) -> (f64, f64, &'static str) {
    let median = |mut v: Vec<f64>, upper: bool| {
        v.sort_by(f64::total_cmp);
        v[if upper {
            (v.len() - 1) / 2
        } else {
            v.len() / 2
        }]
    };
    let edge = |i: usize| {
        let p = median(plain.iter().map(|p| p.band_hz[i]).collect(), i == 1);
        let e: Vec<f64> = extended.iter().map(|p| p.band_hz[i]).collect();
        let beyond = e
            .iter()
            .filter(|&&x| {
                if i == 0 {
                    x * CAMPAIGN_EXTENSION_FACTOR < p
                } else {
                    x > p * CAMPAIGN_EXTENSION_FACTOR
                }
            })
            .count();
        if 2 * beyond > e.len() {
            (median(e, i == 1), true)
        } else {
            (p, false)
        }
    };
    let ((lo, a), (hi, b)) = (edge(0), edge(1));
    (
        lo,
        hi,
        if a || b {
            "the median of the poses' own bands grown to the isolated coherent resonances \
             that most of them hold beyond it"
        } else {
            "the median of the poses' own bands"
        },
    )
}

/// Pole pairs that stand for what lies outside the band (the mass line of the modes
/// below it, the stiffness of those above), and tracked modes that are not one physical
/// mode ([`RESIDUAL_IRREGULAR`]), are fixed only loosely by the data: their
/// frequency and damping wander from pose to pose while their sum in the band stays
/// put, and interpolating such parameters between poses gives nonsense (a pole at 7 Hz
/// at one pose, at 84 Hz at the next). Each such tracked mode gets one pole for the whole
/// campaign (the median over the poses), and every pose's numerators are solved anew
/// for it: the band response is linear in the numerators, so it interpolates smoothly.
fn common_residual_poles(fits: &mut [PoseFit], freeze: Freeze) -> Result<(Vec<String>, bool)> {
    let mut notes = Vec::new();
    let n_modes = fits.first().map_or(0, |f| f.model.modes.len());
    if fits.len() < 2 || fits.iter().any(|f| f.model.modes.len() != n_modes) {
        return Ok((notes, false));
    }
    let bands: Vec<(f64, f64)> = fits
        .iter()
        .map(|f| band_of(&f.frf, &f.options).pose)
        .collect();
    let outside: Vec<usize> = (0..n_modes)
        .filter(|&k| {
            fits.iter().zip(&bands).any(|(f, b)| {
                let m = f.model.modes[k];
                let hz = m.wn / (2.0 * std::f64::consts::PI);
                hz < RESIDUAL_BAND_FACTOR * b.0
                    || hz * RESIDUAL_BAND_FACTOR > b.1
                    || m.zeta > RESIDUAL_ZETA
            })
        })
        .collect();
    let irregular: Vec<usize> = (0..n_modes)
        .filter(|&k| !outside.contains(&k) && irregular_over_poses(fits, k) > RESIDUAL_IRREGULAR)
        .collect();
    if outside.is_empty() && irregular.is_empty() {
        return Ok((notes, false));
    }
    // each pose's fit of its FRF
    let pose_fit = |f: &PoseFit, m: &ModalModel| mean_fit(&pose_channel_fits(f, m));
    let before: Vec<f64> = fits.iter().map(|f| pose_fit(f, &f.model)).collect();
    // one pole for the modes `set` at every pose, every pose's numerators solved again;
    // with the largest drop of a pose's fit
    let freeze_set = |set: &[usize]| -> Result<Frozen> {
        let common: Vec<(usize, f64, f64)> = set
            .iter()
            .map(|&k| {
                let wn = median(fits.iter().map(|f| f.model.modes[k].wn.ln()).collect()).exp();
                let zeta = median(fits.iter().map(|f| f.model.modes[k].zeta).collect()).max(0.02);
                (k, wn, zeta)
            })
            .collect();
        let mut models = Vec::with_capacity(fits.len());
        let mut drop = 0.0f64;
        for (f, b) in fits.iter().zip(&before) {
            let mut m = f.model.clone();
            for &(k, wn, zeta) in &common {
                m.modes[k].wn = wn;
                m.modes[k].zeta = zeta;
            }
            let solved = resolve_numerators(f, m)?;
            drop = drop.max(b - pose_fit(f, &solved));
            models.push(solved);
        }
        Ok((models, common, drop))
    };
    // a frozen pole must not cost a measured pose its fit: physical modes that move with
    // the pose but were tracked irregularly (crossing modes) stay as tracked then
    let mut all = outside.clone();
    all.extend(&irregular);
    all.sort_unstable();
    let mut chosen = None;
    let mut refused = None;
    for set in [all, outside.clone()] {
        if set.is_empty() {
            continue;
        }
        let (models, common, drop) = freeze_set(&set)?;
        if drop <= RESIDUAL_MAX_FIT_DROP || matches!(freeze, Freeze::All) {
            chosen = Some((models, common));
            break;
        }
        refused.get_or_insert(drop);
    }
    if let Some(drop) = refused.filter(|_| !irregular.is_empty()) {
        let hz = |k: usize| {
            median(fits.iter().map(|f| f.model.modes[k].wn).collect())
                / (2.0 * std::f64::consts::PI)
        };
        notes.push(format!(
            "tracked mode(s) near {} Hz do not follow a smooth trend over the poses (modes that \
             cross or swap): kept as tracked at each pose (one pole for every pose would fit a \
             measured pose {drop:.1} points worse); the twin between poses is less certain there",
            irregular
                .iter()
                .map(|&k| format!("{:.0}", hz(k)))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let refused_irregular = refused.is_some() && !irregular.is_empty();
    let Some((models, common)) = chosen else {
        // no pole for every pose: each pose where such a mode departs wildly from the
        // same mode at its nearest poses takes theirs (numerators solved anew) where
        // that costs its fit at most RESIDUAL_MAX_FIT_DROP
        let mut set = outside.clone();
        set.extend(&irregular);
        notes.extend(local_residual_poles(fits, &set, &before, pose_fit)?);
        return Ok((notes, refused_irregular));
    };
    for (f, m) in fits.iter_mut().zip(models) {
        f.model = m;
    }
    notes.push(format!(
        "{} for modes outside the band or off a smooth trend over the poses ({}): one pole for every pose, \
         numerators per pose",
        if common.len() == 1 {
            "1 pole pair stands".to_string()
        } else {
            format!("{} pole pairs stand", common.len())
        },
        common
            .iter()
            .map(|&(_, wn, z)| format!(
                "{:.0} Hz / {:.0} %",
                wn / (2.0 * std::f64::consts::PI),
                100.0 * z
            ))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    Ok((notes, refused_irregular))
}

/// Pose `f`'s channel fits of its FRF by `m` (unwindowed, as pose models are kept: judged
/// in the windowed domain of the FRF), each channel in the pose's band.
fn pose_channel_fits(f: &PoseFit, m: &ModalModel) -> Vec<ChannelFit> {
    let mut w = m.clone();
    if let Some(s) = f.sigma {
        w.shift_poles(-s);
    }
    channel_fits_as(&w, &f.frf, &band_of(&f.frf, &f.options), 0, None)
}

/// The middle value of `v` (the upper one of an even count); `v` not empty.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// How many nearest poses [`local_residual_poles`] compares a pose's mode with.
const LOCAL_NEIGHBOURS: usize = 4;
/// A mode whose natural frequency departs by more than this factor from the median of
/// the same mode at its [`LOCAL_NEIGHBOURS`] nearest poses is wild there.
const LOCAL_WILD_FACTOR: f64 = 1.25;

/// For each mode of `set` (modes outside the band or off a smooth trend that could not
/// get one pole for every pose): each pose where it departs by more than
/// [`LOCAL_WILD_FACTOR`] from the median of the same mode at its nearest poses, or is
/// damped beyond [`RESIDUAL_ZETA`] where they are not, takes their median pole, its
/// numerators solved anew, when that costs the pose's fit (`before`) at most
/// [`RESIDUAL_MAX_FIT_DROP`] (second generator, an 18-pose campaign: a slot at 70-75 Hz
/// held 4.7 Hz at 124 % damping at two poses, another 66-232 Hz, and the twin between
/// them interpolated those).
fn local_residual_poles(
    fits: &mut [PoseFit],
    set: &[usize],
    before: &[f64],
    pose_fit: impl Fn(&PoseFit, &ModalModel) -> f64,
) -> Result<Vec<String>> {
    let n = fits.len();
    if n <= LOCAL_NEIGHBOURS || set.is_empty() {
        return Ok(Vec::new());
    }
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let original: Vec<ModalModel> = fits.iter().map(|f| f.model.clone()).collect();
    let mut repaired = Vec::new();
    for p in 0..n {
        let mut near: Vec<usize> = (0..n).filter(|&q| q != p).collect();
        near.sort_by(|&a, &b| {
            dist(fits[a].pose, fits[p].pose).total_cmp(&dist(fits[b].pose, fits[p].pose))
        });
        near.truncate(LOCAL_NEIGHBOURS);
        let mut m = fits[p].model.clone();
        let mut changed = Vec::new();
        for &k in set {
            let wn = median(near.iter().map(|&q| original[q].modes[k].wn.ln()).collect()).exp();
            let zeta = median(near.iter().map(|&q| original[q].modes[k].zeta).collect());
            let own = original[p].modes[k];
            let wild = (own.wn / wn).ln().abs() > LOCAL_WILD_FACTOR.ln()
                || (own.zeta > RESIDUAL_ZETA && zeta <= RESIDUAL_ZETA);
            if wild {
                m.modes[k].wn = wn;
                m.modes[k].zeta = zeta;
                changed.push((k, own, wn, zeta));
            }
        }
        if changed.is_empty() {
            continue;
        }
        let solved = resolve_numerators(&fits[p], m)?;
        let after = pose_fit(&fits[p], &solved);
        if before[p] - after <= RESIDUAL_MAX_FIT_DROP {
            fits[p].model = solved;
            for (k, own, wn, zeta) in changed {
                repaired.push(format!(
                    "pose {p}: mode {} {:.1} Hz / {:.0} % -> {:.1} Hz / {:.0} % (its neighbours')",
                    k + 1,
                    own.wn / (2.0 * std::f64::consts::PI),
                    100.0 * own.zeta,
                    wn / (2.0 * std::f64::consts::PI),
                    100.0 * zeta
                ));
            }
        }
    }
    Ok(if repaired.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "modes off a smooth trend that depart wildly at a pose take their nearest poses' pole there ({}): \
             the twin between poses follows the neighbours",
            repaired.join("; ")
        )]
    })
}

/// The pose models with some poles made common, those poles (mode, ωn, ζ), and the
/// largest drop of a pose's fit.
type Frozen = (Vec<ModalModel>, Vec<(usize, f64, f64)>, f64);

/// Largest drop of a measured pose's fit \[points\] that [`common_residual_poles`]
/// accepts for one pole per residual term.
const RESIDUAL_MAX_FIT_DROP: f64 = 1.0;

/// Makes every pose model carry the same modes in the same order.
///
/// The reference is the pose nearest the workspace centre among those with the most
/// common mode count; its model is carried to the nearest not-yet-tracked pose and
/// refined there (Levenberg–Marquardt from the neighbour's modes, each replaced by the
/// matching mode of the pose's own fit when that lies within 20 % in frequency:
/// continuity of frequency, damping and residues), then on from there (Prim's order),
/// so "mode 2" means the same physical mode everywhere.
fn track_modes(fits: &mut [PoseFit], judge: Judge) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    let n = fits.len();
    let mut counts: Vec<usize> = fits.iter().map(|f| f.model.modes.len()).collect();
    counts.sort_unstable();
    let m = common_count(&counts);
    if std::env::var_os("MTWIN_DEBUG_FIT").is_some() {
        eprintln!("tracking: own orders {counts:?}, common {m}");
    }
    let mut centre = [0.0; 3];
    for f in fits.iter() {
        for a in 0..3 {
            centre[a] += f.pose[a] / n as f64;
        }
    }
    let d2 = |p: &[f64; 3], q: &[f64; 3]| (0..3).map(|a| (p[a] - q[a]).powi(2)).sum::<f64>();
    let reference = (0..n)
        .filter(|&i| fits[i].model.modes.len() == m)
        .min_by(|&a, &b| d2(&fits[a].pose, &centre).total_cmp(&d2(&fits[b].pose, &centre)))
        .unwrap_or(0);
    let mut tracked = vec![false; n];
    tracked[reference] = true;
    for _ in 1..n {
        // nearest untracked pose to any tracked pose
        let mut pick = (f64::INFINITY, 0usize, 0usize);
        for i in (0..n).filter(|&i| !tracked[i]) {
            for j in (0..n).filter(|&j| tracked[j]) {
                let d = d2(&fits[i].pose, &fits[j].pose);
                if d < pick.0 {
                    pick = (d, i, j);
                }
            }
        }
        let (_, i, j) = pick;
        let mut start = fits[j].model.clone();
        // start at the pose's own matched modes (modes move by up to ~10 % between
        // neighbouring poses); a mode the own fit lacks is carried from the neighbour
        if fits[i].model.modes.len() == m {
            let own = match_modes(&fits[j].model, &fits[i].model);
            for (s, o) in start.modes.iter_mut().zip(&own.modes) {
                if (o.wn / s.wn).ln().abs() < 0.2 {
                    *s = *o;
                }
            }
        }
        // the neighbour's model is unwindowed; fit in the windowed domain of pose i
        if let Some(s) = fits[i].sigma {
            start.shift_poles(-s);
        }
        let w = crate::rational_fit::weights(&fits[i].fitted, &fits[i].options);
        let mut refined = refine_from(&start, &fits[i].fitted, &w, &fits[i].options)?;
        let score = |f: &[ChannelFit]| match judge {
            Judge::AllChannels => mean_fit(f),
            Judge::Direct => direct_mean_fit(f),
        };
        let band = band_of(&fits[i].frf, &fits[i].options);
        let own = {
            let mut own = fits[i].model.clone();
            if let Some(s) = fits[i].sigma {
                own.shift_poles(-s);
            }
            score(&channel_fits_as(&own, &fits[i].frf, &band, 0, None))
        };
        let carried = score(&channel_fits_as(&refined, &fits[i].frf, &band, 0, None));
        // The neighbour's modes carried over can get stuck far from this pose's optimum
        // (modes move by several per cent across a workspace); when the pose's own fit has
        // the same modes and fits better, keep it, matched to the neighbour's mode order.
        let own_is_better = fits[i].model.modes.len() == m && own > carried + 0.1;
        if carried < own - 1.0 && !own_is_better {
            warnings.push(format!(
                "pose {}: tracked model fits {carried:.2} % vs {own:.2} % for the pose's own \
                 fit ({}); the pose may hold a mode its neighbours lack",
                crate::axis::PoseText(fits[i].pose),
                crate::axis::count(fits[i].model.modes.len(), "mode")
            ));
        }
        if let Some(s) = fits[i].sigma {
            refined.shift_poles(s);
            warnings.extend(
                repair_window_damping(&mut refined, s)
                    .into_iter()
                    .map(|w| format!("pose {}: {w}", crate::axis::PoseText(fits[i].pose))),
            );
        }
        let refined = if own_is_better {
            match_modes(&fits[j].model, &fits[i].model)
        } else {
            match_modes(&fits[j].model, &refined)
        };
        fits[i].model = refined;
        fits[i].order.modes = m;
        tracked[i] = true;
    }
    Ok(warnings)
}

/// Whether [`fit_pose`] tries one fit per force direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PerInput {
    /// As the last alternative of a poor fit.
    Try,
    /// Never (a campaign, whose poses are interpolated through common poles).
    Never,
}

/// Name of the per-direction alternative in `plan.alternatives`.
const PER_INPUT_NAME: &str = "one fit per force direction";

/// The first fit of a pose, then the alternatives when a channel fits its measured FRF
/// worse than [`TRY_ALTERNATIVES_BELOW`]: the inverse-variance weighting (when the
/// campaign allows it) and the balanced weighting, then, if a channel is still below
/// [`QUALITY_WARNING_BELOW`] and the diagram found fewer physical modes than the model
/// has (or none), a deeper
/// stabilization diagram (orders up to 128, no early stop) with the first and the best
/// weighting so far; the best mean channel fit (octave-averaged, [`octave_fits`]) wins
/// (an alternative must gain 0.2 points). The plan records what was tried. Every fit
/// takes its poles from the channels `steer` ([`fit_frf_steered`]).
fn fit_pose(
    frf: &Frf,
    options: &FitOptions,
    mut plan: PosePlan,
    opts: &CampaignOptions,
    pose: [f64; 3],
    per_input: PerInput,
    steer: &[crate::axis::Channel],
) -> Result<(crate::rational_fit::FitResult, PosePlan)> {
    let inputs = input_axes(frf);
    let name = |o: &FitOptions| -> String {
        if let (Some(n), None) = (o.n_modes, options.n_modes) {
            return format!("{} (order raised)", crate::axis::count(n, "mode"));
        }
        format!(
            "{} weighting, diagram orders up to {}",
            match o.weighting {
                Weighting::InverseVariance => "inverse-variance",
                Weighting::Uniform => "uniform",
                Weighting::Balanced => "balanced",
                Weighting::Mobility => "mobility",
                Weighting::Custom(_) => "custom",
                Weighting::Coherence => "coherence",
            },
            o.stabilization.max_order
        )
    };
    let band = band_of(frf, options);
    let judge = crate::plan::steering_channels(&plan);
    let plan_averages = plan.averages;
    // A windowed (Welch) estimate smears sharp peaks: a fit that follows the data there
    // follows the window's bias, which only the coherence records (it drops where the
    // window leaks). There the candidates are ranked by their likelihood, the mean
    // squared error in units of each line's noise; elsewhere by the data they fit.
    let likelihood = plan.excitation.contains("Welch")
        && plan_averages.is_some_and(|n| n > 1)
        && frf.channels.iter().all(|c| c.coherence.is_some());
    let what = if likelihood {
        "likelihood score (100 − mean squared error in noise units)"
    } else {
        "mean fit"
    };
    let score = |r: &crate::rational_fit::FitResult| {
        let mut f = if likelihood {
            noise_scores(&r.model, frf, &band, plan_averages.unwrap_or(2))
        } else {
            octave_fits(&r.model, frf, &band, plan_averages)
        };
        // a channel the plan does not let steer the poles (coherent in part of the band
        // only) counts down to zero: below that it scores its noise, and a fit of -300 %
        // must not outvote the channels that steer (lumped pose g04: xx 94 -> 78 % vs the
        // truth when it did); above it, it still tells a candidate that misses its modes
        for c in f.iter_mut().filter(|c| !judge.contains(&c.channel)) {
            c.fit_pct = c.fit_pct.max(0.0);
        }
        let worst = f.iter().map(|c| c.fit_pct).fold(f64::INFINITY, f64::min);
        (mean_fit(&f), worst)
    };
    let mut candidates: Vec<FitOptions> = Vec::new();
    let ml_allowed = opts.try_ml_weighting && options.weighting == Weighting::Coherence;
    if ml_allowed {
        candidates.push(FitOptions {
            weighting: Weighting::InverseVariance,
            ..options.clone()
        });
        candidates.push(FitOptions {
            weighting: Weighting::Balanced,
            ..options.clone()
        });
        candidates.push(FitOptions {
            weighting: Weighting::Mobility,
            ..options.clone()
        });
    }
    // the first fit and the other weightings do not depend on each other: all at once
    let (first, mut ready): (Result<crate::rational_fit::FitResult>, Vec<_>) = rayon::join(
        || fit_frf_steered(frf, options, steer),
        || {
            candidates
                .par_iter()
                .map(|c| Some(fit_frf_steered(frf, c, steer)))
                .collect()
        },
    );
    let mut best = first.map_err(|e| match e {
        Error::Numerical(msg) => {
            Error::Numerical(format!("pose {}: {msg}", crate::axis::PoseText(pose)))
        }
        other => other,
    })?;
    let debug = std::env::var_os("MTWIN_DEBUG_FIT").is_some();
    if debug {
        eprintln!("pose {pose:?}, first fit:\n{}", best.report);
    }
    // a pose alone at the automatic order (a forced order is the user's): noise-line modes
    // removed, drifting candidates rejected (in a campaign
    // the tracking and residual-pole freezing pair and replace the poles of all poses, and
    // removing modes pose by pose cost the second generator's campaign 14 points of yy)
    let guards = crate::guards::ModelGuards::new(frf, band.pose, &judge)
        .filter(|_| per_input == PerInput::Try);
    let prune = |r: &mut crate::rational_fit::FitResult| guards.as_ref()?.prune(&mut r.model);
    let drifting = |m: &crate::model::ModalModel| guards.as_ref()?.drifting(m);
    if let Some(why) = prune(&mut best) {
        plan.alternatives.push(format!("{}: {why}", name(options)));
    }
    let mut best_score = score(&best);
    if let Some(why) = drifting(&best.model) {
        plan.alternatives.push(format!(
            "{}: {why}; any alternative replaces it",
            name(options)
        ));
        best_score = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    }
    let mut best_name = name(options);
    let mut best_options = options.clone();
    let deep = |o: &FitOptions| {
        let mut o = o.clone();
        o.stabilization.max_order = o.stabilization.max_order.max(128);
        o.stabilization.quiet_orders = 0;
        o
    };
    let mut tried_deep = false;
    let mut tried_order = false;
    let mut i = 0;
    while i < candidates.len() || (!tried_order && options.n_modes.is_none()) {
        if i >= candidates.len() && tried_deep {
            // last: one and two pairs more than the best fit's automatic order (a mode
            // merged with its neighbour, or one whose peak spans two lines, leaves a misfit
            // the order rule's global residual did not weigh)
            tried_order = true;
            if best_score.0 >= TRY_ALTERNATIVES_BELOW {
                break;
            }
            let n = best.model.modes.len();
            for extra in [1, 2] {
                candidates.push(FitOptions {
                    n_modes: Some(n + extra),
                    ..best_options.clone()
                });
            }
            continue;
        }
        if i >= candidates.len() {
            // the deeper diagram only for a poor fit whose modes the diagram did not account
            // for (it found none, or the order rule had to add pairs it did not see): a
            // deeper diagram cannot help a fit whose modes the diagram already all found
            tried_deep = true;
            let physical = best.diagram.n_physical();
            if best_score.1 >= QUALITY_WARNING_BELOW
                || (physical > 0 && physical >= best.model.modes.len())
            {
                continue;
            }
            candidates.push(deep(options));
            if best_options != *options {
                candidates.push(deep(&best_options));
            }
            continue;
        }
        if ready.len() < candidates.len() {
            // every pending candidate of this batch at once (they do not depend on each
            // other; the choice below still goes through them in order)
            let fresh: Vec<Option<Result<crate::rational_fit::FitResult>>> = candidates
                [ready.len()..]
                .par_iter()
                .map(|c| Some(fit_frf_steered(frf, c, steer)))
                .collect();
            ready.extend(fresh);
        }
        let cand = &candidates[i];
        let fitted_cand = ready[i]
            .take()
            .unwrap_or_else(|| fit_frf_steered(frf, cand, steer));
        i += 1;
        match fitted_cand {
            Ok(alt) if drifting(&alt.model).is_some() => plan.alternatives.push(format!(
                "{}: {}",
                name(cand),
                drifting(&alt.model).unwrap_or_default()
            )),
            Ok(mut alt) => {
                if let Some(why) = prune(&mut alt) {
                    plan.alternatives.push(format!("{}: {why}", name(cand)));
                }
                let s = score(&alt);
                if debug {
                    eprintln!("pose {pose:?}, {}:\n{}", name(cand), alt.report);
                }

                // a forced higher order must earn its modes: one point of mean fit
                let gain = if cand.n_modes.is_some() && options.n_modes.is_none() {
                    ORDER_ALTERNATIVE_GAIN
                } else {
                    0.2
                };
                let better = s.0 > best_score.0 + gain;
                plan.alternatives.push(format!(
                    "{}: {what} {:.2} %, worst channel {:.2} %, {}{}",
                    name(cand),
                    s.0,
                    s.1,
                    crate::axis::count(alt.model.modes.len(), "mode"),
                    if better { " (kept)" } else { "" }
                ));
                if better {
                    best = alt;
                    best_score = s;
                    best_name = name(cand);
                    best_options = cand.clone();
                }
            }
            Err(e) => plan
                .alternatives
                .push(format!("{}: failed ({e})", name(cand))),
        }
    }
    // last, for a poor fit of several hammer directions: one fit per force direction
    // (each with its own poles). Where the directions excite different modes (x and y
    // modes of a machine that do not couple), common poles must place one pole between
    // two neighbouring modes of the two directions and miss both.
    if per_input == PerInput::Try
        && options.n_modes.is_none()
        && inputs.len() >= 2
        && best_score.0 < TRY_ALTERNATIVES_BELOW
    {
        let sub_options = FitOptions {
            n_modes: None,
            ..best_options.clone()
        };
        match fit_per_input(frf, &inputs, &sub_options, steer) {
            Ok(alt) if drifting(&alt.model).is_some() => plan.alternatives.push(format!(
                "{PER_INPUT_NAME}: {}",
                drifting(&alt.model).unwrap_or_default()
            )),
            Ok(mut alt) => {
                if let Some(why) = prune(&mut alt) {
                    plan.alternatives.push(format!("{PER_INPUT_NAME}: {why}"));
                }
                let s = score(&alt);
                let better = s.0 > best_score.0 + ORDER_ALTERNATIVE_GAIN;
                let cand_name = format!(
                    "{PER_INPUT_NAME} ({})",
                    crate::axis::count(alt.model.modes.len(), "mode")
                );
                plan.alternatives.push(format!(
                    "{cand_name}: {what} {:.2} %, worst channel {:.2} %{}",
                    s.0,
                    s.1,
                    if better { " (kept)" } else { "" }
                ));
                if better {
                    best = alt;
                    best_score = s;
                    best_name = cand_name;
                }
            }
            Err(e) => plan
                .alternatives
                .push(format!("{PER_INPUT_NAME}: failed ({e})")),
        }
    }
    if let Some(why) = guards
        .as_ref()
        .and_then(|g| g.damp_unresolved_outside(&mut best.model))
    {
        plan.alternatives.push(format!("{best_name}: {why}"));
    }
    let power = plan.measured_as.map_or(0, |m| m.power());
    if let Some(why) = guards
        .as_ref()
        .and_then(|g| repair_unseen_peaks(g, &mut best, frf, &best_options, power, &score))
    {
        plan.alternatives.push(format!("{best_name}: {why}"));
    }
    if let Some(why) = repair_held_channels(&mut best, frf, &best_options, &plan, steer) {
        plan.alternatives.push(format!("{best_name}: {why}"));
    }
    if !plan.alternatives.is_empty() {
        plan.alternatives.insert(
            0,
            format!(
                "kept: {best_name} ({what} {:.2} %, worst channel {:.2} %)",
                best_score.0, best_score.1
            ),
        );
    }
    Ok((best, plan))
}

/// Each in-band mode of `best` whose peak falls between the lines and none of them shows
/// ([`crate::guards::ModelGuards::unseen_peaks`]) is either given the damping of a one-line
/// half-power band (`ζ = Δf / 2f`, the narrowest the lines resolve) or removed, whichever
/// scores better with the numerators solved again for the poles left, when that costs at
/// most [`crate::guards::UNSEEN_PEAK_FIT_LOSS`] points of the candidate's score and of
/// each channel's fit over the band (as receptance and as measured, `(jω)^power`). Its
/// height was set by a damping no line fixes, and a time simulation of the twin rings
/// with it for seconds. A real lightly damped mode whose skirts the lines beside it hold
/// costs more and is kept (the pyuff free-free beam's 51.5 Hz mode at 0.05 %: 5.9-6.2
/// points). Says what it changed.
fn repair_unseen_peaks(
    g: &crate::guards::ModelGuards,
    best: &mut crate::rational_fit::FitResult,
    frf: &Frf,
    options: &FitOptions,
    power: i32,
    score: &dyn Fn(&crate::rational_fit::FitResult) -> (f64, f64),
) -> Option<String> {
    let mut notes = Vec::new();
    // from the highest index down: a removal does not move the modes still to repair
    let mut unseen = g.unseen_peaks(&best.model);
    unseen.reverse();
    for k in unseen {
        let md = best.model.modes[k];
        let (hz, z0) = (md.freq_hz(), md.zeta);
        let w = crate::rational_fit::weights(frf, options);
        let solved = |m: ModalModel| -> Option<crate::rational_fit::FitResult> {
            let model = crate::rational_fit::solve_numerators(&m, frf, &w, options).ok()?;
            (model.is_valid()).then(|| crate::rational_fit::FitResult {
                model,
                ..best.clone()
            })
        };
        let mut damped = best.model.clone();
        damped.modes[k].zeta = (g.line_spacing() / (2.0 * hz)).clamp(z0, 1.0);
        let mut removed = best.model.clone();
        removed.modes.remove(k);
        for c in removed.channels.iter_mut() {
            c.num.remove(k);
        }
        let options: Vec<(&str, crate::rational_fit::FitResult)> = [
            ("damped to a one-line half-power band", solved(damped)),
            ("removed", solved(removed)),
        ]
        .into_iter()
        .filter_map(|(what, r)| r.map(|r| (what, r)))
        .collect();
        let Some((what, r, s)) = options
            .into_iter()
            .map(|(what, r)| {
                let s = score(&r);
                (what, r, s)
            })
            .max_by(|a, b| a.2 .0.total_cmp(&b.2 .0))
        else {
            continue;
        };
        let before = score(best);
        // the loss in the candidate's score (each octave alike) and in each channel's fit
        // over the band (where the largest peaks weigh most), as receptance and as measured
        let band_fits =
            |m: &ModalModel, p: i32| channel_fits_as(m, frf, &Bands::whole(g.band()), p, None);
        let band_loss = [0, power]
            .iter()
            .flat_map(|&p| {
                band_fits(&best.model, p)
                    .into_iter()
                    .zip(band_fits(&r.model, p))
                    .map(|(a, b)| a.fit_pct - b.fit_pct)
                    .collect::<Vec<_>>()
            })
            .fold(0.0, f64::max);
        let loss = (before.0 - s.0).max(band_loss);
        if !(loss <= crate::guards::UNSEEN_PEAK_FIT_LOSS) {
            notes.push(format!(
                "the mode at {hz:.1} Hz ({:.4} %) kept as fitted: its peak stands between \
                 the lines, but the lines beside it hold it (the best repair, {what}, \
                 costs {loss:.2} points of fit)",
                100.0 * z0,
            ));
            continue;
        }
        notes.push(format!(
            "the mode at {hz:.1} Hz ({:.4} %) {what}, numerators solved again (its peak \
             between the lines stood at least {} times above every line within two \
             spacings; mean fit {:.2} -> {:.2} %)",
            100.0 * z0,
            crate::guards::UNSEEN_PEAK_RATIO,
            before.0,
            s.0
        ));
        *best = r;
    }
    (!notes.is_empty()).then(|| notes.join("; "))
}

/// A held channel of a single pose (its numerators fitted with the poles of the steering
/// channels held, [`crate::rational_fit::fit_frf_steered`]) whose fit to its own FRF in
/// its trusted band falls short of what that FRF's noise allows by more than
/// [`NOISE_LIMIT_MARGIN`]: its numerators are solved again, poles held, under each
/// weighting the fit knows (the pose's weighting served the steering channels); the best
/// fit in the trusted band (as measured) is kept when it gains [`HELD_REPAIR_MIN_GAIN`]
/// points and the channel does not run away over the pose band. The poles and every
/// other channel stay as they are. (Second generator, seed 9: the `zx` of a centre twin
/// at −190 % of its measured accelerance in 138-2300 Hz, whose noise allows 74 %; solved
/// again under the balanced weighting 58.6 %, and vs the analytic truth over 30-2500 Hz
/// 17.1 → 40.5 % as receptance. Weighing the lines outside the trusted band ten times less
/// fitted the trusted band better but lost the receptance below it: seed 18, 34.6 →
/// 13.2 %.) Says what it changed.
fn repair_held_channels(
    best: &mut crate::rational_fit::FitResult,
    frf: &Frf,
    options: &FitOptions,
    plan: &PosePlan,
    steer: &[crate::axis::Channel],
) -> Option<String> {
    let power = plan.measured_as.map_or(0, |m| m.power());
    let pose_band = band_of(frf, options);
    let bands = plan.bands(pose_band.pose);
    let averages = plan.averages;
    let fits = |m: &ModalModel, b: &Bands| channel_fits_as(m, frf, b, power, averages);
    let mut notes = Vec::new();
    for (ci, c) in frf.channels.iter().enumerate() {
        if steer.contains(&c.channel) || best.model.channel_index(c.channel) != Some(ci) {
            continue;
        }
        let Some([lo, hi]) = bands.own(c.channel) else {
            continue;
        };
        let Some(before) = fits(&best.model, &bands)
            .into_iter()
            .find(|f| f.channel == c.channel)
        else {
            continue;
        };
        let Some(limit) = before.noise_limit_pct else {
            continue;
        };
        if !(before.fit_pct < limit - NOISE_LIMIT_MARGIN) {
            continue;
        }
        let whole = |m: &ModalModel| {
            fits(m, &Bands::whole(pose_band.pose))
                .into_iter()
                .find(|f| f.channel == c.channel)
                .map_or(f64::NEG_INFINITY, |f| f.fit_pct)
        };
        let mut found: Option<(f64, ModalModel, &str)> = None;
        for (name, weighting) in [
            ("coherence", Weighting::Coherence),
            ("balanced", Weighting::Balanced),
            ("mobility", Weighting::Mobility),
            ("inverse-variance", Weighting::InverseVariance),
        ] {
            let o = FitOptions {
                weighting,
                ..options.clone()
            };
            let w = crate::rational_fit::weights(frf, &o);
            let Ok(m) = crate::rational_fit::solve_numerators(&best.model, frf, &w, &o) else {
                continue;
            };
            let mut cand = best.model.clone();
            cand.channels[ci] = m.channels[ci].clone();
            if !cand.is_valid() || whole(&cand) < HELD_RUNAWAY_PCT {
                continue;
            }
            let Some(after) = fits(&cand, &bands)
                .into_iter()
                .find(|f| f.channel == c.channel)
            else {
                continue;
            };
            if found.as_ref().is_none_or(|(a, _, _)| after.fit_pct > *a) {
                found = Some((after.fit_pct, cand, name));
            }
        }
        if let Some((after, cand, name)) = found {
            if after >= before.fit_pct + HELD_REPAIR_MIN_GAIN {
                notes.push(format!(
                    "{}: numerators solved again with the poles held ({name} weighting): \
                     fit in its trusted {lo:.0}-{hi:.0} Hz {:.1} -> {after:.1} % (its \
                     noise allows {limit:.1} %)",
                    c.channel, before.fit_pct
                ));
                best.model = cand;
            }
        }
    }
    (!notes.is_empty()).then(|| notes.join("; "))
}

/// Points of fit in its trusted band a held channel's repair must gain to be kept.
const HELD_REPAIR_MIN_GAIN: f64 = 1.0;
/// Fit over the pose band \[%\] below which a repaired held channel has run away.
const HELD_RUNAWAY_PCT: f64 = -100.0;

/// The force axes of `frf`'s channels, in axis order.
fn input_axes(frf: &Frf) -> Vec<crate::axis::Axis> {
    let mut v: Vec<crate::axis::Axis> = frf.channels.iter().map(|c| c.channel.input).collect();
    v.sort_by_key(|a| a.index());
    v.dedup();
    v
}

/// One fit per force direction of `frf`, merged into one model: the modes of all fits,
/// sorted by frequency, each with its numerators in the channels of its own direction
/// and zero in the others.
fn fit_per_input(
    frf: &Frf,
    inputs: &[crate::axis::Axis],
    options: &FitOptions,
    steer: &[crate::axis::Channel],
) -> Result<crate::rational_fit::FitResult> {
    let mut parts = Vec::new();
    for a in inputs {
        let chans: Vec<crate::axis::Channel> = frf
            .channels
            .iter()
            .map(|c| c.channel)
            .filter(|c| c.input == *a)
            .collect();
        parts.push(fit_frf_steered(
            &select_channels(frf, &chans),
            options,
            steer,
        )?);
    }
    // (mode, source fit, index in it), by frequency
    let mut order: Vec<(crate::model::Mode, usize, usize)> = parts
        .iter()
        .enumerate()
        .flat_map(|(i, r)| {
            r.model
                .modes
                .iter()
                .enumerate()
                .map(move |(k, m)| (*m, i, k))
        })
        .collect();
    order.sort_by(|a, b| a.0.wn.total_cmp(&b.0.wn));
    let mut model = ModalModel {
        modes: order.iter().map(|o| o.0).collect(),
        channels: Vec::new(),
    };
    let mut fit_pct = Vec::new();
    for c in &frf.channels {
        let Some((i, cm)) = parts.iter().enumerate().find_map(|(i, r)| {
            r.model
                .channels
                .iter()
                .find(|m| m.channel == c.channel)
                .map(|m| (i, m))
        }) else {
            continue;
        };
        let num = order
            .iter()
            .map(|&(_, src, k)| {
                if src == i {
                    cm.num[k]
                } else {
                    crate::model::ModeNum { b0: 0.0, b1: 0.0 }
                }
            })
            .collect();
        model.channels.push(crate::model::ChannelModel {
            channel: c.channel,
            num,
            d: cm.d,
        });
        if let Some(f) = parts[i].fit_pct.iter().find(|f| f.0 == c.channel) {
            fit_pct.push(*f);
        }
    }
    let first = parts.swap_remove(0);
    Ok(crate::rational_fit::FitResult {
        model,
        fit_pct,
        diagram: first.diagram,
        automatic_order: true,
        report: first.report,
    })
}

/// Points of mean fit a forced higher order (the automatic order plus one or two pairs)
/// must gain over the best automatic fit to be kept.
const ORDER_ALTERNATIVE_GAIN: f64 = 1.0;

/// Two tracked modes of one pose count as coincident when their natural frequencies
/// differ by less than this fraction of the smaller half-power half-width `ζω`.
const COINCIDENT_SEPARATION: f64 = 0.5;

/// Where two tracked modes of a pose coincide (a crossing of their frequencies inside the
/// workspace), the data fix only the sum of their numerators: any split fits the FRF
/// alike, and an arbitrary one spoils the interpolation towards every neighbour. The
/// split is taken from the other poses instead ([`ridge_split`] towards their
/// interpolation at this pose), kept only when the pose's own fit drops by less than
/// 0.05 points. One warning per re-split pair.
fn resplit_coincident_modes(fits: &mut [PoseFit]) -> Vec<String> {
    let mut notes = Vec::new();
    if fits.len() < 3 {
        return notes;
    }
    for i in 0..fits.len() {
        let n = fits[i].model.modes.len();
        let mut pairs = Vec::new();
        for a in 0..n {
            for b in a + 1..n {
                let (ma, mb) = (fits[i].model.modes[a], fits[i].model.modes[b]);
                let half = (ma.zeta * ma.wn).min(mb.zeta * mb.wn);
                if (ma.wn - mb.wn).abs() < COINCIDENT_SEPARATION * half {
                    pairs.push((a, b));
                }
            }
        }
        // an exponential window's damping is removed from the model but not from the
        // FRF: the split is only re-solved on unwindowed estimates
        if pairs.is_empty() || fits[i].sigma.is_some() {
            continue;
        }
        let others: Vec<([f64; 3], &ModalModel)> = fits
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, f)| (f.pose, &f.model))
            .collect();
        let Ok(mut ev) = TwinEvaluator::from_poses(&others) else {
            continue;
        };
        let pred = ev.model_at(fits[i].pose).clone();
        if pred.modes.len() != n {
            continue;
        }
        let band = band_of(&fits[i].frf, &fits[i].options);
        let before = mean_fit(&channel_fits_as(
            &fits[i].model,
            &fits[i].frf,
            &band,
            0,
            None,
        ));
        for (a, b) in pairs {
            let Some(trial) = ridge_split(&fits[i].model, &pred, &fits[i].frf, band.pose, (a, b))
            else {
                continue;
            };
            let after = mean_fit(&channel_fits_as(&trial, &fits[i].frf, &band, 0, None));
            if after >= before - 0.05 {
                notes.push(format!(
                    "pose {}: modes at {:.1} and {:.1} Hz coincide (the data fix only their \
                     sum); their split taken from the other poses (fit {:.2} -> {:.2} %)",
                    crate::axis::PoseText(fits[i].pose),
                    trial.modes[a].freq_hz(),
                    trial.modes[b].freq_hz(),
                    before,
                    after
                ));
                fits[i].model = trial;
            }
        }
    }
    notes
}

/// The coincident modes `pair` of `model` with the poles of `pred` (the other poses'
/// interpolation: fitted together with an arbitrary split, the pair's poles are as
/// uncertain as the split), then the numerators of every channel re-solved on `frf`
/// within `band` with the pair's pulled weakly towards `pred`'s: the data decide what
/// they determine (the sum), the prior the direction they leave open (the split). Least
/// squares on unit-norm columns, ridge 0.1 on the pair's four numerator coefficients.
fn ridge_split(
    model: &ModalModel,
    pred: &ModalModel,
    frf: &Frf,
    band: (f64, f64),
    pair: (usize, usize),
) -> Option<ModalModel> {
    use nalgebra::{DMatrix, DVector};
    const RIDGE: f64 = 1e-1;
    let b = frf.band(band.0, band.1);
    let n = model.modes.len();
    let cols = 2 * n + 1;
    let mut out = model.clone();
    // the pair's poles, fitted together with an arbitrary split, are as uncertain as the
    // split: both taken from the other poses too
    out.modes[pair.0] = pred.modes[pair.0];
    out.modes[pair.1] = pred.modes[pair.1];
    let model = &out.clone();
    for (ci, ch) in model.channels.iter().enumerate() {
        let data = b.channels.iter().find(|c| c.channel == ch.channel)?;
        let pc = &pred.channels[pred.channel_index(ch.channel)?];
        let lines = b.freqs_hz.len();
        let mut a_m = DMatrix::<f64>::zeros(2 * lines + 4, cols);
        let mut rhs = DVector::<f64>::zeros(2 * lines + 4);
        for (k, &f) in b.freqs_hz.iter().enumerate() {
            let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f);
            for (j, m) in model.modes.iter().enumerate() {
                let inv = 1.0 / m.den(s);
                let c1 = s * inv;
                a_m[(2 * k, 2 * j)] = inv.re;
                a_m[(2 * k + 1, 2 * j)] = inv.im;
                a_m[(2 * k, 2 * j + 1)] = c1.re;
                a_m[(2 * k + 1, 2 * j + 1)] = c1.im;
            }
            a_m[(2 * k, 2 * n)] = 1.0;
            rhs[2 * k] = data.h[k].re;
            rhs[2 * k + 1] = data.h[k].im;
        }
        let norms: Vec<f64> = (0..cols)
            .map(|c| a_m.column(c).norm().max(f64::MIN_POSITIVE))
            .collect();
        for (c, nrm) in norms.iter().enumerate() {
            a_m.column_mut(c).scale_mut(1.0 / nrm);
        }
        let ridge = [(pair.0, 0), (pair.0, 1), (pair.1, 0), (pair.1, 1)];
        for (r, (j, which)) in ridge.into_iter().enumerate() {
            let c = 2 * j + which;
            let target = if which == 0 {
                pc.num[j].b0
            } else {
                pc.num[j].b1
            };
            a_m[(2 * lines + r, c)] = RIDGE;
            rhs[2 * lines + r] = RIDGE * target * norms[c];
        }
        let x = a_m.svd(true, true).solve(&rhs, 1e-14).ok()?;
        let oc = &mut out.channels[ci];
        for j in 0..n {
            oc.num[j].b0 = x[2 * j] / norms[2 * j];
            oc.num[j].b1 = x[2 * j + 1] / norms[2 * j + 1];
        }
        oc.d = x[2 * n] / norms[2 * n];
    }
    out.is_valid().then_some(out)
}

/// Damping ratio given to a mode whose fitted damping was smaller than what the
/// exponential window added (the unwindowed model would be unstable).
pub const MIN_REPAIRED_DAMPING: f64 = 1e-4;

/// After removing an exponential window's damping (`shift_poles(sigma)`), a mode whose
/// fitted damping was within the window's own is unstable or undamped: its damping
/// ratio becomes half the window's (at least [`MIN_REPAIRED_DAMPING`]), and a warning
/// says so. The model stays
/// loadable (`is_valid`).
fn repair_window_damping(model: &mut ModalModel, sigma: f64) -> Vec<String> {
    let mut out = Vec::new();
    for m in &mut model.modes {
        if !(m.zeta >= MIN_REPAIRED_DAMPING) && m.wn.is_finite() && m.wn > 0.0 {
            // the fit says the mode's own damping lies between 0 and the window's: half
            // the window's is the guess with the smallest worst-case error (0.01 % made
            // its peak up to a hundred times too tall)
            let zeta = (0.5 * sigma / m.wn).clamp(MIN_REPAIRED_DAMPING, 0.2);
            out.push(format!(
                "mode at {:.1} Hz: its fitted damping is within the exponential window's \
                 ({:.3} %); set to {:.3} %, half the window's (the data cannot tell it; use a \
                 longer record)",
                m.wn / (2.0 * std::f64::consts::PI),
                100.0 * sigma / m.wn,
                100.0 * zeta
            ));
            m.zeta = zeta;
        }
    }
    out
}

/// One warning per channel whose model fits its measured FRF in `band` worse than
/// [`QUALITY_WARNING_BELOW`], saying what to try.
fn quality_warnings(
    pose: [f64; 3],
    fit: &[ChannelFit],
    band: (f64, f64),
    measured_as: Option<crate::plan::MeasuredAs>,
) -> Vec<String> {
    let what = measured_as.map_or("measured FRF", |m| m.name());
    fit.iter()
        // as good as the data's noise allows (within 5 points) is not a poor fit
        .filter(|c| {
            !(c.fit_pct >= QUALITY_WARNING_BELOW)
                && c.noise_limit_pct
                    .is_none_or(|l| c.fit_pct < l - NOISE_LIMIT_MARGIN)
        })
        .map(|c| {
            format!(
                "POOR FIT at pose ({:.3}, {:.3}, {:.3}) m, channel {}: the model fits its own \
                 {what} at {:.1} % in {:.0}-{:.0} Hz (target {QUALITY_WARNING_BELOW} %); \
                 check that channel's coherence and band in the report, try --order with more \
                 modes, --weighting ml, or narrow --fmin/--fmax to the modes of interest",
                pose[0],
                pose[1],
                pose[2],
                c.channel,
                c.fit_pct,
                c.band_hz.map_or(band.0, |b| b[0]),
                c.band_hz.map_or(band.1, |b| b[1])
            )
        })
        .collect()
}

/// [`mean_fit`] over the direct channels (response along the force) when there are any:
/// the channels a pose's modes are judged by (a cross channel near its noise floor scores
/// its noise).
fn direct_mean_fit(f: &[ChannelFit]) -> f64 {
    let direct: Vec<ChannelFit> = (f.iter())
        .filter(|c| c.channel.output == c.channel.input)
        .cloned()
        .collect();
    if direct.is_empty() {
        mean_fit(f)
    } else {
        mean_fit(&direct)
    }
}

fn mean_fit(f: &[ChannelFit]) -> f64 {
    if f.is_empty() {
        return f64::NAN;
    }
    f.iter().map(|c| c.fit_pct).sum::<f64>() / f.len() as f64
}

/// Method name and leave-one-pose-out figures of a twin's interpolation.
pub fn interpolation_info(twin: &Twin) -> Result<InterpolationInfo> {
    let ev = TwinEvaluator::new(twin)?;
    let mut info = InterpolationInfo {
        method: match ev.method() {
            Method::Single => "single",
            Method::TensorGrid => "tensor_grid",
            Method::Rbf => "rbf",
        }
        .into(),
        ..Default::default()
    };
    if twin.poses.len() >= 3 {
        let mut methods = Vec::new();
        for i in 0..twin.poses.len() {
            let others: Vec<([f64; 3], &ModalModel)> = twin
                .poses
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, p)| (p.pose, &p.model))
                .collect();
            let mut ev = TwinEvaluator::from_poses(&others)?;
            methods.push(ev.method());
            let p = &twin.poses[i];
            let mut m = ev.model_at(p.pose).clone();
            if let Some(s) = p.frf_exp_window_sigma {
                m.shift_poles(-s);
            }
            let band = (p.band_hz[0], p.band_hz[1]);
            let bands = p
                .plan
                .as_ref()
                .map_or(Bands::whole(band), |pl| pl.bands(band));
            info.leave_one_out.push(LooEntry {
                pose: p.pose,
                fit: channel_fits_as(&m, &p.frf, &bands, 0, None),
            });
        }
        methods.dedup();
        info.leave_one_out_method = format!(
            "each pose predicted from the others ({:?}); fit against its measured FRF",
            methods
        );
    }
    Ok(info)
}

#[cfg(test)]
mod window_repair_tests {
    use super::*;
    use crate::axis::{Axis, Channel};
    use crate::model::{ChannelModel, Mode, ModeNum};

    /// A mode whose fitted damping (1 %) is below the exponential window's (2 %): after
    /// the window is removed it gets half the window's damping, stays loadable and warns.
    #[test]
    fn a_mode_under_the_window_gets_half_its_damping() {
        let wn = 2.0 * std::f64::consts::PI * 100.0;
        let mut model = ModalModel {
            modes: vec![Mode::from_hz(100.0, 0.01)],
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num: vec![ModeNum { b0: 1.0, b1: 0.0 }],
                d: 0.0,
            }],
        };
        let sigma = 0.02 * wn;
        model.shift_poles(sigma);
        let w = repair_window_damping(&mut model, sigma);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            (model.modes[0].zeta - 0.01).abs() < 1e-3,
            "{:?}",
            model.modes[0]
        );
        assert!(model.is_valid());
    }
}

#[cfg(test)]
mod campaign_band_tests {
    use super::*;

    fn plans(bands: &[(f64, f64)]) -> Vec<PosePlan> {
        (bands.iter())
            .map(|&(a, b)| PosePlan {
                band_hz: [a, b],
                ..Default::default()
            })
            .collect()
    }

    /// Most poses hold a coherent resonance below the median trusted band: the common
    /// band reaches it; a few poses that do (or lines a little lower) never move it.
    #[test]
    fn the_band_grows_to_a_resonance_only_when_most_poses_hold_it() {
        let plain = plans(&[(130.0, 3700.0); 5]);
        let most = plans(&[
            (68.0, 3700.0),
            (70.0, 3700.0),
            (72.0, 3700.0),
            (126.0, 3700.0),
            (130.0, 3700.0),
        ]);
        let (lo, hi, why) = campaign_band(&plain, &most);
        assert_eq!((lo, hi), (72.0, 3700.0), "{why}");
        assert!(why.contains("grown"), "{why}");
        let few = plans(&[
            (68.0, 3700.0),
            (70.0, 3700.0),
            (126.0, 3700.0),
            (126.0, 3700.0),
            (130.0, 3700.0),
        ]);
        let (lo, _, why) = campaign_band(&plain, &few);
        assert_eq!(lo, 130.0, "{why}");
        assert_eq!(why, "the median of the poses' own bands");
    }
}
