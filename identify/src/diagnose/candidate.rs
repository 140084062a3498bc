//! What the causes' detectors share: the candidate extension each proposes ([`Cand`]) and
//! the model edits and refits they are built from.

use super::Cause;
use crate::axis::{Axis, Channel};
use crate::error::Result;
use crate::modal_update::{update_modes, Points, Prior};
use crate::model::{ChannelModel, ModalModel, Mode, ModeNum};
use crate::twin::Twin;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde_json::{Map, Value};
use std::f64::consts::PI;

/// Replaces the model of every pose by `f(model)`.
pub(super) fn map_models(twin: &Twin, f: impl Fn(&ModalModel) -> ModalModel) -> Twin {
    let mut t = twin.clone();
    for p in &mut t.poses {
        p.model = f(&p.model);
    }
    t
}

pub(super) fn dominant_axis(model: &ModalModel, k: usize) -> Axis {
    model
        .channels
        .iter()
        .filter(|c| c.channel.output == c.channel.input)
        .max_by(|a, b| {
            let m = model.modes[k];
            let g = |c: &ChannelModel| {
                (c.num[k].b0.abs() + c.num[k].b1.abs() * m.wn) / (m.zeta * m.wn * m.wn)
            };
            g(a).total_cmp(&g(b))
        })
        .map_or(Axis::X, |c| c.channel.output)
}

/// The largest residual of `model` against `pts` (in standard errors) over the channels
/// the model has: (its size, frequency \[Hz\], channel).
pub(super) fn largest_residual(model: &ModalModel, pts: &[Points]) -> Option<(f64, f64, Channel)> {
    let mut peak: Option<(f64, f64, Channel)> = None;
    for p in pts {
        let Some(ci) = model.channel_index(p.channel) else {
            continue;
        };
        for ((f, h), sg) in p.freqs_hz.iter().zip(&p.h).zip(&p.sigma) {
            let r = ((h - model.eval_hz(ci, *f)) / sg).norm();
            if peak.is_none_or(|b| r > b.0) {
                peak = Some((r, *f, p.channel));
            }
        }
    }
    peak
}

/// Linear least squares of a channel's numerators with fixed poles, without a residual
/// compliance (`d = 0`: a constant fitted on a narrow band is an acceleration growing
/// with ω² everywhere else).
///
/// Only the modes the points constrain get numerators: those within a third octave of
/// the points' span (the nearest one when none is). A channel seen only around one mode
/// (a cross channel coherent near its peak) would otherwise give every other mode a
/// numerator that the few points cannot fix: they cancel there and blow up elsewhere.
pub(super) fn fit_numerators(modes: &[Mode], p: &Points) -> Option<ChannelModel> {
    let (f_lo, f_hi) = p
        .freqs_hz
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &f| (a.min(f), b.max(f)));
    let third = 2f64.powf(1.0 / 3.0);
    let fk = |m: &Mode| m.wn / (2.0 * PI);
    let mut active: Vec<usize> = (0..modes.len())
        .filter(|&k| fk(&modes[k]) >= f_lo / third && fk(&modes[k]) <= f_hi * third)
        .collect();
    if active.is_empty() {
        let dist = |k: usize| (fk(&modes[k]).ln() - (f_lo * f_hi).sqrt().ln()).abs();
        active.extend((0..modes.len()).min_by(|&a, &b| dist(a).total_cmp(&dist(b))));
    }
    let n = active.len();
    let rows = 2 * p.h.len();
    if rows < 2 * n + 1 {
        return None;
    }
    let mut a = DMatrix::zeros(rows, 2 * n);
    let mut b = DVector::zeros(rows);
    for (i, ((f, h), sg)) in p.freqs_hz.iter().zip(&p.h).zip(&p.sigma).enumerate() {
        let s = Complex64::new(0.0, 2.0 * PI * f);
        let target = h / sg;
        b[2 * i] = target.re;
        b[2 * i + 1] = target.im;
        for (j, &k) in active.iter().enumerate() {
            let m = &modes[k];
            let c0 = 1.0 / m.den(s) / sg;
            let c1 = s / m.den(s) / sg;
            a[(2 * i, 2 * j)] = c0.re;
            a[(2 * i + 1, 2 * j)] = c0.im;
            a[(2 * i, 2 * j + 1)] = c1.re;
            a[(2 * i + 1, 2 * j + 1)] = c1.im;
        }
    }
    // column scaling for conditioning
    let scales: Vec<f64> = (0..2 * n).map(|j| a.column(j).norm().max(1e-300)).collect();
    for (j, sc) in scales.iter().enumerate() {
        a.column_mut(j).scale_mut(1.0 / sc);
    }
    let x = a.svd(true, true).solve(&b, 1e-12).ok()?;
    let mut num = vec![ModeNum { b0: 0.0, b1: 0.0 }; modes.len()];
    for (j, &k) in active.iter().enumerate() {
        num[k] = ModeNum {
            b0: x[2 * j] / scales[2 * j],
            b1: x[2 * j + 1] / scales[2 * j + 1],
        };
    }
    Some(ChannelModel {
        channel: p.channel,
        num,
        d: 0.0,
    })
}

