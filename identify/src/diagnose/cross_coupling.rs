//! Cause `cross_coupling`: the cross channels the twin lacks.

use super::candidate::{fit_numerators, map_models, retune, Cand};
use super::Cause;
use crate::modal_update::{chi, Points};
use crate::model::{ChannelModel, ModalModel, ModeNum};
use crate::twin::Twin;
use serde_json::{json, Map};

/// Largest relative frequency change of a mode refitted as turned into another axis.
const TURNED_MAX_SHIFT: f64 = 0.05;

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
    let turned = fitted[0]
        .num
        .iter()
        .enumerate()
        .filter(|(_, n)| n.b0 != 0.0 || n.b1 != 0.0)
        .filter_map(|(k, _)| {
            let r = retune(&m0, k, pts).ok()?;
            Some((chi(&r.model, pts, 0.0), k, r.model))
        })
        // a turned mode keeps its frequency within a few per cent (a larger move is
        // another mode's work, not this one turning)
        .filter(|(_, k, r)| (r.modes[*k].wn / model.modes[*k].wn - 1.0).abs() <= TURNED_MAX_SHIFT)
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
    })
}
