//! Update of selected modes of a model from FRF points (Levenberg–Marquardt with a prior).
//!
//! The lifetime refit's own method: only the modes whose resonance region the operating
//! data excites are free (natural frequency, damping, numerators of every channel); the
//! others are held. The data term is the complex misfit at the measured lines, each
//! weighted by the inverse of its standard error (from coherence); a weak prior pulls
//! the free parameters towards the previous model so that a mode seen on one flank
//! only cannot run away.
//!
//! The prior only means something when the standard errors do: a twin identified from
//! other data never fits new data to within the Welch noise, and with noise-only errors
//! that model discrepancy outweighs any prior, so free modes bend to absorb it (a mode
//! the data barely see runs to a far frequency and acts as a broadband correction).
//! [`discrepancy`] estimates, per channel, the relative model error robustly (the median
//! normalised misfit, so the few lines a real change affects do not set it) and
//! [`with_discrepancy`] adds it to the errors. [`update_modes_with`] also keeps each
//! mode's identity: its frequency stays between its neighbours ([`ModeBounds`]), its
//! damping within physical bounds, and with [`UpdateOptions::shape_prior`] its numerators
//! keep the mode's direction (a y-bending mode cannot take on an x residue), each within
//! a relative width that can be the twin's own measured discrepancy in that channel.

use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::model::ModalModel;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// FRF points of one channel with their standard errors.
#[derive(Debug, Clone)]
pub struct Points {
    /// The channel.
    pub channel: Channel,
    /// Frequencies \[Hz\].
    pub freqs_hz: Vec<f64>,
    /// Measured receptance.
    pub h: Vec<Complex64>,
    /// Standard error of each point (same unit as `h`), > 0.
    pub sigma: Vec<f64>,
}

/// Squared misfits `|F(f) e^{−iωτ} − H| ² / σ²` of every point, per channel (the model's
/// response delayed by `delay_s`; channels the model lacks count as model = 0).
fn normalized_residuals(model: &ModalModel, pts: &[Points], delay_s: f64) -> Vec<Vec<f64>> {
    pts.iter()
        .map(|p| {
            let ci = model.channel_index(p.channel);
            p.freqs_hz
                .iter()
                .zip(&p.h)
                .zip(&p.sigma)
                .map(|((f, h), sg)| {
                    let m = ci.map_or(Complex64::new(0.0, 0.0), |ci| {
                        model.eval_hz(ci, *f) * Complex64::from_polar(1.0, -2.0 * PI * f * delay_s)
                    });
                    ((m - h) / sg).norm_sqr()
                })
                .collect()
        })
        .collect()
}

/// RMS misfit in standard errors per real component (1 = within noise).
pub fn chi(model: &ModalModel, pts: &[Points], delay_s: f64) -> f64 {
    let r2 = normalized_residuals(model, pts, delay_s);
    let n: usize = r2.iter().map(Vec::len).sum();
    if n == 0 {
        return 0.0;
    }
    (r2.iter().flatten().sum::<f64>() / (2 * n) as f64).sqrt()
}

/// Largest local RMS misfit in standard errors: over every window of ±2.5 % around a
/// point, widened to at least two points on each side (coarse lines at a low mode: a
/// hit record of 0.4 s has lines 2.5 Hz apart, wider than ±2.5 % below 250 Hz), per
/// channel. A missing or shifted resonance is local; the global RMS of [`chi`] dilutes
/// it over the whole band.
pub fn chi_local(model: &ModalModel, pts: &[Points], delay_s: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for (p, r2) in pts.iter().zip(normalized_residuals(model, pts, delay_s)) {
        let f = &p.freqs_hz;
        let n = f.len();
        if n < 5 {
            continue;
        }
        let mut cum = vec![0.0; n + 1];
        for i in 0..n {
            cum[i + 1] = cum[i] + r2[i] / 2.0;
        }
        for i in 0..n {
            let lo = f
                .partition_point(|x| *x < f[i] * 0.975)
                .min(i.saturating_sub(2));
            let hi = f
                .partition_point(|x| *x <= f[i] * 1.025)
                .max((i + 3).min(n));
            let m = hi - lo;
            if m >= 5 {
                worst = worst.max(((cum[hi] - cum[lo]).max(0.0) / m as f64).sqrt());
            }
        }
    }
    worst
}

/// Prior widths (one standard deviation) of the free parameters.
#[derive(Debug, Clone, Copy)]
pub struct Prior {
    /// Of ln ω (0.2 = 20 % frequency change).
    pub ln_wn: f64,
    /// Of ln ζ.
    pub ln_zeta: f64,
    /// Of a numerator, relative to the mode's numerator scale.
    pub num_rel: f64,
}

impl Default for Prior {
    fn default() -> Self {
        Prior {
            ln_wn: 0.2,
            ln_zeta: 1.0,
            num_rel: 0.5,
        }
    }
}

/// Physical range of a damping ratio a refit may give a structural mode.
pub const ZETA_RANGE: (f64, f64) = (1e-4, 0.2);

/// Shape likeness below which two modes cannot be mistaken for one another
/// ([`shape_likeness`]).
pub const LIKE_SHAPE: f64 = 0.5;