pub(super) struct Cand {
    pub(super) cause: Cause,
    pub(super) twin: Twin,
    pub(super) chi: f64,
    pub(super) details: Map<String, Value>,
    /// When not empty: the twin to judge each record's held-out part with (one per
    /// record, in order), e.g. a disturbance's tones fitted per record.
    pub(super) per_record: Vec<Twin>,
    /// The worst local misfit (χ over ±2.5 % of frequency) before and after, when the
    /// candidate judges it itself: a pose dependence, each data pose's model against that
    /// pose's own evidence (at the data's mean pose its per-pose changes average out).
    /// `None`: judged on the pooled evidence at the data's pose.
    pub(super) local_chi: Option<(f64, f64)>,
    /// Fitted to the records' responses in time, not to the FRF evidence (periodic
    /// milling forces leave that evidence little but leakage): judged by the held-out
    /// responses alone, where it acts and as a whole.
    pub(super) fitted_in_time: bool,
}

/// Mode `k` of `model` alone refitted to `pts` (frequency may move up to ~30 %).
pub(super) fn retune(
    model: &ModalModel,
    k: usize,
    pts: &[Points],
) -> Result<crate::modal_update::UpdateResult> {
    update_modes(model, &[k], pts, retune_prior(), 40)
}

/// Largest relative frequency distance of two modes retuned together as one pair (the
/// x and y bending modes of one body, e.g. a tool on its interface, move together; a
/// turned guide splits them).
pub(super) const PAIR_MAX_SPACING: f64 = 0.05;

/// The mode of `model` nearest mode `k` within [`PAIR_MAX_SPACING`] among `among`.
pub(super) fn pair_partner(
    model: &ModalModel,
    k: usize,
    among: impl Iterator<Item = usize>,
) -> Option<usize> {
    nearest_mode_within(model, k, among, PAIR_MAX_SPACING)
}

/// The mode of `among` (not `k`) nearest to mode `k` of `model` in frequency, within a
/// relative distance `spacing` of it.
pub(super) fn nearest_mode_within(
    model: &ModalModel,
    k: usize,
    among: impl Iterator<Item = usize>,
    spacing: f64,
) -> Option<usize> {
    let f = |i: usize| model.modes[i].freq_hz();
    among
        .filter(|&j| j != k && (f(j) / f(k) - 1.0).abs() <= spacing)
        .min_by(|&a, &b| (f(a) - f(k)).abs().total_cmp(&(f(b) - f(k)).abs()))
}

/// The prior of a retune: a mode's frequency may move by up to ~30 %.
pub(super) fn retune_prior() -> Prior {
    Prior {
        ln_wn: 0.3,
        ..Prior::default()
    }
}

/// [`retune`] with the posterior standard deviation of the mode's `[ln ω, ln ζ]`
/// ([`UpdateResult::posterior_sd`](crate::modal_update::UpdateResult)).
pub(super) fn retune_with_sd(
    model: &ModalModel,
    k: usize,
    pts: &[Points],
) -> Result<crate::modal_update::UpdateResult> {
    let opts = crate::modal_update::UpdateOptions {
        prior: retune_prior(),
        max_iter: 40,
        posterior: true,
        ..crate::modal_update::UpdateOptions::default()
    };
    crate::modal_update::update_modes_with(model, &[k], pts, &opts)
}

/// The points of `pts` between `lo` and `hi` Hz.
pub(super) fn near_points(pts: &[Points], lo: f64, hi: f64) -> Vec<Points> {
    pts.iter()
        .map(|p| {
            let keep: Vec<usize> = (0..p.freqs_hz.len())
                .filter(|&i| p.freqs_hz[i] >= lo && p.freqs_hz[i] <= hi)
                .collect();
            Points {
                channel: p.channel,
                freqs_hz: keep.iter().map(|&i| p.freqs_hz[i]).collect(),
                h: keep.iter().map(|&i| p.h[i]).collect(),
                sigma: keep.iter().map(|&i| p.sigma[i]).collect(),
            }
        })
        .filter(|p| !p.h.is_empty())
        .collect()
}
