//! Cause `cross_coupling`: the cross channels the twin lacks.

use super::candidate::{fit_numerators, map_models, pair_partner, retune, retune_prior, Cand};
use super::Cause;
use crate::modal_update::{chi, Points};
use crate::model::{ChannelModel, ModalModel, ModeNum};
use crate::twin::Twin;
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
                r.channel_index(p.channel).map_or(0.0, |ci| {
                    let (md, nm) = (r.modes[k], r.channels[ci].num[k]);
                    let s = num_complex::Complex64::new(0.0, md.wn);
                    (num_complex::Complex64::new(nm.b0, 0.0) + s * nm.b1).norm() / md.den(s).norm()
                })
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
