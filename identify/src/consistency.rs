//! Modal consistency of a pose model: at the tool center point the hammer and the sensor
//! sit at the same point, so each mode's residues over the channels between the hammered
//! directions form a rank-one matrix (`ψ ψᵀ` scaled, complex for non-proportional
//! damping). A free fit per channel also puts small residues where the mode has none: an
//! x mode fitted in yy as well, which draws a dip of a few percent into yy at the x mode's
//! frequency (tryout pose (0.2, 0.15, 0.25): 4 % at 82 Hz, half of yy's misfit of the
//! truth). Each isolated mode's residue matrix is replaced by its nearest rank-one matrix
//! when the measured FRF does not contradict it.

use crate::axis::{Axis, Channel};
use crate::model::{ModalModel, ModeNum};
use nalgebra::DMatrix;
use num_complex::Complex64;

/// A mode is isolated when every other mode lies more than this many times the sum of
/// both half-power half-widths (`ζ ωn`) away: closer modes share their residues (two
/// modes 2 % apart at 3 % damping trade them, and each one's own matrix is not rank one).
pub const ISOLATION_WIDTHS: f64 = 2.0;

/// Modes damped more than this are residual terms (out-of-band modes lumped together),
/// not one physical mode: never projected.
const MAX_ZETA: f64 = 0.2;

/// A residue matrix whose second singular value exceeds this share of its first holds
/// two modes' shapes (a pole that merged an x and a y mode): never projected.
pub const MAX_RATIO: f64 = 0.1;

/// The channels between the hammered directions, when all are in `model` and carry a
/// response (none held at zero): `idx[o][i]`, directions in axis order.
fn collocated_block(model: &ModalModel) -> Option<Vec<Vec<usize>>> {
    let mut inputs: Vec<Axis> = Vec::new();
    for c in &model.channels {
        if !inputs.contains(&c.channel.input) {
            inputs.push(c.channel.input);
        }
    }
    if inputs.len() < 2 {
        return None;
    }
    inputs.sort_by_key(|a| a.index());
    let mut idx = Vec::with_capacity(inputs.len());
    for o in &inputs {
        let mut row = Vec::with_capacity(inputs.len());
        for i in &inputs {
            let ci = model.channel_index(Channel::new(*o, *i))?;
            let held = model.channels[ci]
                .num
                .iter()
                .all(|n| n.b0 == 0.0 && n.b1 == 0.0);
            if held {
                return None;
            }
            row.push(ci);
        }
        idx.push(row);
    }
    Some(idx)
}

/// Mode `k` of `model` is isolated from every other mode ([`ISOLATION_WIDTHS`]), inside
/// `band` \[Hz\] and a physical mode (damped ≤ 20 %).
fn isolated(model: &ModalModel, k: usize, band: (f64, f64)) -> bool {
    let m = &model.modes[k];
    let f = m.freq_hz();
    if !(m.zeta <= MAX_ZETA && f >= band.0 && f <= band.1) {
        return false;
    }
    model.modes.iter().enumerate().all(|(j, o)| {
        j == k || (m.wn - o.wn).abs() > ISOLATION_WIDTHS * (m.zeta * m.wn + o.zeta * o.wn)
    })
}

/// The nearest rank-one matrix to mode `k`'s residues over the block `idx`, as numerators,
/// and the ratio of the matrix's second singular value to its first.
fn rank_one(model: &ModalModel, k: usize, idx: &[Vec<usize>]) -> Option<(Vec<ModeNum>, f64)> {
    let n = idx.len();
    let mode = model.modes[k];
    let p = mode.pole();
    let r =
        DMatrix::<Complex64>::from_fn(n, n, |o, i| model.channels[idx[o][i]].num[k].residue(&mode));
    let svd = r.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|a, b| svd.singular_values[*b].total_cmp(&svd.singular_values[*a]));
    let s0 = svd.singular_values[order[0]];
    if !(s0 > 0.0 && s0.is_finite()) {
        return None;
    }
    let s1 = order.get(1).map_or(0.0, |&j| svd.singular_values[j]);
    let mut out = Vec::with_capacity(n * n);
    for o in 0..n {
        for i in 0..n {
            let r1 = u[(o, order[0])] * v_t[(order[0], i)] * s0;
            out.push(ModeNum::from_residue(p, r1));
        }
    }
    Some((out, s1 / s0))
}

