//! Cause `mode_change`: the dominant changed mode retuned.

use super::candidate::{dominant_axis, map_models, retune, retune_prior, Cand};
use super::Cause;
use crate::axis::Channel;
use crate::modal_update::{chi, Points};
use crate::model::ModalModel;
use crate::twin::Twin;
use num_complex::Complex64;
use serde_json::{json, Map};

/// Largest relative frequency distance of two modes retuned together as one pair (the
/// x and y bending modes of one body, e.g. a tool on its interface, move together).
const PAIR_MAX_SPACING: f64 = 0.05;

/// The mode whose retune fits `pts` best: (χ after, its index, the retuned model). Each
/// mode is retuned alone and, where another mode lies within [`PAIR_MAX_SPACING`] of it,
/// together with that neighbour: a joint that carries both bending modes of a body (a
/// tool interface) changes both, and one mode retuned alone then loses to an added mode
/// (second generator: tool interface stiffness x0.77, damping x1.8, both 2 kHz modes
/// moved to 1765 Hz; one mode retuned χ 14.3, a new mode 9.6). Of a pair, the index
/// returned is the mode that moved most.
pub(super) fn best_retune(model: &ModalModel, pts: &[Points]) -> Option<(f64, usize, ModalModel)> {
    let mut best: Option<(f64, usize, ModalModel)> = None;
    let n = model.modes.len();
    let f = |m: &ModalModel, k: usize| m.modes[k].freq_hz();
    for k in 0..n {
        let mut tries = Vec::new();
        if let Ok(r) = retune(model, k, pts) {
            tries.push((r.model, k));
        }
        // the pair with the next mode up (each pair once)
        if let Some(j) = (k + 1..n)
            .filter(|&j| (f(model, j) / f(model, k) - 1.0).abs() <= PAIR_MAX_SPACING)
            .min_by(|&a, &b| {
                (f(model, a) - f(model, k))
                    .abs()
                    .total_cmp(&(f(model, b) - f(model, k)).abs())
            })
        {
            let prior = retune_prior();
            if let Ok(r) = crate::modal_update::update_modes(model, &[k, j], pts, prior, 40) {
                let moved = |i: usize| (f(&r.model, i) / f(model, i)).ln().abs();
                let lead = if moved(j) > moved(k) { j } else { k };
                tries.push((r.model, lead));
            }
        }
        for (m, lead) in tries {
            let c = chi(&m, pts, 0.0);
            if best.as_ref().is_none_or(|b| c < b.0) {
                best = Some((c, lead, m));
            }
        }
    }
    best
}

pub(super) fn cand_mode_change(
    twin: &Twin,
    model: &ModalModel,
    retuned: Option<&(f64, usize, ModalModel)>,
) -> Option<Cand> {
    let (c, k, new) = retuned?.clone();
    let (old_m, new_m) = (model.modes[k], new.modes[k]);
    let ext = map_models(twin, |m| {
        let mut m = m.clone();
        crate::modal_update::apply_change(&mut m, model, &new, 1.0);
        m
    });
    // the mode kept its frequency and damping but now moves the tool along another
    // axis too (its cross-channel response rose): a cross coupling, not a worn mode
    if let Some((channel, rise)) = turned_mode(model, &new, k) {
        let mut d = Map::new();
        d.insert("channel".into(), json!(channel.name()));
        d.insert("freq_hz".into(), json!(new_m.freq_hz()));
        d.insert("channels".into(), json!([channel.name()]));
        d.insert("mode".into(), json!(k));
        d.insert("cross_rise_rel_to_direct".into(), json!(rise));
        return Some(Cand {
            cause: Cause::CrossCoupling,
            twin: ext,
            chi: c,
            details: d,
            per_record: Vec::new(),
            local_chi: None,
        });
    }
    let mut d = Map::new();
    d.insert("freq_hz".into(), json!(old_m.freq_hz()));
    d.insert("new_freq_hz".into(), json!(new_m.freq_hz()));
    d.insert("damping".into(), json!(old_m.zeta));
    d.insert("new_damping".into(), json!(new_m.zeta));
    d.insert("axis".into(), json!(dominant_axis(model, k).to_string()));
    d.insert("mode".into(), json!(k));
    Some(Cand {
        cause: Cause::ModeChange,
        twin: ext,
        chi: c,
        details: d,
        per_record: Vec::new(),
        local_chi: None,
    })
}

/// Largest frequency change \[relative\] of a retuned mode that still counts as "kept
/// its frequency" (a turned mode, not a worn one).
const TURNED_MAX_FREQ_CHANGE: f64 = 0.005;
/// Largest damping change \[relative\] of a turned mode.
const TURNED_MAX_DAMPING_CHANGE: f64 = 0.25;
/// Smallest rise of a cross channel's resonant response, relative to the mode's
/// largest direct-channel response, that makes the retune a cross coupling.
const TURNED_MIN_CROSS_RISE: f64 = 0.1;

/// When mode `k` of `new` (retuned from `old`) kept its frequency and damping while a
/// cross channel's resonant response of that mode rose by at least
/// [`TURNED_MIN_CROSS_RISE`] of the mode's largest direct response (and at least
/// doubled): that channel and the rise.
fn turned_mode(old: &ModalModel, new: &ModalModel, k: usize) -> Option<(Channel, f64)> {
    let (mo, mn) = (old.modes[k], new.modes[k]);
    if (mn.wn / mo.wn - 1.0).abs() > TURNED_MAX_FREQ_CHANGE
        || (mn.zeta / mo.zeta - 1.0).abs() > TURNED_MAX_DAMPING_CHANGE
    {
        return None;
    }
    // the mode's response at its own resonance in each channel
    let peak = |m: &ModalModel, c: &crate::model::ChannelModel| {
        let md = m.modes[k];
        let s = Complex64::new(0.0, md.wn);
        (Complex64::new(c.num[k].b0, 0.0) + s * c.num[k].b1).norm() / md.den(s).norm()
    };
    let direct = new
        .channels
        .iter()
        .filter(|c| c.channel.input == c.channel.output)
        .map(|c| peak(new, c))
        .fold(0.0, f64::max);
    if direct <= 0.0 {
        return None;
    }
    new.channels
        .iter()
        .zip(&old.channels)
        .filter(|(c, _)| c.channel.input != c.channel.output)
        .map(|(cn, co)| {
            let (a, b) = (peak(old, co), peak(new, cn));
            (cn.channel, (b - a) / direct, b / a.max(1e-300))
        })
        .filter(|(_, rise, ratio)| *rise >= TURNED_MIN_CROSS_RISE && *ratio >= 2.0)
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(c, rise, _)| (c, rise))
}
