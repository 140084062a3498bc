//! Rational fit of measured FRFs (what MATLAB `tfest` does in the paper's section 2.2,
//! minimising its equation 2, `Σ |W (H − F)|²`).
//!
//! All channels of a pose share their poles; each channel has its own numerators and
//! constant residual. The fit runs in three stages, all in scaled units (frequency
//! divided by the band top, every channel normalised to unit weighted RMS):
//!
//! 1. **Order** ([`crate::stabilization`]): a pLSCF stabilization diagram gives the
//!    physical modes (poles stable over several orders, physically damped, where the
//!    coherence is good). With [`FitOptions::n_modes`] = `None` their number is the
//!    starting order.
//! 2. **Sanathanan–Koerner iterations as relaxed vector fitting** (common poles,
//!    partial-fraction basis, unstable poles flipped) from the diagram's poles, filled up
//!    with lightly damped pairs where needed.
//! 3. **Refinement** of the true weighted error by Levenberg–Marquardt over each mode's
//!    `(ln ω, ln ζ)` — so every mode stays stable — with the numerators eliminated by
//!    variable projection.
//!
//! **Automatic order rule.** Start with the physical modes of the diagram (at least one).
//! Then add one pole pair at a time, placed at the line of largest weighted residual,
//! while the relative weighted residual `‖W(H−F)‖/‖W F‖` is above
//! [`FitOptions::target_residual`] and above the noise floor implied by the coherence
//! (`σ² = |F|² (1−γ²)/γ²` per line, when coherence is given), and while each new pair
//! lowers the residual by at least [`FitOptions::min_improvement`] (one extra pair of
//! look-ahead, so two close modes that only pay off together are still found). The
//! extra pairs stand for close modes the diagram could not separate and for out-of-band
//! influence; modes are never added where the lines are unusable because unusable lines
//! carry no weight.
//!
//! ```
//! use identify::axis::{Axis, Channel};
//! use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
//! use identify::rational_fit::{fit_frf, FitOptions};
//! let truth = ModalModel {
//!     modes: vec![Mode::from_hz(80.0, 0.02), Mode::from_hz(210.0, 0.03)],
//!     channels: vec![ChannelModel {
//!         channel: Channel::new(Axis::X, Axis::X),
//!         num: vec![ModeNum { b0: 1.0, b1: 0.0 }, ModeNum { b0: 2.0, b1: 0.0 }],
//!         d: 0.0,
//!     }],
//! };
//! let freqs: Vec<f64> = (1..=400).map(|k| k as f64).collect();
//! let fit = fit_frf(&truth.frf(&freqs), &FitOptions::default()).unwrap();
//! assert_eq!(fit.model.modes.len(), 2);
//! assert!(fit.fit_pct[0].1 > 99.9);
//! ```

mod data;
mod pf_gram;
mod varpro;
mod vf;

use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::frf::{fit_percent, Frf};
use crate::model::{ModalModel, Mode};
use crate::stabilization::{self, StabilizationDiagram, StabilizationOptions};
use data::Prepared;
use num_complex::Complex64;
use std::f64::consts::PI;
use std::fmt::Write as _;
use varpro::Solved;

pub use crate::stabilization::poly_roots;

