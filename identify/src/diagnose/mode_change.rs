//! Cause `mode_change`: the dominant changed mode retuned.

use super::candidate::{dominant_axis, map_models, retune, Cand};
use super::Cause;
use crate::modal_update::{chi, Points};
use crate::model::ModalModel;
use crate::twin::Twin;
use serde_json::{json, Map};

pub(super) fn cand_mode_change(twin: &Twin, model: &ModalModel, pts: &[Points]) -> Option<Cand> {
    let mut best: Option<(f64, usize, ModalModel)> = None;
    for k in 0..model.modes.len() {
        let Ok(r) = retune(model, k, pts) else {
            continue;
        };
        let c = chi(&r.model, pts, 0.0);
        if best.as_ref().is_none_or(|b| c < b.0) {
            best = Some((c, k, r.model));
        }
    }
    let (c, k, new) = best?;
    let (old_m, new_m) = (model.modes[k], new.modes[k]);
    let ext = map_models(twin, |m| {
        let mut m = m.clone();
        crate::modal_update::apply_change(&mut m, model, &new, 1.0);
        m
    });
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
    })
}