/// How alike the shapes of modes `j` and `k` of `model` look in its channels, 0 to 1: the
/// modal assurance criterion of their numerators' magnitudes at their own frequencies
/// over all channels (an x mode and a y mode: 0; a mode turned 45° against an x mode:
/// 0.25 in xx, xy, yx, yy; one channel only: 1).
pub fn shape_likeness(model: &ModalModel, j: usize, k: usize) -> f64 {
    let size = |m: usize| -> Vec<f64> {
        let w = model.modes[m].wn;
        model
            .channels
            .iter()
            .map(|c| Complex64::new(c.num[m].b0, c.num[m].b1 * w).norm())
            .collect()
    };
    let (a, b) = (size(j), size(k));
    let ab: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    let (aa, bb): (f64, f64) = (a.iter().map(|x| x * x).sum(), b.iter().map(|y| y * y).sum());
    if aa <= 0.0 || bb <= 0.0 {
        return 1.0;
    }
    ab * ab / (aa * bb)
}

/// Bounds of one free mode's parameters (natural logarithms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeBounds {
    /// Of ln ω.
    pub ln_wn: (f64, f64),
    /// Of ln ζ.
    pub ln_zeta: (f64, f64),
}

impl ModeBounds {
    /// Identity bounds of mode `k` of `model`: the natural frequency stays between the
    /// geometric midpoints to its neighbours in frequency of a like shape (it can neither
    /// pass such a neighbour nor take its place; modes with real poles, ζ ≥ 1, are no
    /// resonances and do not count; a neighbour whose shape differs, [`shape_likeness`]
    /// below [`LIKE_SHAPE`], cannot be confused with it and may be passed: a worn x mode
    /// moving past a y mode) and within 3 prior widths of where it was; the damping ratio
    /// within [`ZETA_RANGE`] and 3 prior widths. The starting point always lies inside.
    pub fn identity(model: &ModalModel, k: usize, prior: &Prior) -> ModeBounds {
        Self::identity_reaching(model, k, prior, 0.5)
    }

    /// [`ModeBounds::identity`] with the limit towards a like-shaped neighbour at `reach`
    /// of the way to it in ln ω (`identity`: 0.5, the geometric midpoint), for evidence
    /// that pins a mode more tightly than the Welch spectra do.
    pub fn identity_reaching(
        model: &ModalModel,
        k: usize,
        prior: &Prior,
        reach: f64,
    ) -> ModeBounds {
        let m = model.modes[k];
        let lw = m.wn.ln();
        let (mut lo, mut hi) = (lw - 3.0 * prior.ln_wn, lw + 3.0 * prior.ln_wn);
        for (j, o) in model.modes.iter().enumerate() {
            if j == k || o.zeta >= 1.0 || !(o.wn > 0.0) || shape_likeness(model, j, k) < LIKE_SHAPE
            {
                continue;
            }
            let mid = lw + reach * (o.wn.ln() - lw);
            if o.wn < m.wn {
                lo = lo.max(mid);
            } else if o.wn > m.wn {
                hi = hi.min(mid);
            }
        }
        let lz = m.zeta.max(1e-6).ln();
        let zlo = (lz - 3.0 * prior.ln_zeta).max(ZETA_RANGE.0.ln()).min(lz);
        let zhi = (lz + 3.0 * prior.ln_zeta).min(ZETA_RANGE.1.ln()).max(lz);
        ModeBounds {
            ln_wn: (lo.min(lw), hi.max(lw)),
            ln_zeta: (zlo, zhi),
        }
    }

    /// True when `ln_wn` lies on (within 1e-6 of) the frequency bounds.
    pub fn wn_at_bound(&self, ln_wn: f64) -> bool {
        ln_wn <= self.ln_wn.0 + 1e-6 || ln_wn >= self.ln_wn.1 - 1e-6
    }
}

/// Options of [`update_modes_with`].
#[derive(Debug, Clone)]
pub struct UpdateOptions {
    /// Prior widths.
    pub prior: Prior,
    /// Bounds of every free mode (same order as `free`); `None` = unbounded.
    pub bounds: Option<Vec<ModeBounds>>,
    /// Numerator prior per channel, relative to the numerator itself: `Some(w)` gives a
    /// numerator in channel `c` (model channel order) the width `w[c]` times its own size
    /// (at least 1e-6 of the mode's largest numerator). The mode keeps its direction:
    /// wear changes a mode's frequency and damping, it does not turn a y-mode into an
    /// x-mode, so a residue the mode hardly has cannot grow (the data's weak cross
    /// channels, estimated from correlated cutting forces, would otherwise rotate it).
    /// `None`: every numerator's width is `num_rel` times the mode's largest numerator.
    pub shape_prior: Option<Vec<f64>>,
    /// Levenberg–Marquardt iterations at most.
    pub max_iter: usize,
    /// Also compute [`UpdateResult::posterior_sd`] (one more Jacobian).
    pub posterior: bool,
    /// Where the iterations start (same modes and channels as the model updated; its
    /// free modes' values are taken, clamped to the bounds): e.g. the fit of a subset of
    /// the free modes. The prior stays centred on the model updated and
    /// [`UpdateResult::chi_before`] is its misfit. `None`: the model updated.
    pub start: Option<ModalModel>,
}