/// How the lines are weighted in `Σ |W (H − F)|²`.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Weighting {
    /// Default. `W² ∝ γ²/(1−γ²)` (the inverse relative variance of an H1 estimate),
    /// with γ² clipped at 0.99 so every line of coherence ≥ 0.99 counts fully (W = 1);
    /// uniform for channels without coherence. Lines below
    /// [`FitOptions::min_coherence`] get W = 0.
    #[default]
    Coherence,
    /// W = 1 on every line (the paper's 3-DoF example).
    Uniform,
    /// The maximum-likelihood weight of an H1 estimate: `W = 1/σ` with the line's
    /// standard deviation `σ² = |H|² (1−γ²)/γ²` (γ² capped at 0.9999), so small
    /// resonances far below the largest peak count as much as their noise allows.
    /// Uniform for channels without coherence.
    InverseVariance,
    /// The coherence weight divided by the FRF's level around each line (its RMS over
    /// ±1/6 octave), so every part of the band counts alike whatever the dynamic range
    /// (receptance of an accelerometer test spans decades): a relative, near-logarithmic
    /// error, with resonances still above their neighbourhood.
    Balanced,
    /// The coherence weighting of the *mobility* (receptance × jω): `W` of
    /// [`Weighting::Coherence`] times the line's frequency. Between the receptance, whose
    /// low end dominates (mass lines of a free or softly held structure, or of an
    /// accelerometer test, span decades there), and the accelerance, whose sharp
    /// high-frequency peaks dominate: mass and stiffness lines both slope by one decade
    /// per decade, so resonances at both ends of a wide band count.
    Mobility,
    /// Amplitude weight W per channel per line of the input FRF (≥ 0).
    Custom(Vec<Vec<f64>>),
}

/// Settings of [`fit_frf`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Number of modes (pole pairs); `None` = automatic (see the module docs).
    pub n_modes: Option<usize>,
    /// Fitted band \[Hz\], inclusive; `None` = every line.
    pub band_hz: Option<(f64, f64)>,
    /// Line weighting.
    pub weighting: Weighting,
    /// Lines whose coherence is below this are not fitted (default 0.5).
    pub min_coherence: f64,
    /// Upper limit of the automatic order in pole pairs (default 40).
    pub max_modes: usize,
    /// Maximum vector-fitting (SK) iterations per order (default 12).
    pub sk_iterations: usize,
    /// Run the Levenberg–Marquardt refinement of the true weighted error (default true).
    pub refine: bool,
    /// Maximum Levenberg–Marquardt iterations (default 30).
    pub lm_iterations: usize,
    /// Automatic order: stop adding pairs once the relative weighted residual is below
    /// this (default 1e-3).
    pub target_residual: f64,
    /// Automatic order: an added pair must lower the relative weighted residual by this
    /// fraction (default 0.05).
    pub min_improvement: f64,
    /// Automatic order: the residual counts as measurement noise (no mode missing) when
    /// its lag-one correlation along frequency is below this (default 0.5).
    pub white_residual: f64,
    /// Automatic order: keep adding pairs while a few neighbouring lines are misfit far
    /// beyond their noise and by more than 3 % of the data there (a sharp resonance the
    /// global residual cannot see; default true). Only for estimates without peak bias:
    /// a windowed (Welch) estimate smears a sharp peak, and the check would fit the
    /// smearing with spurious modes.
    pub sharp_peaks: bool,
    /// Settings of the stabilization diagram.
    pub stabilization: StabilizationOptions,
    /// Automatic order: the residual of every direct channel (response along its force)
    /// must also be within twice that channel's own noise before the order counts as
    /// enough, however noisy the cross channels fitted with it are (default false; a
    /// campaign whose force directions are fitted apart sets it: there each fit holds one
    /// direct channel and the cross channels of that force, whose noise would otherwise
    /// set the floor).
    pub direct_at_noise: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            n_modes: None,
            band_hz: None,
            weighting: Weighting::Coherence,
            min_coherence: 0.5,
            max_modes: 40,
            sk_iterations: 12,
            refine: true,
            lm_iterations: 30,
            target_residual: 1e-3,
            min_improvement: 0.05,
            white_residual: 0.5,
            sharp_peaks: true,
            stabilization: StabilizationOptions::default(),
            direct_at_noise: false,
        }
    }
}

/// The amplitude weights `W` the fit applies to `frf` under `opts`, per channel per line
/// of the full grid (zero outside the band and below the coherence limit).
pub fn weights(frf: &Frf, opts: &FitOptions) -> Vec<Vec<f64>> {
    let custom = match &opts.weighting {
        Weighting::Custom(w) if w.len() == frf.channels.len() => Some(w.as_slice()),
        _ => None,
    };
    let band = opts.band_hz.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    data::full_weights(frf, opts, custom, band)
}

