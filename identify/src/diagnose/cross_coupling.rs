//! Cause `cross_coupling`: the cross channels the twin lacks.

use super::candidate::{fit_numerators, map_models, Cand};
use super::Cause;
use crate::modal_update::{chi, Points};
use crate::model::{ChannelModel, ModalModel};
use crate::twin::Twin;
use num_complex::Complex64;
use serde_json::{json, Map};

/// The channels the data have and the twin lacks, each fitted with the twin's modes
/// (numerators and residual only); `channel` names the one with the strongest response
/// (in standard errors), `channels` lists every one added (milling excites x and y at
/// once: both cross channels can be missing).
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
        .filter_map(|p| fit_numerators(&model.modes, p, |_| Complex64::new(0.0, 0.0)))
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
    let ext = {
        let mut t = map_models(twin, |pm| {
            let mut pm = pm.clone();
            pm.channels.extend(fitted.iter().cloned());
            pm
        });
        t.channels.extend(fitted.iter().map(|c| c.channel));
        t.channels.sort();
        t
    };
    let mut d = Map::new();
    d.insert("channel".into(), json!(p.channel.name()));
    d.insert("freq_hz".into(), json!(peak_f));
    d.insert(
        "channels".into(),
        json!(fitted.iter().map(|c| c.channel.name()).collect::<Vec<_>>()),
    );
    Some(Cand {
        cause: Cause::CrossCoupling,
        chi: chi(&m, pts, 0.0),
        twin: ext,
        details: d,
        per_record: Vec::new(),
    })
}