impl Default for UpdateOptions {
    fn default() -> Self {
        UpdateOptions {
            prior: Prior::default(),
            bounds: None,
            shape_prior: None,
            max_iter: 60,
            posterior: false,
            start: None,
        }
    }
}

impl UpdateOptions {
    /// Identity-keeping options: [`ModeBounds::identity`] for every mode of `free` and the
    /// shape prior, `prior.num_rel` relative in every channel; posterior widths computed.
    pub fn keeping_identity(model: &ModalModel, free: &[usize], prior: Prior) -> Self {
        UpdateOptions {
            prior,
            bounds: Some(
                free.iter()
                    .map(|&k| ModeBounds::identity(model, k, &prior))
                    .collect(),
            ),
            shape_prior: Some(vec![prior.num_rel; model.channels.len()]),
            max_iter: 60,
            posterior: true,
            start: None,
        }
    }
}

/// Size `|b0| + |b1| ω` of mode `k`'s numerator in channel `c`.
pub(crate) fn num_size(model: &ModalModel, c: usize, k: usize) -> f64 {
    let n = model.channels[c].num[k];
    n.b0.abs() + n.b1.abs() * model.modes[k].wn
}

/// Width scale of mode `k`'s numerator in channel `c` under the shape prior (see
/// [`UpdateOptions::shape_prior`]), before the channel's relative width: the numerator's
/// own size, at least 1e-6 of the mode's largest numerator `mode_scale`.
pub(crate) fn shape_scale(model: &ModalModel, c: usize, k: usize, mode_scale: f64) -> f64 {
    num_size(model, c, k).max(1e-6 * mode_scale)
}

/// The size a model error of channel `ci` at `f_hz` scales with: the geometric mean of
/// the direct channels along its output and input, `sqrt(|F_oo| |F_ii|)` (an error in a
/// mode's direction moves a cross channel by that much, however small the cross channel
/// itself is), at least `|F_oi|`. Without a direct channel along an axis, the largest
/// channel at that end stands in.
fn discrepancy_scale(model: &ModalModel, ci: usize, f_hz: f64) -> f64 {
    let ch = model.channels[ci].channel;
    let own = model.eval_hz(ci, f_hz).norm();
    let along = |a: Axis, out: bool| -> f64 {
        match model.channel_index(Channel::new(a, a)) {
            Some(d) => model.eval_hz(d, f_hz).norm(),
            None => (0..model.channels.len())
                .filter(|&j| {
                    let cj = model.channels[j].channel;
                    if out {
                        cj.output == a
                    } else {
                        cj.input == a
                    }
                })
                .map(|j| model.eval_hz(j, f_hz).norm())
                .fold(0.0, f64::max),
        }
    };
    own.max((along(ch.output, true) * along(ch.input, false)).sqrt())
}