/// Outcome of [`fit_frf`].
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The identified model (modes sorted, stable, finite), in original units.
    pub model: ModalModel,
    /// Paper eq. 5 fit \[%\] per channel over the fitted lines (band, weight > 0).
    pub fit_pct: Vec<(Channel, f64)>,
    /// The stabilization diagram the order came from.
    pub diagram: StabilizationDiagram,
    /// True when the order was chosen automatically.
    pub automatic_order: bool,
    /// Human-readable log: orders tried, iterations, weighted errors.
    pub report: String,
}

/// Identifies a common-pole modal model of all channels of `frf` (see the module docs).
pub fn fit_frf(frf: &Frf, opts: &FitOptions) -> Result<FitResult> {
    let prep = Prepared::new(frf, opts)?;
    let diagram = stabilization::diagram(&prep.band, &prep.w, &opts.stabilization)?;
    let mut report = String::new();
    let energy = prep.energy();
    if energy <= 0.0 {
        return Err(Error::BadInput(
            "the FRF is zero on every fitted line: nothing to identify".into(),
        ));
    }
    let _ = writeln!(
        report,
        "{}, {}, band {:.4}..{:.4} Hz; diagram orders 2..{}: {}{}",
        crate::axis::count(prep.n_lines(), "line"),
        crate::axis::count(prep.channels.len(), "channel"),
        prep.band.freqs_hz[0],
        prep.band.freqs_hz[prep.n_lines() - 1],
        diagram.orders.last().map(|o| o.order).unwrap_or(0),
        crate::axis::count(diagram.n_physical(), "physical mode"),
        diagram
            .physical
            .iter()
            .map(|m| format!(" {:.2} Hz/{:.3}%", m.f_hz, 100.0 * m.zeta))
            .collect::<String>()
    );
    let physical: Vec<Complex64> = diagram
        .physical
        .iter()
        .map(|m| {
            let wn = 2.0 * PI * m.f_hz / prep.w_scale;
            Mode { wn, zeta: m.zeta }.pole()
        })
        .collect();

    let sol = match opts.n_modes {
        Some(n) => {
            if n == 0 || n > 200 {
                return Err(Error::BadInput(format!(
                    "n_modes = {n}: give between 1 and 200 modes, or None for automatic"
                )));
            }
            let poles = start_poles(&prep, &physical, n);
            fit_order(&prep, poles, opts, &mut report)?
        }
        None => auto_order(&prep, &physical, opts, &mut report)?,
    };
    let sol = if opts.refine {
        let before = sol.cost;
        match varpro::refine(&prep, &sol.modes, opts.lm_iterations) {
            Some(r) if r.cost <= before => {
                let _ = writeln!(
                    report,
                    "Levenberg-Marquardt: {} iterations, relative weighted error {:.3e} -> {:.3e}",
                    r.iterations,
                    (before / energy).sqrt(),
                    (r.cost / energy).sqrt()
                );
                r
            }
            _ => sol,
        }
    } else {
        sol
    };
    let model = finish(&prep, &sol)?;
    let fit_pct = fit_percentages(&prep, &model);
    let _ = writeln!(
        report,
        "final: {}, relative weighted error {:.3e}, fit {}",
        crate::axis::count(model.modes.len(), "mode"),
        (sol.cost / energy).sqrt(),
        fit_pct
            .iter()
            .map(|(c, f)| format!("{c} {f:.3}%"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(FitResult {
        model,
        fit_pct,
        diagram,
        automatic_order: opts.n_modes.is_none(),
        report,
    })
}

/// Fit [%] over all the band's lines below which a held channel of [`fit_frf_steered`]
/// has run away (its error more than twice its measured response) and is solved again.
const HELD_RUNAWAY_FIT_PCT: f64 = -100.0;

/// [`fit_frf`] with the poles taken from the channels in `steer` alone: the other
/// channels of `frf` get their numerators and residual with those poles held (the
/// linear part of the fit, same weights). A weak cross channel, coherent only in part of
/// the band, then cannot pull the common poles towards its noise. With no steering
/// channel among `frf`'s, all of them, or a custom weighting (given per channel of the
/// whole FRF), this is [`fit_frf`].
pub fn fit_frf_steered(frf: &Frf, opts: &FitOptions, steer: &[Channel]) -> Result<FitResult> {
    let n_steer = (frf.channels.iter())
        .filter(|c| steer.contains(&c.channel))
        .count();
    if n_steer == 0
        || n_steer == frf.channels.len()
        || matches!(opts.weighting, Weighting::Custom(_))
    {
        return fit_frf(frf, opts);
    }
    let mut sub = frf.clone();
    sub.channels.retain(|c| steer.contains(&c.channel));
    let mut r = fit_frf(&sub, opts)?;
    let prep = Prepared::new(frf, opts)?;
    let sol = varpro::solve_linear(&prep, &prep.scale_modes(&r.model.modes)).ok_or_else(|| {
        Error::Numerical(
            "the numerator least squares is singular: too few usable lines for the order".into(),
        )
    })?;
    r.model = finish(&prep, &sol)?;
    // A held channel's lines below `min_coherence` weigh nothing: where it has a gap of
    // low coherence under close poles (two modes 6 Hz apart, one 0.3 % damped), nothing
    // holds their numerators, and the channel may get a resonance thousands of times its
    // measured response there (second generator seed 17: zx at -7859 % of its measured
    // FRF, which then spoiled every held-out simulation of diagnose). Such a channel
    // (its error over all the band's lines larger than twice its response) is solved
    // again with every line weighted by its coherence weight, no cut, and the better of
    // the two kept.
    let all_lines_fit = |m: &ModalModel, ci: usize| {
        let ch = &prep.band.channels[ci];
        let est: Vec<Complex64> = (prep.band.freqs_hz.iter())
            .map(|f| m.eval_hz(ci, *f))
            .collect();
        fit_percent(&ch.h, &est)
    };
    let runaway: Vec<usize> = (0..frf.channels.len())
        .filter(|&ci| !steer.contains(&frf.channels[ci].channel))
        .filter(|&ci| all_lines_fit(&r.model, ci) < HELD_RUNAWAY_FIT_PCT)
        .collect();
    if !runaway.is_empty() {
        let uncut = FitOptions {
            min_coherence: 0.0,
            ..opts.clone()
        };
        let prep2 = Prepared::new(frf, &uncut)?;
        if let Some(m2) = varpro::solve_linear(&prep2, &prep2.scale_modes(&r.model.modes))
            .and_then(|s| finish(&prep2, &s).ok())
        {
            for ci in runaway {
                let (before, after) = (all_lines_fit(&r.model, ci), all_lines_fit(&m2, ci));
                if after > before {
                    let _ = writeln!(
                        r.report,
                        "{}: numerators solved again over every line of the band (its \
                         low-coherence lines counted): {before:.1} -> {after:.1} % over all lines",
                        frf.channels[ci].channel
                    );
                    r.model.channels[ci] = m2.channels[ci].clone();
                }
            }
        }
    }
    r.fit_pct = fit_percentages(&prep, &r.model);
    let held: Vec<String> = (frf.channels.iter())
        .filter(|c| !steer.contains(&c.channel))
        .map(|c| c.channel.to_string())
        .collect();
    let _ = writeln!(
        r.report,
        "poles from {} only; {} fitted with them held: {}",
        crate::axis::count(n_steer, "channel"),
        held.join(", "),
        r.fit_pct
            .iter()
            .map(|(c, f)| format!("{c} {f:.3}%"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(r)
}

/// Refits `frf` starting from `initial` (same number of modes): Levenberg–Marquardt on
/// the modes with the numerators of every channel of `frf` solved anew, minimising
/// `Σ |W (H − F)|²` with `weights[c][k]` the amplitude weight of channel `c` at line `k`
/// of `frf` (this overrides `opts.weighting`; `opts.band_hz` and `opts.min_coherence`
/// still apply). Used for the lifetime updates (paper section 2.3).
pub fn refine_from(
    initial: &ModalModel,
    frf: &Frf,
    weights: &[Vec<f64>],
    opts: &FitOptions,
) -> Result<ModalModel> {
    if initial.modes.is_empty() || !initial.is_valid() {
        return Err(Error::BadInput(
            "refine_from: the initial model needs at least one stable mode and finite numbers"
                .into(),
        ));
    }
    let prep = Prepared::with_weights(frf, opts, Some(weights))?;
    let start = prep.scale_modes(&initial.modes);
    let sol = varpro::refine(&prep, &start, opts.lm_iterations.max(1))
        .or_else(|| varpro::solve_linear(&prep, &start))
        .ok_or_else(|| {
            Error::Numerical(
                "refine_from: the numerator least squares is singular; give weight to more lines"
                    .into(),
            )
        })?;
    finish(&prep, &sol)
}

/// The numerators (and residual terms) of `frf` for the modes of `model` held fixed: the
/// linear least-squares part of [`refine_from`] alone, same weights. The modes keep the
/// order of `model` (a campaign's tracked models hold mode `k` as the same physical
/// mode at every pose, wherever it lies in frequency; sorted by frequency, a pole frozen
/// for every pose would swap slots with a mode that crosses it).
pub fn solve_numerators(
    model: &ModalModel,
    frf: &Frf,
    weights: &[Vec<f64>],
    opts: &FitOptions,
) -> Result<ModalModel> {
    let prep = Prepared::with_weights(frf, opts, Some(weights))?;
    let modes = prep.scale_modes(&model.modes);
    let sol = varpro::solve_linear(&prep, &modes).ok_or_else(|| {
        Error::Numerical(
            "the numerator least squares is singular: too few usable lines for the order".into(),
        )
    })?;
    let sorted = finish(&prep, &sol)?;
    // `finish` sorts by frequency (stably): put each mode back in its slot
    let mut idx: Vec<usize> = (0..modes.len()).collect();
    idx.sort_by(|&a, &b| modes[a].wn.total_cmp(&modes[b].wn));
    let mut out = sorted.clone();
    for (j, &i) in idx.iter().enumerate() {
        out.modes[i] = sorted.modes[j];
        for (c, s) in out.channels.iter_mut().zip(&sorted.channels) {
            c.num[i] = s.num[j];
        }
    }
    Ok(out)
}

/// Starting poles (scaled, one per pair): the physical ones first, then lightly damped
/// pairs spread linearly over the band gaps.
fn start_poles(prep: &Prepared, physical: &[Complex64], n: usize) -> Vec<Complex64> {
    let mut poles: Vec<Complex64> = physical.iter().take(n).copied().collect();
    let extra = n - poles.len();
    if extra > 0 {
        let lo = prep.s[0].im.max(1e-3);
        let hi = prep.s[prep.n_lines() - 1].im;
        for i in 0..extra {
            let w = lo + (hi - lo) * (i as f64 + 0.5) / extra as f64;
            poles.push(Complex64::new(-0.01 * w, w));
        }
    }
    poles
}

/// VF iterations at a fixed order, then the numerators in the modal basis.
fn fit_order(
    prep: &Prepared,
    mut poles: Vec<Complex64>,
    opts: &FitOptions,
    report: &mut String,
) -> Result<Solved> {
    let its = vf::relocate(prep, &mut poles, opts.sk_iterations.max(1));
    let modes = vf::poles_to_modes(&poles);
    let sol = varpro::solve_linear(prep, &modes).ok_or_else(|| {
        Error::Numerical(
            "the numerator least squares is singular: too few usable lines for the order".into(),
        )
    })?;
    let _ = writeln!(
        report,
        "order {} pairs: {} SK/VF iterations, relative weighted error {:.3e}, residual lag-1 correlation {:.2}",
        modes.len(),
        its,
        (sol.cost / prep.energy()).sqrt(),
        varpro::lag_one_correlation(prep, &sol)
    );
    Ok(sol)
}

/// Weighted noise energy implied by the coherence: Σ w² |F|² (1−γ²)/γ².
fn noise_floor(prep: &Prepared) -> Option<f64> {
    noise_per_line(prep).map(|v| v.iter().sum())
}

/// Weighted noise energy per line implied by the coherence (summed over channels), as in
/// [`noise_floor`]; `None` without coherence.
fn noise_per_line(prep: &Prepared) -> Option<Vec<f64>> {
    noise_lines_per_channel(prep).map(|per| {
        (0..prep.n_lines())
            .map(|k| per.iter().map(|c| c[k]).sum())
            .collect()
    })
}

/// Weighted noise energy per channel and line implied by the coherence (zero without
/// coherence); `None` when no channel has coherence.
fn noise_lines_per_channel(prep: &Prepared) -> Option<Vec<Vec<f64>>> {
    let mut any = false;
    let out = prep
        .band
        .channels
        .iter()
        .enumerate()
        .map(|(ci, ch)| {
            let mut acc = vec![0.0; prep.n_lines()];
            if let Some(g) = &ch.coherence {
                any = true;
                for (k, &g) in g.iter().enumerate() {
                    let w = prep.w[ci][k];
                    if w > 0.0 {
                        let g = g.clamp(1e-6, 1.0);
                        acc[k] = w * w * prep.h[ci][k].norm_sqr() * (1.0 - g) / g;
                    }
                }
            }
            acc
        })
        .collect();
    any.then_some(out)
}

/// Lines on each side of the windows in which [`local_excess`] compares the residual
/// with the noise.
const LOCAL_HALF_WIDTH: usize = 3;

/// The largest ratio, over windows of `2·LOCAL_HALF_WIDTH + 1` neighbouring lines, of the
/// weighted residual energy to the noise energy the coherence implies there. A global
/// residual at the noise floor can hide a sharp resonance the model misses: its few lines
/// weigh nothing against thousands of noisy ones, yet there the residual is many times the
/// (tiny) noise of a coherent peak.
fn local_excess(prep: &Prepared, sol: &Solved, noise: &[f64]) -> f64 {
    let res = varpro::residual_per_line(prep, sol);
    let n = res.len();
    // weighted data energy per line
    let sig: Vec<f64> = (0..n)
        .map(|k| {
            (0..prep.h.len())
                .map(|ci| (prep.h[ci][k] * prep.w[ci][k]).norm_sqr())
                .sum()
        })
        .collect();
    let (mut worst, mut r_sum, mut n_sum, mut s_sum) = (0.0f64, 0.0, 0.0, 0.0);
    // running sums over the window [k - h, k + h]
    let h = LOCAL_HALF_WIDTH;
    for k in 0..n.min(h) {
        r_sum += res[k];
        n_sum += noise[k];
        s_sum += sig[k];
    }
    for k in 0..n {
        if k + h < n {
            r_sum += res[k + h];
            n_sum += noise[k + h];
            s_sum += sig[k + h];
        }
        if k > h {
            r_sum -= res[k - h - 1];
            n_sum -= noise[k - h - 1];
            s_sum -= sig[k - h - 1];
        }
        // only a misfit that is also large against the data there counts: a model-form
        // error of a fraction of a percent is no missing mode, however clean the data
        // ... and only at a peak of the data inside the band (a missing resonance shows
        // as one; a band edge or a mode's flank is model form, not a missing mode)
        let peak = k >= h && k + h < n && (k - h..=k + h).all(|j| sig[j] <= sig[k]) && {
            // ... that stands out of its surroundings (a noise bump on a smooth
            // tail does not)
            let (a, b) = (
                k.saturating_sub(PEAK_SURROUNDINGS),
                (k + PEAK_SURROUNDINGS + 1).min(n),
            );
            let mean = sig[a..b].iter().sum::<f64>() / (b - a) as f64;
            sig[k] >= PEAK_PROMINENCE * mean
        };
        if peak && n_sum > 0.0 && r_sum > LOCAL_RELATIVE_MIN * LOCAL_RELATIVE_MIN * s_sum {
            worst = worst.max(r_sum / n_sum);
        }
    }
    worst
}

/// Lines on each side over which [`local_excess`] compares a data peak with its
/// surroundings.
const PEAK_SURROUNDINGS: usize = 8 * LOCAL_HALF_WIDTH;

/// A data peak counts for [`local_excess`] when its weighted energy is this many times the
/// mean over its surroundings.
const PEAK_PROMINENCE: f64 = 4.0;

/// [`local_excess`] ignores windows whose residual is below this fraction (RMS) of the
/// data there.
const LOCAL_RELATIVE_MIN: f64 = 0.03;

/// A window whose residual exceeds this multiple of its noise ([`local_excess`]) means a
/// mode is still missing there, however small the global residual (with 5 averages a
/// 7-line window's noise energy has about 70 degrees of freedom: 4× is far beyond chance).
const LOCAL_EXCESS_LIMIT: f64 = 4.0;

/// The automatic order rule of the module docs.
fn auto_order(
    prep: &Prepared,
    physical: &[Complex64],
    opts: &FitOptions,
    report: &mut String,
) -> Result<Solved> {
    let energy = prep.energy();
    let noise = noise_floor(prep);
    let noise_lines = noise_per_line(prep);
    let local_ok = |s: &Solved| {
        noise_lines
            .as_ref()
            .is_none_or(|nl| !opts.sharp_peaks || local_excess(prep, s, nl) <= LOCAL_EXCESS_LIMIT)
    };
    let max_modes = opts.max_modes.max(1);
    let n0 = physical.len().clamp(1, max_modes);
    let rel = |s: &Solved| (s.cost / energy).sqrt();
    // A white residual only counts as "noise, nothing missing" when it is also near the
    // noise floor the coherence implies (when coherence is known): many close modes
    // leave a residual that looks white along frequency but is far above the noise.
    let white = |s: &Solved| {
        varpro::lag_one_correlation(prep, s) < opts.white_residual
            && noise.is_none_or(|nf| s.cost <= 2.0 * nf)
    };
    // the direct channels (response along the force) at their own noise: a noisier cross
    // channel in the same fit must not lend them its noise floor
    let direct_noise: Option<Vec<(usize, f64)>> = noise_lines_per_channel(prep).map(|nl| {
        nl.iter()
            .enumerate()
            .filter(|(ci, _)| prep.channels[*ci].output == prep.channels[*ci].input)
            .map(|(ci, v)| (ci, v.iter().sum::<f64>()))
            .collect()
    });
    let direct_ok = |s: &Solved| {
        if !opts.direct_at_noise {
            return true;
        }
        direct_noise.as_ref().is_none_or(|dn| {
            let r = varpro::residuals(prep, s);
            dn.iter().all(|&(ci, n)| {
                let c: f64 = r[ci].iter().map(|v| v.norm_sqr()).sum();
                c <= 2.0 * n
            })
        })
    };
    let done = |s: &Solved| {
        rel(s) <= opts.target_residual
            || ((noise.is_some_and(|nf| s.cost <= nf) || white(s)) && local_ok(s) && direct_ok(s))
    };
    let mut best = fit_order(prep, start_poles(prep, physical, n0), opts, report)?;
    // Prune diagram modes that only fit noise: drop the weakest while the residual
    // stays white and hardly grows.
    while best.modes.len() > 1 && white(&best) && rel(&best) > opts.target_residual {
        let contrib = varpro::mode_contributions(prep, &best);
        let weakest = (0..contrib.len())
            .min_by(|&a, &b| contrib[a].total_cmp(&contrib[b]))
            .unwrap_or(0);
        let mut modes = best.modes.clone();
        modes.remove(weakest);
        let cand = fit_order(prep, vf::modes_to_poles(&modes), opts, report)?;
        // A mode that only fits noise barely changes the residual when removed; a
        // physical mode's removal raises it even if the residual still looks white
        // (a missing sharp peak spans few lines).
        if white(&cand) && rel(&cand) <= rel(&best) * (1.0 + 3.0 * opts.min_improvement) {
            best = cand;
        } else {
            break;
        }
    }
    let mut current = best.clone();
    while !done(&best) && current.modes.len() < max_modes {
        let next = add_pair(prep, &current, opts, report)?;
        let gain = 1.0 - rel(&next) / rel(&best);
        // a missing sharp resonance (local_ok false) pays off locally, not globally
        let required = if local_ok(&best) {
            opts.min_improvement
        } else {
            0.2 * opts.min_improvement
        };
        if gain >= required {
            best = next.clone();
            current = next;
            continue;
        }
        // one pair of look-ahead
        if next.modes.len() >= max_modes {
            break;
        }
        let next2 = add_pair(prep, &next, opts, report)?;
        let gain2 = 1.0 - rel(&next2) / rel(&best);
        if gain2 >= 2.0 * required {
            best = next2.clone();
            current = next2;
        } else {
            break;
        }
    }
    if let Some(nf) = noise {
        let _ = writeln!(
            report,
            "automatic order: {} (noise floor from coherence {:.3e}, residual {:.3e})",
            crate::axis::count(best.modes.len(), "mode"),
            (nf / energy).sqrt(),
            rel(&best)
        );
    } else {
        let _ = writeln!(
            report,
            "automatic order: {}",
            crate::axis::count(best.modes.len(), "mode")
        );
    }
    Ok(best)
}

/// The fit with one more pole pair, placed at the line of largest weighted residual:
/// vector fitting relocates all poles from there; when that ends worse than keeping the
/// current modes and adding the new pair alone (lightly damped, at a few damping ratios,
/// numerators re-solved), the latter is taken, so an added pair never raises the error.
fn add_pair(
    prep: &Prepared,
    current: &Solved,
    opts: &FitOptions,
    report: &mut String,
) -> Result<Solved> {
    let res = varpro::residual_per_line(prep, current);
    // smooth over ±2 lines so a single noisy line does not attract the pole
    let n = res.len();
    let k = (0..n)
        .max_by(|&a, &b| {
            let sa: f64 = res[a.saturating_sub(2)..(a + 3).min(n)].iter().sum();
            let sb: f64 = res[b.saturating_sub(2)..(b + 3).min(n)].iter().sum();
            sa.total_cmp(&sb)
        })
        .unwrap_or(0);
    let w = prep.s[k].im.max(1e-3);
    let mut poles = vf::modes_to_poles(&current.modes);
    poles.push(Complex64::new(-0.01 * w, w));
    let relocated = fit_order(prep, poles, opts, report)?;
    let mut best = relocated;
    for zeta in [1e-2, 1e-3, 1e-4] {
        let mut modes = current.modes.clone();
        modes.push(Mode { wn: w, zeta });
        if let Some(sol) = varpro::solve_linear(prep, &modes) {
            if sol.cost < best.cost {
                best = sol;
            }
        }
    }
    if best.modes.len() == current.modes.len() + 1 && best.cost < current.cost {
        let _ = writeln!(
            report,
            "order {} pairs: best of relocation and the added pair alone, relative weighted error {:.3e}",
            best.modes.len(),
            (best.cost / prep.energy()).sqrt()
        );
    }
    Ok(best)
}

/// Converts to original units, checks finiteness and stability.
fn finish(prep: &Prepared, sol: &Solved) -> Result<ModalModel> {
    let model = prep.to_model(&sol.modes, &sol.coefs);
    if !model.is_valid() {
        return Err(Error::Numerical(
            "the fitted model is not finite or not stable; narrow the band or fix the order".into(),
        ));
    }
    Ok(model)
}

/// Paper eq. 5 per channel over the lines with positive weight.
fn fit_percentages(prep: &Prepared, model: &ModalModel) -> Vec<(Channel, f64)> {
    prep.band
        .channels
        .iter()
        .enumerate()
        .map(|(ci, ch)| {
            let idx = &prep.fitted[ci];
            let truth: Vec<Complex64> = idx.iter().map(|&k| ch.h[k]).collect();
            let est: Vec<Complex64> = idx
                .iter()
                .map(|&k| model.eval_hz(ci, prep.band.freqs_hz[k]))
                .collect();
            (ch.channel, fit_percent(&truth, &est))
        })
        .collect()
}
