//! Cause `cross_coupling`: the cross channels the twin lacks.

use super::candidate::{
    dominant_axis, fit_numerators, map_models, nearest_mode_within, pair_partner, retune,
    retune_prior, Cand,
};
use super::in_time::{force_power, force_share_near, InTime};
use super::mode_change::{
    excited_modes, time_search, twin_data_fits, TIME_RETUNE_DAMPING, TIME_RETUNE_MIN_DATA_DROP,
    TIME_RETUNE_MIN_FORCE_SHARE,
};
use super::Cause;
use crate::axis::{Axis, Channel};
use crate::modal_update::{chi, Points};
use crate::model::{ChannelModel, ModalModel, ModeNum};
use crate::twin::Twin;
use rayon::prelude::*;
use serde_json::{json, Map};

/// Largest relative frequency change of a mode refitted as turned into another axis: a
/// guide turned by 20-30 degrees also changes the stiffness the mode sees (second
/// generator: the ram guide's 137-140 Hz mode at 127-128 Hz, 7-9 %; with 5 % the refit
/// stayed at the old frequency and left 7-10 sigma of local misfit).
const TURNED_MAX_SHIFT: f64 = 0.15;

/// The channels the data have and the twin lacks, each fitted with the twin's modes
/// (numerators only, of the modes near the channel's points); `channel` names the one
/// with the strongest response (in standard errors), `channels` lists every one added
/// (milling excites x and y at once: both cross channels can be missing).
///
/// A mode turned into another axis also changes its direct response (it falls as the
/// cross one rises) and may move a little: each twin mode near the strongest missing
/// channel's points is refitted (frequency, damping, numerators in every channel, the
/// missing ones included) and the best refit is kept when it fits the evidence better
/// than the numerators alone; `freq_hz` is then that mode's new frequency.
pub(super) fn cand_cross_coupling(twin: &Twin, model: &ModalModel, pts: &[Points]) -> Option<Cand> {
    let strength = |p: &Points| {
        p.h.iter()
            .zip(&p.sigma)
            .map(|(h, s)| (h / s).norm_sqr())
            .sum::<f64>()
    };
    let mut missing: Vec<&Points> = pts
        .iter()
        .filter(|p| model.channel_index(p.channel).is_none())
        .collect();
    missing.sort_by(|a, b| strength(b).total_cmp(&strength(a)));
    let p = *missing.first()?;
    let fitted: Vec<ChannelModel> = missing
        .iter()
        .filter_map(|p| fit_numerators(&model.modes, p))
        .collect();
    if fitted.first().is_none_or(|c| c.channel != p.channel) {
        return None;
    }
    let mut m = model.clone();
    m.channels.extend(fitted.iter().cloned());
    let peak_f =
        p.h.iter()
            .zip(&p.freqs_hz)
            .max_by(|a, b| a.0.norm().total_cmp(&b.0.norm()))
            .map_or(0.0, |(_, f)| *f);
    let chi_num = chi(&m, pts, 0.0);
    // the turned mode: the twin with the missing channels (zero numerators), one mode
    // near the strongest missing channel refitted
    let zeros = |c: &ChannelModel| ChannelModel {
        channel: c.channel,
        num: vec![ModeNum { b0: 0.0, b1: 0.0 }; c.num.len()],
        d: 0.0,
    };
    let mut m0 = model.clone();
    m0.channels.extend(fitted.iter().map(zeros));
    // a turned guide couples the x and y bending modes of one body and splits them: each
    // mode with a share of the missing channel is refitted alone and together with its
    // nearest neighbour within a few per cent (second generator: the ram guide turned
    // 15-30 degrees split the 137/140 Hz pair, the new yx peak at 133 Hz; one mode
    // refitted alone stayed at 135.5-136.4 Hz); of a pair, the mode named is the one
    // with the larger response in the missing channel
    let n = model.modes.len();
    let turned = fitted[0]
        .num
        .iter()
        .enumerate()
        .filter(|(_, n)| n.b0 != 0.0 || n.b1 != 0.0)
        .flat_map(|(k, _)| {
            let pair = pair_partner(model, k, 0..n);
            let alone = retune(&m0, k, pts).ok().map(|r| (vec![k], r.model));
            let both = pair.and_then(|j| {
                let mut modes = vec![k, j];
                modes.sort_unstable();
                crate::modal_update::update_modes(&m0, &modes, pts, retune_prior(), 40)
                    .ok()
                    .map(|r| (modes, r.model))
            });
            alone.into_iter().chain(both)
        })
        // a turned mode keeps its frequency within TURNED_MAX_SHIFT (a larger move is
        // another mode's work, not this one turning)
        .filter(|(modes, r)| {
            modes
                .iter()
                .all(|&k| (r.modes[k].wn / model.modes[k].wn - 1.0).abs() <= TURNED_MAX_SHIFT)
        })
        .map(|(modes, r)| {
            // the mode of the pair with the larger response in that channel
            let cross = |k: usize| {
                r.channel_index(p.channel)
                    .map_or(0.0, |ci| r.mode_peak(ci, k))
            };
            let named = modes
                .iter()
                .copied()
                .max_by(|&a, &b| cross(a).total_cmp(&cross(b)))
                .unwrap_or(modes[0]);
            (chi(&r, pts, 0.0), named, r)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .filter(|t| t.0 < chi_num);
    let mut d = Map::new();
    d.insert("channel".into(), json!(p.channel.name()));
    d.insert(
        "channels".into(),
        json!(fitted.iter().map(|c| c.channel.name()).collect::<Vec<_>>()),
    );
    let chi_c = match &turned {
        Some((c, k, new)) => {
            super::trace(|| {
                format!(
                    "cross_coupling: mode {k} turned: {:.1} -> {:.1} Hz, chi {chi_num:.2} -> {c:.2}",
                    model.modes[*k].freq_hz(),
                    new.modes[*k].freq_hz()
                )
            });
            d.insert("freq_hz".into(), json!(new.modes[*k].freq_hz()));
            d.insert("mode".into(), json!(k));
            *c
        }
        None => {
            d.insert("freq_hz".into(), json!(peak_f));
            chi_num
        }
    };
    // every pose gains the missing channels: with the turned mode's change, or with the
    // numerators fitted here
    let mut ext = map_models(twin, |pm| {
        let mut pm = pm.clone();
        match &turned {
            Some((_, _, new)) => {
                pm.channels.extend(fitted.iter().map(zeros));
                crate::modal_update::apply_change(&mut pm, &m0, new, 1.0);
            }
            None => pm.channels.extend(fitted.iter().cloned()),
        }
        pm
    });
    ext.channels.extend(fitted.iter().map(|c| c.channel));
    ext.channels.sort();
    Some(Cand {
        cause: Cause::CrossCoupling,
        chi: chi_c,
        twin: ext,
        details: d,
        per_record: Vec::new(),
        local_chi: None,
        fitted_in_time: false,
    })
}

/// Turn angles \[degrees\] of [`cand_cross_coupling_time`]'s first search (each sign).
const TIME_TURN_DEG: [f64; 9] = [5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0];
/// Smallest turn \[degrees\] that [`cand_cross_coupling_time`] names: the cross response
/// is then at least a tenth of the direct one (tan 6° ≈ 0.1, as the FRF rule's
/// `TURNED_MIN_CROSS_RISE`).
const TIME_TURN_MIN_DEG: f64 = 6.0;
/// The further angles \[degrees\] of the first search of a pair turned together (a
/// stiffness turned a little turns the shapes of two modes of nearly one frequency much
/// further: the pair's angle spans the whole period, ±90°).
const TIME_TURN_DEG_PAIR: [f64; 9] = [50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0, 85.0, 90.0];
/// Largest relative frequency distance of the other axis's mode that
/// [`cand_cross_coupling_time`] retunes together with a turned mode's, to compare.
const TURN_PARTNER_SPACING: f64 = 0.1;
/// Largest difference \[degrees\] between the turn angles that
/// [`cand_cross_coupling_time`] fits to each record alone.
const TURN_ANGLE_AGREEMENT_DEG: f64 = 10.0;
/// Rounds of [`cand_cross_coupling_time`]'s pattern search.
const TIME_TURN_REFINE_ROUNDS: usize = 12;

/// The cross channels between the in-plane axes x and y that `twin` lacks, where it has
/// both direct channels.
fn missing_in_plane(twin: &Twin) -> Vec<Channel> {
    let has = |c: Channel| twin.channels.contains(&c);
    if !has(Channel::new(Axis::X, Axis::X)) || !has(Channel::new(Axis::Y, Axis::Y)) {
        return Vec::new();
    }
    [
        Channel::new(Axis::Y, Axis::X),
        Channel::new(Axis::X, Axis::Y),
    ]
    .into_iter()
    .filter(|c| !has(*c))
    .collect()
}

/// `model` with zero-numerator channels `add` (in the models' channel order).
fn with_zero_channels(model: &ModalModel, add: &[Channel]) -> ModalModel {
    let mut m = model.clone();
    for &c in add {
        if m.channel_index(c).is_none() {
            m.channels.push(ChannelModel {
                channel: c,
                num: vec![ModeNum { b0: 0.0, b1: 0.0 }; m.modes.len()],
                d: 0.0,
            });
        }
    }
    m.channels
        .sort_by_key(|c| (c.channel.input.index(), c.channel.output.index()));
    m
}

/// Mode `k`'s shape turned by `theta` \[rad\] about z: its numerators in every channel
/// become `R N Rᵀ` (`N` the mode's numerator matrix over the axes, absent channels zero;
/// `R` the rotation in the x-y plane), exact for a mode of rank one (`N = φ φᵀ`, the
/// shape `φ` turned) and linear in the numerators; then its frequency scaled by `f` and
/// its damping by `z`.
fn turn_mode(m: &mut ModalModel, k: usize, theta: f64, f: f64, z: f64) {
    let (c, s) = (theta.cos(), theta.sin());
    let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
    let mut n = [[(0.0, 0.0); 3]; 3];
    for ch in &m.channels {
        n[ch.channel.output.index()][ch.channel.input.index()] = (ch.num[k].b0, ch.num[k].b1);
    }
    for ch in &mut m.channels {
        let (o, i) = (ch.channel.output.index(), ch.channel.input.index());
        let (mut b0, mut b1) = (0.0, 0.0);
        for (a, ra) in r[o].iter().enumerate() {
            for (b, rb) in r[i].iter().enumerate() {
                b0 += ra * n[a][b].0 * rb;
                b1 += ra * n[a][b].1 * rb;
            }
        }
        ch.num[k] = ModeNum { b0, b1 };
    }
    m.modes[k].wn *= f;
    m.modes[k].zeta *= z;
}

/// A turn of mode `k` (and of its partner `j` along the other axis, by the same angle)
/// with the modes' frequency and damping factors `p` = `[f_k, ζ_k, f_j, ζ_j]`.
#[derive(Debug, Clone, Copy)]
struct Turn {
    k: usize,
    j: Option<usize>,
    theta: f64,
    p: [f64; 4],
}

impl Turn {
    /// The turn applied to `m` ([`turn_mode`]).
    fn apply(&self, m: &mut ModalModel) {
        turn_mode(m, self.k, self.theta, self.p[0], self.p[1]);
        if let Some(j) = self.j {
            turn_mode(m, j, self.theta, self.p[2], self.p[3]);
        }
    }
}

/// `base` (the twin with the missing cross channels at zero) turned by `t` at every pose.
fn with_turn(base: &Twin, t: &Turn) -> Twin {
    map_models(base, |pm| {
        let mut pm = pm.clone();
        t.apply(&mut pm);
        pm
    })
}

/// The retune of mode `k` (and of its partner `j`) and the best turn from it, fitted
/// to `fit`'s responses: `(residual retuned, the retune, residual turned, the turn, ln
/// of the frequency span)`; the turn is the retune when no angle fits better.
fn search_turn(
    fit: &InTime,
    base: &Twin,
    k: usize,
    j: Option<usize>,
) -> Option<(f64, Turn, f64, Turn, f64)> {
    let r0 = fit.residual(base)?;
    let score = |t: &Turn| fit.residual(&with_turn(base, t));
    let at = |theta: f64, p: [f64; 4]| Turn { k, j, theta, p };
    // the retune: frequency and damping of the mode, of its partner, of the mode again
    let mut p = [1.0; 4];
    let ((mut r, fk, zk), ln_span) = time_search(r0, |f, z| score(&at(0.0, [f, z, 1.0, 1.0])));
    p[0] = fk;
    p[1] = zk;
    if j.is_some() {
        let ((r2, fj, zj), _) = time_search(r, |f, z| score(&at(0.0, [p[0], p[1], f, z])));
        if r2 < r {
            (r, p[2], p[3]) = (r2, fj, zj);
        }
        let ((r3, fk, zk), _) = time_search(r, |f, z| score(&at(0.0, [f, z, p[2], p[3]])));
        if r3 < r {
            (r, p[0], p[1]) = (r3, fk, zk);
        }
    }
    let r_retune = r;
    let retuned = at(0.0, p);
    let mut top = (r, at(0.0, p));
    // a pair turned by 90 degrees swaps its shapes: its angles span the whole period
    let max_turn = if j.is_some() {
        90f64.to_radians()
    } else {
        TIME_TURN_DEG[TIME_TURN_DEG.len() - 1].to_radians()
    };
    for d in TIME_TURN_DEG.iter().chain(&TIME_TURN_DEG_PAIR) {
        if d.to_radians() > max_turn {
            continue;
        }
        for t in [*d, -d] {
            if let Some(r) = score(&at(t.to_radians(), p)) {
                if r < top.0 {
                    top = (r, at(t.to_radians(), p));
                }
            }
        }
    }
    if top.1.theta == 0.0 {
        let t = top.1;
        return Some((r_retune, t, r_retune, t, ln_span));
    }
    // a pattern search in (angle, ln frequencies, ln dampings) from there, its steps
    // halved when no move gains, within the first searches' bounds (their edges stay
    // edges)
    let (z_lo, z_hi) = (
        TIME_RETUNE_DAMPING[0].ln(),
        TIME_RETUNE_DAMPING[TIME_RETUNE_DAMPING.len() - 1].ln(),
    );
    let dims = if j.is_some() { 5 } else { 3 };
    let mut steps = [f64::to_radians(4.0), 0.01, 0.2, 0.01, 0.2];
    for _ in 0..TIME_TURN_REFINE_ROUNDS {
        let mut moved = false;
        for i in 0..dims {
            for sign in [1.0, -1.0] {
                let t = &top.1;
                let mut q = [t.theta, t.p[0].ln(), t.p[1].ln(), t.p[2].ln(), t.p[3].ln()];
                q[i] += sign * steps[i];
                if j.is_some() && q[0].abs() > max_turn {
                    q[0] -= q[0].signum() * std::f64::consts::PI;
                }
                let inside = q[0].abs() <= max_turn
                    && q[1].abs() <= ln_span
                    && q[3].abs() <= ln_span
                    && (z_lo..=z_hi).contains(&q[2])
                    && (z_lo..=z_hi).contains(&q[4]);
                if !inside {
                    continue;
                }
                let cand = at(q[0], [q[1].exp(), q[2].exp(), q[3].exp(), q[4].exp()]);
                if let Some(r) = score(&cand) {
                    if r < top.0 {
                        top = (r, cand);
                        moved = true;
                    }
                }
            }
        }
        if !moved {
            steps.iter_mut().for_each(|s| *s *= 0.5);
        }
    }
    Some((r_retune, retuned, top.0, top.1, ln_span))
}

/// For operating data (continuous records) of a twin without the x-y cross channels:
/// each in-plane mode the records excite, its shape turned about z (and its frequency
/// and damping retuned) to the building parts' responses in time; the turn that predicts
/// them best, fitted in time as [`super::mode_change::cand_mode_change_time`] is. A mode
/// with a partner along the other axis (within [`TURN_PARTNER_SPACING`]) turns with it by
/// one angle, and the turn must beat the retune of the same modes (a turn by zero), pass
/// the retune's gates, and be found again, at one angle, in each record alone
/// ([`TURN_ANGLE_AGREEMENT_DEG`]). Milling forces push along x and y at once and rise
/// and fall together, so at one harmonic line a new cross channel cannot be told from a
/// changed direct one (the FRF rule above has nothing to fit); in time, the turned
/// shape's direct and cross responses must follow every harmonic of both forces
/// together.
pub(super) fn cand_cross_coupling_time(
    twin: &Twin,
    model: &ModalModel,
    parts: &[crate::timeseries::TimeSeries],
    pts: &[Points],
) -> Option<Cand> {
    let missing = missing_in_plane(twin);
    if missing.is_empty() {
        return None;
    }
    let mut base = map_models(twin, |pm| with_zero_channels(pm, &missing));
    base.channels.extend(missing.iter().copied());
    base.channels.sort();
    let m0 = with_zero_channels(model, &missing);
    let fit = InTime::new(&base, parts)?;
    let r0 = fit.residual(&base)?;
    let (fits0, force) = (twin_data_fits(&base), force_power(fit.parts()));
    let in_plane = |k: usize| matches!(dominant_axis(&m0, k), Axis::X | Axis::Y);
    // a turn is scored against the retune of the same modes (a turn by zero): a pair
    // (the mode and its nearest mode along the other axis) is turned together, as a
    // turned guide turns the stiffness both modes of one body see
    let other_axis =
        |k: usize, j: usize| in_plane(j) && dominant_axis(&m0, j) != dominant_axis(&m0, k);
    // the modes to turn, a pair once (from its first mode the records excite)
    let mut tasks: Vec<(usize, Option<usize>)> = Vec::new();
    for k in excited_modes(&base, &m0, &fit)
        .into_iter()
        .filter(|&k| in_plane(k))
    {
        let j = nearest_mode_within(
            &m0,
            k,
            (0..m0.modes.len()).filter(|&j| other_axis(k, j)),
            TURN_PARTNER_SPACING,
        );
        if !tasks.iter().any(|&(a, b)| Some(k) == b && j == Some(a)) {
            tasks.push((k, j));
        }
    }
    let found: Vec<(f64, f64, Turn)> = tasks
        .par_iter()
        .filter_map(|&(k, j)| {
            let (r_retune, _, r_turn, t, ln_span) = search_turn(&fit, &base, k, j)?;
            if t.theta == 0.0 {
                return None;
            }
            let turned = with_turn(&base, &t);
            let drop = (fits0.iter())
                .zip(twin_data_fits(&turned))
                .map(|(a, b)| a - b)
                .fold(0.0, f64::max);
            let fk = m0.modes[k].freq_hz();
            let share = |i: usize, f: f64, z: f64| {
                let fi = m0.modes[i].freq_hz();
                let zi = m0.modes[i].zeta;
                force_share_near(&force, fi * f.min(1.0), fi * f.max(1.0), zi.max(zi * z))
            };
            let forced = share(k, t.p[0], t.p[1]).max(j.map_or(0.0, |j| share(j, t.p[2], t.p[3])));
            super::trace(|| {
                format!(
                    "  time turn [{k}] ({fk:.1} Hz, partner {j:?}): residual {:.4}, retuned {:.4}, \
                        turned {:.4}: {:.1} deg, x{:.4} Hz, x{:.2} damping (partner x{:.4}, x{:.2}), \
                        twin data fit drop {drop:.2}, force share there {forced:.1e}",
                    r0 / fit.power,
                    r_retune / fit.power,
                    r_turn / fit.power,
                    t.theta.to_degrees(),
                    t.p[0],
                    t.p[1],
                    t.p[2],
                    t.p[3]
                )
        });
        // the gates of the retune in time: not on the search's edge, a turn that
        // matters, one the twin's own identification data contradict, at a mode the cuts
        // excite
        // a pair turned by about 90 degrees has swapped its shapes: not a turn
        let deg = t.theta.to_degrees().abs();
        let deg = if j.is_some() {
            deg.min(90.0 - deg)
        } else {
            deg
        };
        let near = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b.abs().max(1e-3);
        let (z_lo, z_hi) = (
            TIME_RETUNE_DAMPING[0].ln(),
            TIME_RETUNE_DAMPING[TIME_RETUNE_DAMPING.len() - 1].ln(),
        );
        let z_edge = |z: f64| near(z.ln(), z_lo) || near(z.ln(), z_hi);
        let on_edge = (j.is_none() && near(deg, TIME_TURN_DEG[TIME_TURN_DEG.len() - 1]))
            || near(t.p[0].ln().abs(), ln_span)
            || z_edge(t.p[1])
            || (j.is_some() && (near(t.p[2].ln().abs(), ln_span) || z_edge(t.p[3])));
        (!on_edge
            && deg >= TIME_TURN_MIN_DEG
            && drop >= TIME_RETUNE_MIN_DATA_DROP
            && forced >= TIME_RETUNE_MIN_FORCE_SHARE
            && r_turn < r_retune)
            .then_some((r_turn, r_retune, t))
        })
        .collect();
    // the best (the first of equals, in the modes' order)
    let (r_turn, r_retune, t) =
        found
            .into_iter()
            .fold(None, |b: Option<(f64, f64, Turn)>, c| match b {
                Some(b) if b.0 <= c.0 => Some(b),
                _ => Some(c),
            })?;
    // a turned guide has one angle, whatever the cut: each record alone must give a turn,
    // at angles that agree within TURN_ANGLE_AGREEMENT_DEG (a turn that only soaks up the
    // twin's own error at one cut's harmonics lands elsewhere at another spindle speed;
    // second generator, milling: a healthy cut's pair turned 69 and 29 degrees, a turned
    // ram guide's 61 and 65)
    if parts.len() >= 2 {
        let angles: Vec<Option<f64>> = (0..parts.len())
            .into_par_iter()
            .map(|a| {
                let fit_a = InTime::new(&base, std::slice::from_ref(&parts[a]))?;
                let (_, _, _, turn_a, _) = search_turn(&fit_a, &base, t.k, t.j)?;
                let deg = turn_a.theta.to_degrees();
                super::trace(|| {
                    format!("  time turn [{}] fitted to record {a}: {deg:.1} deg", t.k)
                });
                (turn_a.theta != 0.0).then_some(deg)
            })
            .collect();
        let angles: Vec<f64> = angles.into_iter().collect::<Option<_>>()?;
        // angles of a shape are defined modulo 180 degrees
        let apart = |x: f64, y: f64| {
            let d = (x - y).rem_euclid(180.0);
            d.min(180.0 - d)
        };
        let spread = (angles.iter())
            .flat_map(|x| angles.iter().map(move |y| apart(*x, *y)))
            .fold(0.0, f64::max);
        if spread > TURN_ANGLE_AGREEMENT_DEG {
            return None;
        }
    }
    let ext = with_turn(&base, &t);
    let mut new = m0.clone();
    t.apply(&mut new);
    let c = chi(&new, pts, twin.extensions.delay_s.unwrap_or(0.0));
    super::trace(|| {
        format!(
            "  time turn chosen [{}]: residual retuned {:.4}, turned {:.4} (ratio {:.3})",
            t.k,
            r_retune / fit.power,
            r_turn / fit.power,
            r_turn / r_retune
        )
    });
    // the cross channel named: the one whose force drives it harder (milling along x:
    // yx), both carry the same numerators
    let force_of = |a: Axis| {
        parts
            .iter()
            .filter_map(|p| p.force(a))
            .map(|v| {
                let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
                v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>()
            })
            .sum::<f64>()
    };
    let channel = missing
        .iter()
        .copied()
        .max_by(|a, b| force_of(a.input).total_cmp(&force_of(b.input)))?;
    // of a pair, the mode named is the one with the larger resonance in that channel
    let cross = |i: usize| {
        new.channel_index(channel)
            .map_or(0.0, |ci| new.mode_peak(ci, i))
    };
    let k = match t.j {
        Some(j) if cross(j) > cross(t.k) => j,
        _ => t.k,
    };
    let mut d = Map::new();
    d.insert("channel".into(), json!(channel.name()));
    d.insert(
        "channels".into(),
        json!(missing.iter().map(|c| c.name()).collect::<Vec<_>>()),
    );
    d.insert("freq_hz".into(), json!(new.modes[k].freq_hz()));
    d.insert("twin_freq_hz".into(), json!(m0.modes[k].freq_hz()));
    d.insert("mode".into(), json!(k));
    d.insert("turn_deg".into(), json!(t.theta.to_degrees()));
    if let Some(j) = t.j {
        d.insert("modes".into(), json!([t.k, j]));
    }
    Some(Cand {
        cause: Cause::CrossCoupling,
        chi: c,
        twin: ext,
        details: d,
        per_record: Vec::new(),
        local_chi: None,
        fitted_in_time: true,
    })
}