/// Per channel of `pts`, the relative model discrepancy ε: the smallest ε ≥ 0 for which
/// the median of `|F − H|² / (σ² + ε² S²)` over the channel's points is the median of
/// χ²₂ (2 ln 2), F the model and S its size for errors there (`sqrt(|F_oo| |F_ii|)`, at
/// least `|F|`: see [`with_discrepancy`]). A median is robust: lines a real change of
/// the machine affects (fewer than half) do not set it. Capped at 100.
pub fn discrepancy(model: &ModalModel, pts: &[Points]) -> Vec<f64> {
    let target = 2.0 * std::f64::consts::LN_2;
    pts.iter()
        .map(|p| {
            let Some(ci) = model.channel_index(p.channel) else {
                return 0.0;
            };
            let rm: Vec<(f64, f64)> = p
                .freqs_hz
                .iter()
                .zip(&p.h)
                .map(|(f, h)| {
                    let m = model.eval_hz(ci, *f);
                    ((m - h).norm_sqr(), discrepancy_scale(model, ci, *f).powi(2))
                })
                .collect();
            if rm.is_empty() {
                return 0.0;
            }
            let med = |eps: f64| -> f64 {
                let mut v: Vec<f64> = rm
                    .iter()
                    .zip(&p.sigma)
                    .map(|((r2, m2), s)| r2 / (s * s + eps * eps * m2).max(1e-300))
                    .collect();
                let mid = v.len() / 2;
                *v.select_nth_unstable_by(mid, f64::total_cmp).1
            };
            if med(0.0) <= target {
                return 0.0;
            }
            let (mut lo, mut hi) = (0.0f64, 100.0f64);
            if med(hi) > target {
                return hi;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if med(mid) > target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi
        })
        .collect()
}

/// `pts` with the model discrepancy `eps` (per channel, see [`discrepancy`]) added to
/// every standard error: `σ² + ε² S²`, S the size of `model`'s channel for errors there:
/// the geometric mean of the direct channels along its output and input (a mode's
/// direction is known no better than its direct residues), at least its own `|F|`.
pub fn with_discrepancy(model: &ModalModel, pts: &[Points], eps: &[f64]) -> Vec<Points> {
    pts.iter()
        .zip(eps)
        .map(|(p, e)| {
            let mut q = p.clone();
            if let Some(ci) = model.channel_index(p.channel) {
                for (s, f) in q.sigma.iter_mut().zip(&p.freqs_hz) {
                    let m = discrepancy_scale(model, ci, *f);
                    *s = (*s * *s + e * e * m * m).sqrt();
                }
            }
            q
        })
        .collect()
}

/// Result of [`update_modes`].
#[derive(Debug, Clone)]
pub struct UpdateResult {
    /// The updated model.
    pub model: ModalModel,
    /// Weighted RMS misfit (in standard errors) before and after.
    pub chi_before: f64,
    /// See `chi_before`.
    pub chi_after: f64,
    /// LM iterations used.
    pub iterations: usize,
    /// Free modes whose frequency ended on a bound (always empty without bounds).
    pub at_bound: Vec<usize>,
    /// Posterior standard deviation of every free mode's `[ln ω, ln ζ]` (same order as
    /// `free`; from the Gauss–Newton curvature, prior included, scaled by the misfit per
    /// degree of freedom when above 1); empty unless [`UpdateOptions::posterior`].
    pub posterior_sd: Vec<[f64; 2]>,
}

struct Layout {
    free: Vec<usize>,
    n_ch: usize,
}

impl Layout {
    fn n(&self) -> usize {
        self.free.len() * (2 + 2 * self.n_ch)
    }
}

fn unpack(base: &ModalModel, lay: &Layout, theta: &[f64], scale: &[f64]) -> ModalModel {
    let mut m = base.clone();
    let per = 2 + 2 * lay.n_ch;
    for (j, &k) in lay.free.iter().enumerate() {
        let o = j * per;
        m.modes[k].wn = theta[o].exp();
        m.modes[k].zeta = theta[o + 1].exp();
        for c in 0..lay.n_ch {
            m.channels[c].num[k].b0 = theta[o + 2 + 2 * c] * scale[j];
            m.channels[c].num[k].b1 = theta[o + 3 + 2 * c] * scale[j] / base.modes[k].wn;
        }
    }
    m
}

/// Updates the modes `free` of `model` to fit `points` (Levenberg–Marquardt), no
/// bounds, one numerator width per mode.
pub fn update_modes(
    model: &ModalModel,
    free: &[usize],
    points: &[Points],
    prior: Prior,
    max_iter: usize,
) -> Result<UpdateResult> {
    update_modes_with(
        model,
        free,
        points,
        &UpdateOptions {
            prior,
            max_iter,
            ..UpdateOptions::default()
        },
    )
}

/// Relative cost reduction a Levenberg–Marquardt step of [`update_modes_with`] must
/// promise (linearised, least damped) to be tried, as in the output-error stage: a
/// misfit of N points resolves a relative change of about 1/N (a thousand points: 1e-3),
/// so 1e-7 stops a converged update at once instead of after twelve ever more damped
/// tries, and moves no parameter by a noticeable fraction of its standard deviation.
const MIN_PREDICTED_GAIN: f64 = 1e-7;

/// Updates the modes `free` of `model` to fit `points` (Levenberg–Marquardt, projected
/// on the bounds of `opts`).
pub fn update_modes_with(
    model: &ModalModel,
    free: &[usize],
    points: &[Points],
    opts: &UpdateOptions,
) -> Result<UpdateResult> {
    let (prior, max_iter) = (opts.prior, opts.max_iter);
    if let Some(b) = &opts.bounds {
        if b.len() != free.len() {
            return Err(Error::BadInput(
                "modal update: one bound per free mode expected".into(),
            ));
        }
    }
    let lay = Layout {
        free: free.to_vec(),
        n_ch: model.channels.len(),
    };
    if lay.free.is_empty() {
        return Ok(UpdateResult {
            model: model.clone(),
            chi_before: 0.0,
            chi_after: 0.0,
            iterations: 0,
            at_bound: Vec::new(),
            posterior_sd: Vec::new(),
        });
    }
    // numerator scale per free mode: the largest |b0| + |b1| ω over the channels
    let scale: Vec<f64> = lay
        .free
        .iter()
        .map(|&k| {
            let w = model.modes[k].wn;
            model
                .channels
                .iter()
                .map(|c| c.num[k].b0.abs() + c.num[k].b1.abs() * w)
                .fold(0.0, f64::max)
                .max(1e-300)
        })
        .collect();
    let per = 2 + 2 * lay.n_ch;
    // θ of a model with the layout of `model` (its free modes' values): the inverse of
    // `unpack` (numerators scaled by `scale` and, for b1, by `model`'s ω)
    let pack = |src: &ModalModel| -> Vec<f64> {
        let mut t = vec![0.0; lay.n()];
        for (j, &k) in lay.free.iter().enumerate() {
            let o = j * per;
            t[o] = src.modes[k].wn.ln();
            t[o + 1] = src.modes[k].zeta.max(1e-6).ln();
            for c in 0..lay.n_ch {
                t[o + 2 + 2 * c] = src.channels[c].num[k].b0 / scale[j];
                t[o + 3 + 2 * c] = src.channels[c].num[k].b1 * model.modes[k].wn / scale[j];
            }
        }
        t
    };
    let theta0 = pack(model);
    let prior_sd: Vec<f64> = (0..lay.n())
        .map(|i| match i % per {
            0 => prior.ln_wn,
            1 => prior.ln_zeta,
            r if opts.shape_prior.is_some() => {
                let j = i / per;
                let c = (r - 2) / 2;
                let w = opts
                    .shape_prior
                    .as_ref()
                    .and_then(|w| w.get(c).copied())
                    .unwrap_or(prior.num_rel);
                w * shape_scale(model, c, lay.free[j], scale[j]) / scale[j]
            }
            _ => prior.num_rel,
        })
        .collect();
    let clamp = |t: &mut [f64]| {
        if let Some(b) = &opts.bounds {
            for (j, bj) in b.iter().enumerate() {
                let o = j * per;
                t[o] = t[o].clamp(bj.ln_wn.0, bj.ln_wn.1);
                t[o + 1] = t[o + 1].clamp(bj.ln_zeta.0, bj.ln_zeta.1);
            }
        }
    };
    let chan_idx: Vec<Option<usize>> = points
        .iter()
        .map(|p| model.channel_index(p.channel))
        .collect();
    let n_data: usize = points.iter().map(|p| 2 * p.h.len()).sum();
    if n_data == 0 {
        return Err(Error::BadInput(
            "no FRF points to update the model from (the operating data excites nothing in band)"
                .into(),
        ));
    }
    let n_res = n_data + lay.n();
    // the points' lines, shared between channels measured at the same lines: every
    // 1/den below is computed once per line, not once per channel
    let mut tables: Vec<&[f64]> = Vec::new();
    let table_of: Vec<usize> = points
        .iter()
        .map(|p| {
            let f = p.freqs_hz.as_slice();
            tables.iter().position(|t| *t == f).unwrap_or_else(|| {
                tables.push(f);
                tables.len() - 1
            })
        })
        .collect();
    let s_of = |f: f64| Complex64::new(0.0, 2.0 * PI * f);
    // 1/den of the modes `ks` of `m` at every line of every table (line-major)
    let inv_dens = |m: &ModalModel, ks: &[usize]| -> Vec<Vec<Complex64>> {
        tables
            .iter()
            .map(|t| {
                t.iter()
                    .flat_map(|&f| ks.iter().map(move |&k| 1.0 / m.modes[k].den(s_of(f))))
                    .collect()
            })
            .collect()
    };
    let held_modes: Vec<usize> = (0..model.modes.len())
        .filter(|k| !lay.free.contains(k))
        .collect();
    // the held modes' and the feedthrough's part of every point's model value: fixed
    // during the update, so each evaluation adds only the free modes' terms
    let held: Vec<Vec<Complex64>> = {
        let inv = inv_dens(model, &held_modes);
        let nh = held_modes.len();
        points
            .iter()
            .zip(&chan_idx)
            .zip(&table_of)
            .map(|((p, ci), &t)| {
                let Some(ci) = *ci else {
                    return vec![Complex64::default(); p.freqs_hz.len()];
                };
                let ch = &model.channels[ci];
                p.freqs_hz
                    .iter()
                    .enumerate()
                    .map(|(l, &f)| {
                        let s = s_of(f);
                        let mut h = Complex64::new(ch.d, 0.0);
                        for (x, &k) in held_modes.iter().enumerate() {
                            let n = ch.num[k];
                            h += (s * n.b1 + n.b0) * inv[t][l * nh + x];
                        }
                        h
                    })
                    .collect()
            })
            .collect()
    };
    let nf = lay.free.len();
    let residuals = |theta: &[f64]| -> (DVector<f64>, ModalModel) {
        let m = unpack(model, &lay, theta, &scale);
        let inv = inv_dens(&m, &lay.free);
        let mut r = DVector::zeros(n_res);
        let mut i = 0;
        for (((p, ci), held), &t) in points.iter().zip(&chan_idx).zip(&held).zip(&table_of) {
            for (l, (((f, h), s), hv)) in p
                .freqs_hz
                .iter()
                .zip(&p.h)
                .zip(&p.sigma)
                .zip(held)
                .enumerate()
            {
                let e = match ci {
                    Some(ci) => {
                        let sv = s_of(*f);
                        let ch = &m.channels[*ci];
                        let mut v = *hv;
                        for (j, &k) in lay.free.iter().enumerate() {
                            let n = ch.num[k];
                            v += (sv * n.b1 + n.b0) * inv[t][l * nf + j];
                        }
                        (v - h) / *s
                    }
                    None => Complex64::new(0.0, 0.0),
                };
                r[i] = e.re;
                r[i + 1] = e.im;
                i += 2;
            }
        }
        for (j, (t, t0)) in theta.iter().zip(&theta0).enumerate() {
            r[n_data + j] = (t - t0) / prior_sd[j];
        }
        (r, m)
    };
    // the Jacobian's nonzero columns of each data row (the free modes' ln ω, ln ζ and
    // the row's channel's numerators)
    let chan_cols: Vec<Vec<usize>> = (0..lay.n_ch)
        .map(|ci| {
            (0..lay.free.len())
                .flat_map(|j| {
                    let o = j * per;
                    [o, o + 1, o + 2 + 2 * ci, o + 3 + 2 * ci]
                })
                .collect()
        })
        .collect();
    // (JᵀJ, Jᵀr) at the model `m` with residual `r`, row by row without the Jacobian
    // itself: a data row has four nonzeros per free mode (in `chan_cols` order), a prior
    // row one
    let normal = |m: &ModalModel, r: &DVector<f64>| -> (DMatrix<f64>, DVector<f64>) {
        let n = lay.n();
        let (mut jtj, mut g) = (DMatrix::zeros(n, n), DVector::zeros(n));
        let mut row = |i: usize, cs: &[usize], vals: &[f64]| {
            for (x, &a) in cs.iter().enumerate() {
                let va = vals[x];
                g[a] += va * r[i];
                for (y, &b) in cs.iter().enumerate().skip(x) {
                    jtj[(a, b)] += va * vals[y];
                }
            }
        };
        let mut i = 0;
        let mut re = vec![0.0; 4 * lay.free.len()];
        let mut im = re.clone();
        let inv = inv_dens(m, &lay.free);
        for ((p, ci), &t) in points.iter().zip(&chan_idx).zip(&table_of) {
            let Some(ci) = *ci else {
                i += 2 * p.h.len();
                continue;
            };
            let cs = &chan_cols[ci];
            for (l, (f, s)) in p.freqs_hz.iter().zip(&p.sigma).enumerate() {
                let sv = s_of(*f);
                for (j, &k) in lay.free.iter().enumerate() {
                    let mode = m.modes[k];
                    let iv = inv[t][l * nf + j];
                    let num = m.channels[ci].num[k];
                    let nv = sv * num.b1 + num.b0;
                    // d/d ln ω and d/d ln ζ of (b1 s + b0)/(s² + 2ζω s + ω²)
                    let [dden_dlnw, dden_dlnz] = mode.den_log_derivatives(sv);
                    let niv2 = -nv * iv * iv;
                    let vs = [
                        niv2 * dden_dlnw,
                        niv2 * dden_dlnz,
                        iv * scale[j],
                        sv * (scale[j] / model.modes[k].wn) * iv,
                    ];
                    for (q, v) in vs.iter().enumerate() {
                        re[4 * j + q] = v.re / s;
                        im[4 * j + q] = v.im / s;
                    }
                }
                row(i, cs, &re);
                row(i + 1, cs, &im);
                i += 2;
            }
        }
        for j in 0..n {
            row(n_data + j, &[j], &[1.0 / prior_sd[j]]);
        }
        for a in 0..n {
            for b in 0..a {
                jtj[(a, b)] = jtj[(b, a)];
            }
        }
        (jtj, g)
    };
    let mut theta = theta0.clone();
    let (mut r, mut m) = residuals(&theta);
    let chi_before = (r.rows(0, n_data).norm_squared() / n_data as f64).sqrt();
    if let Some(st) = opts.start.as_ref().filter(|st| {
        st.modes.len() == model.modes.len() && st.channels.len() == model.channels.len()
    }) {
        theta = pack(st);
        clamp(&mut theta);
        let (rs, ms) = residuals(&theta);
        // a start worse than the model updated (or invalid) is not taken
        if rs.norm_squared() < r.norm_squared() && ms.is_valid() {
            (r, m) = (rs, ms);
        } else {
            theta.clone_from(&theta0);
        }
    }
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut it = 0;
    while it < max_iter {
        it += 1;
        let (jtj, g) = normal(&m, &r);
        let mut improved = false;
        let mut first_try = true;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for d in 0..a.nrows() {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            if std::mem::take(&mut first_try) {
                // the linearised cost's reduction by the least damped step: below
                // MIN_PREDICTED_GAIN of the cost, more damped steps promise less still
                // (a converged update otherwise spends twelve ever more damped tries)
                let pred = -(2.0 * g.dot(&step) + (&jtj * &step).dot(&step));
                if pred < MIN_PREDICTED_GAIN * cost {
                    break;
                }
            }
            let mut cand: Vec<f64> = theta.iter().zip(step.iter()).map(|(t, s)| t + s).collect();
            clamp(&mut cand);
            let (rc, mc) = residuals(&cand);
            let cc = rc.norm_squared();
            if cc.is_finite() && cc < cost && mc.is_valid() {
                let rel = (cost - cc) / cost.max(1e-300);
                theta = cand;
                r = rc;
                m = mc;
                cost = cc;
                lambda = (lambda * 0.3).max(1e-9);
                improved = rel > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let chi_after = (r.rows(0, n_data).norm_squared() / n_data as f64).sqrt();
    if !m.is_valid() {
        return Err(Error::Numerical(
            "modal update produced an invalid model".into(),
        ));
    }
    let at_bound = match &opts.bounds {
        Some(b) => lay
            .free
            .iter()
            .zip(b)
            .enumerate()
            .filter(|(j, (_, bj))| bj.wn_at_bound(theta[j * per]))
            .map(|(_, (&k, _))| k)
            .collect(),
        None => Vec::new(),
    };
    // posterior standard deviations of ln ω, ln ζ: (JᵀJ)⁻¹ at the solution (prior rows
    // included), scaled by the misfit per degree of freedom when that exceeds 1
    let posterior_sd = if opts.posterior {
        let (jtj, _) = normal(&m, &r);
        let s2 =
            (r.rows(0, n_data).norm_squared() / (n_data as f64 - lay.n() as f64).max(1.0)).max(1.0);
        let sd = |i: usize, inv: &DMatrix<f64>| (inv[(i, i)].max(0.0) * s2).sqrt();
        match jtj.cholesky().map(|c| c.inverse()) {
            Some(inv) => (0..lay.free.len())
                .map(|j| [sd(j * per, &inv), sd(j * per + 1, &inv)])
                .collect(),
            None => (0..lay.free.len())
                .map(|_| [prior.ln_wn, prior.ln_zeta])
                .collect(),
        }
    } else {
        Vec::new()
    };
    Ok(UpdateResult {
        model: m,
        chi_before,
        chi_after,
        iterations: it,
        at_bound,
        posterior_sd,
    })
}

/// `target` changed like `old → new` with weight `w`: relative when old and new share a
/// sign and old is not negligible, absolute otherwise.
fn scale_change(target: f64, old: f64, new: f64, w: f64) -> f64 {
    if old.abs() > 1e-12 * (new.abs() + old.abs()) && (new / old) > 0.0 {
        target * (1.0 + w * (new / old - 1.0))
    } else {
        target + w * (new - old)
    }
}

/// Applies the change `old → new` (models at the operating pose) to `target` with
/// weight `w` in [0, 1].
pub fn apply_change(target: &mut ModalModel, old: &ModalModel, new: &ModalModel, w: f64) {
    for k in 0..target.modes.len().min(old.modes.len()) {
        let r = new.modes[k].wn / old.modes[k].wn;
        target.modes[k].wn *= r.powf(w);
        let dz = (new.modes[k].zeta / old.modes[k].zeta).ln();
        target.modes[k].zeta *= (w * dz).exp();
        for ((t, o), n) in target
            .channels
            .iter_mut()
            .zip(&old.channels)
            .zip(&new.channels)
        {
            let nk = &mut t.num[k];
            nk.b0 = scale_change(nk.b0, o.num[k].b0, n.num[k].b0, w);
            nk.b1 = scale_change(nk.b1, o.num[k].b1, n.num[k].b1, w);
        }
    }
    for ((t, o), n) in target
        .channels
        .iter_mut()
        .zip(&old.channels)
        .zip(&new.channels)
    {
        t.d += w * (n.d - o.d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::model::{ChannelModel, Mode, ModeNum};

    fn two_modes(f2: f64) -> ModalModel {
        let modes = vec![Mode::from_hz(100.0, 0.02), Mode::from_hz(f2, 0.03)];
        let num = modes
            .iter()
            .map(|m| ModeNum {
                b0: 1e-6 * m.wn * m.wn,
                b1: 0.0,
            })
            .collect();
        ModalModel {
            modes,
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num,
                d: 0.0,
            }],
        }
    }

    /// A shifted second mode is recovered from points around it only; the first mode,
    /// held, stays exactly as it was.
    #[test]
    fn recovers_a_shifted_mode_from_local_points() {
        let old = two_modes(300.0);
        let truth = two_modes(280.0);
        let freqs: Vec<f64> = (0..40).map(|i| 250.0 + i as f64 * 2.0).collect();
        let h: Vec<Complex64> = freqs.iter().map(|&f| truth.eval_hz(0, f)).collect();
        let sigma = h.iter().map(|v| 0.01 * v.norm() + 1e-12).collect();
        let pts = [Points {
            channel: Channel::new(Axis::X, Axis::X),
            freqs_hz: freqs,
            h,
            sigma,
        }];
        let res = update_modes(&old, &[1], &pts, Prior::default(), 50).unwrap();
        assert!(
            (res.model.modes[1].freq_hz() - 280.0).abs() < 0.05,
            "{:?}",
            res.model.modes
        );
        assert_eq!(res.model.modes[0], old.modes[0]);
        assert!(res.chi_after < 0.05 * res.chi_before);
    }

    fn points_of(model: &ModalModel, ci: usize, freqs: &[f64], rel: f64) -> Points {
        let h: Vec<Complex64> = freqs.iter().map(|&f| model.eval_hz(ci, f)).collect();
        Points {
            channel: model.channels[ci].channel,
            freqs_hz: freqs.to_vec(),
            sigma: h.iter().map(|v| rel * v.norm() + 1e-15).collect(),
            h,
        }
    }

    /// Data with the second mode moved below the first: unbounded, the update follows
    /// it; with identity bounds the mode stops at the geometric midpoint to its neighbour
    /// and says it ended on its bound.
    #[test]
    fn identity_bounds_stop_a_mode_at_its_neighbour() {
        let old = two_modes(120.0);
        let truth = two_modes(95.0);
        let freqs: Vec<f64> = (0..60).map(|i| 85.0 + i as f64).collect();
        let pts = [points_of(&truth, 0, &freqs, 0.01)];
        let free = [1];
        let loose = update_modes(&old, &free, &pts, Prior::default(), 80).unwrap();
        assert!(
            loose.model.modes[1].freq_hz() < 100.0,
            "{:?}",
            loose.model.modes
        );
        let b = ModeBounds::identity(&old, 1, &Prior::default());
        let mid = (100.0f64 * 120.0).sqrt();
        assert!((b.ln_wn.0.exp() / (2.0 * PI) - mid).abs() < 1e-9);
        let opts = UpdateOptions::keeping_identity(&old, &free, Prior::default());
        let kept = update_modes_with(&old, &free, &pts, &opts).unwrap();
        let f1 = kept.model.modes[1].freq_hz();
        assert!(f1 >= mid - 1e-6, "{f1} Hz passed its neighbour");
        assert_eq!(kept.at_bound, vec![1]);
        assert_eq!(kept.model.modes[0], old.modes[0]);
        // damping bounds are physical and hold the start
        assert!(b.ln_zeta.0 <= 0.03f64.ln() && b.ln_zeta.1 >= 0.03f64.ln());
        assert!(b.ln_zeta.1 <= ZETA_RANGE.1.ln() + 1e-12);
    }

    /// The model discrepancy is set by the bulk of the lines: a 2 % scatter (per component)
    /// on every line
    /// gives ε ≈ 2 % whether or not a tenth of the lines also carry a large change.
    #[test]
    fn discrepancy_is_robust_to_a_local_change() {
        let model = two_modes(300.0);
        let freqs: Vec<f64> = (0..400).map(|i| 50.0 + i as f64).collect();
        let mut lcg = crate::test_util::Lcg(7);
        let scatter: Vec<Complex64> = freqs
            .iter()
            .map(|_| Complex64::new(0.07 * lcg.uniform(), 0.07 * lcg.uniform()))
            .collect();
        let mut pts = points_of(&model, 0, &freqs, 1e-6);
        for (h, e) in pts.h.iter_mut().zip(&scatter) {
            *h *= Complex64::new(1.0, 0.0) + e;
        }
        let eps = discrepancy(&model, std::slice::from_ref(&pts))[0];
        assert!((0.015..0.03).contains(&eps), "ε {eps}");
        // a shifted mode changes the lines around 300 Hz (a tenth of them) a lot
        let worn = two_modes(290.0);
        for (i, f) in freqs.iter().enumerate() {
            if (280.0..320.0).contains(f) {
                pts.h[i] = worn.eval_hz(0, *f) * (Complex64::new(1.0, 0.0) + scatter[i]);
            }
        }
        let eps2 = discrepancy(&model, std::slice::from_ref(&pts))[0];
        assert!(eps2 < 1.3 * eps, "ε {eps} -> {eps2}");
        // the errors grow by it: σ² + ε² |F|²
        let with = with_discrepancy(&model, std::slice::from_ref(&pts), &[eps2]);
        for (a, b) in with[0].sigma.iter().zip(&pts.sigma) {
            assert!(a >= b);
        }
    }

    /// The data's cross channel, known no better than the twin's discrepancy there, says
    /// a y-mode has a large x component: without the shape prior the update rotates the
    /// mode; with it the cross residue stays near its small previous value, while the
    /// frequency follows the data.
    #[test]
    fn shape_prior_keeps_a_mode_direction() {
        let mk = |cross: f64| ModalModel {
            modes: vec![Mode::from_hz(100.0, 0.02), Mode::from_hz(200.0, 0.02)],
            channels: [(Axis::X, [1.0, 1e-3]), (Axis::Y, [cross, 1.0])]
                .iter()
                .map(|&(o, n)| ChannelModel {
                    channel: Channel::new(o, Axis::Y),
                    num: n
                        .iter()
                        .map(|v| ModeNum {
                            b0: v * 1e-2 * (2.0 * PI * 150.0).powi(2),
                            b1: 0.0,
                        })
                        .collect(),
                    d: 0.0,
                })
                .collect(),
        };
        // channel 0 is x per y (the cross channel here), channel 1 y per y
        let old = mk(0.0);
        let mut truth = mk(0.0);
        truth.channels[0].num[1].b0 = 0.3 * truth.channels[1].num[1].b0;
        truth.modes[1].wn *= 0.97;
        let freqs: Vec<f64> = (0..80).map(|i| 160.0 + i as f64).collect();
        // the cross channel with an error the size of the model's discrepancy there (a
        // third of the direct channel), the direct one within 1 %
        let direct = points_of(&truth, 1, &freqs, 0.01);
        let mut cross = points_of(&truth, 0, &freqs, 0.01);
        for (s, h) in cross.sigma.iter_mut().zip(&direct.h) {
            *s = 0.3 * h.norm();
        }
        let pts = [cross, direct];
        let free = [1];
        let loose = update_modes(&old, &free, &pts, Prior::default(), 80).unwrap();
        let ratio = |m: &ModalModel| m.channels[0].num[1].b0 / m.channels[1].num[1].b0;
        assert!(ratio(&loose.model) > 0.1, "loose: {}", ratio(&loose.model));
        let kept = update_modes_with(
            &old,
            &free,
            &pts,
            &UpdateOptions::keeping_identity(&old, &free, Prior::default()),
        )
        .unwrap();
        assert!(
            ratio(&kept.model).abs() < 0.01,
            "kept: {}",
            ratio(&kept.model)
        );
        // the frequency still follows the data
        let f = kept.model.modes[1].freq_hz();
        assert!((f / 194.0 - 1.0).abs() < 0.01, "{f} Hz");
        assert_eq!(kept.posterior_sd.len(), 1);
        assert!(kept.posterior_sd[0][0] > 0.0 && kept.posterior_sd[0][0] < 0.2);
    }
}