/// Replaces the residues of each isolated mode of `model` between the hammered directions
/// by their nearest rank-one matrix, one mode at a time, keeping each change while `keeps`
/// accepts the model with it (and those kept before). Returns one note per mode changed.
pub(crate) fn rank_one_residues(
    model: &mut ModalModel,
    band: (f64, f64),
    keeps: impl Fn(&ModalModel) -> bool,
) -> Vec<String> {
    let Some(idx) = collocated_block(model) else {
        return Vec::new();
    };
    let mut notes = Vec::new();
    for k in 0..model.modes.len() {
        if !isolated(model, k, band) {
            continue;
        }
        let Some((nums, ratio)) = rank_one(model, k, &idx).filter(|(_, r)| *r <= MAX_RATIO) else {
            continue;
        };
        let mut next = model.clone();
        let n = idx.len();
        for o in 0..n {
            for i in 0..n {
                next.channels[idx[o][i]].num[k] = nums[o * n + i];
            }
        }
        if !next.is_valid() || !keeps(&next) {
            continue;
        }
        notes.push(format!(
            "{:.1} Hz (second/first singular value {:.3})",
            model.modes[k].freq_hz(),
            ratio
        ));
        *model = next;
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ChannelModel, Mode};

    fn model(residues: &[[Complex64; 4]], modes: &[Mode]) -> ModalModel {
        let chans = [
            (Axis::X, Axis::X),
            (Axis::X, Axis::Y),
            (Axis::Y, Axis::X),
            (Axis::Y, Axis::Y),
        ];
        ModalModel {
            modes: modes.to_vec(),
            channels: chans
                .iter()
                .enumerate()
                .map(|(c, (o, i))| ChannelModel {
                    channel: Channel::new(*o, *i),
                    num: modes
                        .iter()
                        .zip(residues)
                        .map(|(m, r)| ModeNum::from_residue(m.pole(), r[c]))
                        .collect(),
                    d: 0.0,
                })
                .collect(),
        }
    }

    #[test]
    fn a_stray_residue_of_an_isolated_mode_is_removed_and_a_close_pair_is_kept() {
        let c = |re: f64| Complex64::new(0.0, -re);
        let modes = [
            Mode::from_hz(85.0, 0.03),
            Mode::from_hz(125.0, 0.03),
            Mode::from_hz(127.0, 0.03),
        ];
        // an x mode with a stray yy residue (1 % of xx), and a close pair
        let r = [
            [c(1.0), c(0.001), c(0.001), c(0.01)],
            [c(1.0), c(0.4), c(0.4), c(0.2)],
            [c(0.05), c(0.05), c(0.05), c(1.0)],
        ];
        let mut m = model(&r, &modes);
        let before = m.clone();
        let notes = rank_one_residues(&mut m, (30.0, 2500.0), |_| true);
        assert_eq!(notes.len(), 1, "{notes:?}");
        let yy = m.channel_index(Channel::new(Axis::Y, Axis::Y)).unwrap();
        let xx = m.channel_index(Channel::new(Axis::X, Axis::X)).unwrap();
        let ryy = m.channels[yy].num[0].residue(&modes[0]).norm();
        let rxx = m.channels[xx].num[0].residue(&modes[0]).norm();
        assert!(ryy < 1e-5 && (rxx - 1.0).abs() < 1e-3, "yy {ryy}, xx {rxx}");
        // the close pair untouched
        for k in 1..3 {
            for (a, b) in m.channels.iter().zip(&before.channels) {
                assert_eq!(a.num[k], b.num[k]);
            }
        }
        // and nothing when the data refuse it
        let mut m = before.clone();
        assert!(rank_one_residues(&mut m, (30.0, 2500.0), |_| false).is_empty());
        assert_eq!(m, before);
    }
}
