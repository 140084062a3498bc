//! Cause `time_delay`: a constant delay between force and response, from the phase.

use super::candidate::Cand;
use super::Cause;
use crate::modal_update::{chi, Points};
use crate::model::ModalModel;
use crate::twin::Twin;
use serde_json::{json, Map};

pub(super) fn cand_time_delay(
    twin: &Twin,
    model: &ModalModel,
    pts: &[Points],
    dt: f64,
) -> Option<Cand> {
    let f = |tau: f64| chi(model, pts, tau);
    // coarse scan ±50 samples, then golden-section refinement
    let mut best = (f(0.0), 0.0);
    for i in -200..=200 {
        let tau = i as f64 * dt / 4.0;
        let c = f(tau);
        if c < best.0 {
            best = (c, tau);
        }
    }
    let (mut a, mut b) = (best.1 - dt / 4.0, best.1 + dt / 4.0);
    let g = 0.618_033_988_75;
    for _ in 0..40 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if f(x1) < f(x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    let tau = 0.5 * (a + b);
    let mut ext = twin.clone();
    ext.extensions.delay_s = Some(twin.extensions.delay_s.unwrap_or(0.0) + tau);
    let mut d = Map::new();
    d.insert("delay_s".into(), json!(tau));
    Some(Cand {
        cause: Cause::TimeDelay,
        chi: f(tau),
        twin: ext,
        details: d,
        per_record: Vec::new(),
        local_chi: None,
        fitted_in_time: false,
    })
}
