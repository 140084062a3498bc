//! Milling stability lobes from the twin's tool-tip FRF.
//!
//! The regenerative milling model (Altintas, *Manufacturing Automation*, ch. 4):
//!
//! ```text
//! F(t) = ap · Kt · A(t) · (r(t) − r(t − τ)),      τ = 60 / (rpm · N)
//! A(t) = Σ_j g(φ_j) · [ −cos φ − Kr sin φ ;  sin φ − Kr cos φ ] · [ sin φ  cos φ ]
//! ```
//!
//! with `r = (x, y)` the tool-tip displacement (the model's channels `xx`, `xy`, `yx`,
//! `yy`; absent cross channels are 0), `φ_j = Ω t + 2πj/N` the angle of tooth `j`
//! measured clockwise from +y (feed along +x), `g` the engagement window of the radial
//! immersion (down milling: `[acos(2a/D − 1), π]`, up milling: `[0, acos(1 − 2a/D)]`) and
//! `F` the force on the tool. This is Altintas' `{F} = ½ a Kt [A(t)] {Δ}` with the ½
//! absorbed into `A`.
//!
//! Two solutions:
//!
//! * [`lobes_zoa`] — zero-order approximation (Altintas & Budak 1995): `A` replaced by its
//!   average `A0`; for every chatter frequency ωc the eigenvalues λ of `A0 G(iωc)` give
//!   `ap = 1 / (2 Kt Re λ)` (only `Re λ > 0`), and the phase `ψ = arg λ` the spindle
//!   speeds `ωc τ = π + 2ψ + 2πk`, `k = 0, 1, …`. (Equivalent to the textbook
//!   `ap = −2π Λ_R (1 + κ²)/(N Kt)` with `Λ = −N/(4π λ)`.) The limit at a requested speed
//!   is the minimum over all lobe curves passing it.
//! * [`lobes_sd`] — a discretisation of the periodic delay equation over one tooth period
//!   and its Floquet multipliers (Insperger & Stépán). Stable ⇔ spectral radius < 1;
//!   `ap` limit by a bracketed root search on `ln ρ(ap)` started from the ZOA value.
//!   See [`SdOptions`] for the exact variant.
//!
//! Accuracy of the semi-discretisation (tests `identify/tests/lobes/sd.rs`): second order
//! in the step; with ~2.5 vibration periods per tooth period the limit is within ~3 % at
//! `steps = 40`, ~0.7 % at 80, ~0.2 % at 160. Its spectral radius matches the growth
//! factor of a brute-force time simulation of the delay equation to < 0.5 %. Cost: one
//! monodromy of a 10-mode twin (n = 40, 40 steps) ≈ 4 ms in release; the eigenvalues
//! (size `n + 2·steps`) dominate.
//!
//! A residual compliance `d` is exact in ZOA; the semi-discretisation replaces it by a
//! well-damped pseudo-mode ten times above the highest mode (with feedthrough the delay
//! equation would be of neutral type).

use crate::axis::{Axis, Channel};
use crate::eigen::{balance, eigenvalues};
use crate::error::{Error, Result};
use crate::model::{ModalModel, Mode};
use crate::simulate::{Hold, SectionStep};
use nalgebra::DMatrix;
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

/// The cutter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tool {
    /// Number of teeth (flutes), ≥ 1.
    pub teeth: usize,
    /// Diameter \[m\] (only used with a helix, for the axial lag).
    pub diameter_m: f64,
    /// Helix angle \[deg\] (0 = straight flutes). The ZOA average is independent of it; the
    /// semi-discretisation spreads each tooth's engagement over the axial lag.
    pub helix_deg: f64,
}

/// The cutting condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cut {
    /// Radial immersion `ae/D` in (0, 1] (1 = slotting).
    pub radial_immersion: f64,
    /// Down (climb) milling when true, up (conventional) milling when false.
    pub down_milling: bool,
    /// Tangential cutting coefficient Kt \[N/m²\].
    pub kt: f64,
    /// Radial to tangential force ratio Kr = Fr/Ft (dimensionless).
    pub kr: f64,
}

/// One point of a stability lobe diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobePoint {
    /// Spindle speed \[rev/min\].
    pub rpm: f64,
    /// Limiting axial depth of cut \[m\] (`f64::INFINITY` if no chatter was found).
    pub ap_lim_m: f64,
    /// Chatter frequency at the limit \[Hz\] (0 when `ap_lim_m` is infinite).
    pub chatter_hz: f64,
}

/// Options of the semi-discretisation.
///
/// The variant is the *first-order* semi-discretisation in its full-discretisation form
/// (Insperger & Stépán 2002/2004; Ding et al. 2010): over each step the structure (all
/// modes) is propagated exactly (`e^{A h}` in closed form per mode), the directional
/// matrix is replaced by its exact average over the step, and the regenerative term
/// `r(t) − r(t − τ)` is interpolated linearly between the grid points (present and
/// delayed values alike; the implicit present value is solved as a 2×2 system).
/// This keeps `ap` outside every exponential, so one monodromy costs a few sparse
/// passes plus one eigenvalue problem of size `n + 2M` (`n` = 4 per mode, `M` steps).
///
/// When the teeth are out of cut for part of the period (low immersion), the free
/// flight is one exact step and all `steps` are spent inside the cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdOptions {
    /// Steps over the engaged part of one tooth period (≥ 2; default 40).
    pub steps: usize,
    /// Relative tolerance of the `ap` limit (default 1e-3).
    pub rel_tol: f64,
    /// Axial slices used to average the helix lag (default 16; 1 without a helix).
    pub helix_slices: usize,
}

/// Depths probed evenly below a semi-discretisation limit in the search for unstable
/// islands (see `SdProblem::limit_guarded`).
const ISLAND_PROBES: usize = 8;

/// A hump of the spectral radius below the limit is refined (is it an island?) when it
/// reaches this: lower humps are far from instability.
const ISLAND_RHO_MIN: f64 = 0.99;

/// Resolution of the island search, relative to the limit.
const ISLAND_DEPTH_TOL: f64 = 0.01;

impl Default for SdOptions {
    fn default() -> Self {
        SdOptions {
            steps: 40,
            rel_tol: 1e-3,
            helix_slices: 16,
        }
    }
}

/// The critical Floquet multiplier of one cutting condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floquet {
    /// Spectral radius of the monodromy matrix (stable when < 1).
    pub spectral_radius: f64,
    /// The multiplier of largest modulus (`arg ≈ π`: period doubling / flip;
    /// complex: Hopf / secondary Hopf chatter).
    pub multiplier: Complex64,
}

type M2 = [[f64; 2]; 2];

fn m2_add(a: &mut M2, b: &M2, s: f64) {
    for i in 0..2 {
        for j in 0..2 {
            a[i][j] += s * b[i][j];
        }
    }
}

// ---------------------------------------------------------------------------------------
// checks and the cutting geometry

fn check_inputs(tool: &Tool, cut: &Cut) -> Result<()> {
    if tool.teeth == 0 {
        return Err(Error::BadInput("the tool needs at least one tooth".into()));
    }
    if !(cut.radial_immersion > 0.0 && cut.radial_immersion <= 1.0) {
        return Err(Error::BadInput(format!(
            "radial immersion ae/D must be in (0, 1], got {}",
            cut.radial_immersion
        )));
    }
    if !(cut.kt > 0.0 && cut.kt.is_finite()) {
        return Err(Error::BadInput(format!(
            "the tangential cutting coefficient Kt must be positive [N/m²], got {}",
            cut.kt
        )));
    }
    if !cut.kr.is_finite() {
        return Err(Error::BadInput("the radial ratio Kr must be finite".into()));
    }
    if !(tool.helix_deg.is_finite() && tool.helix_deg.abs() < 89.0) {
        return Err(Error::BadInput(format!(
            "helix angle must be within ±89°, got {}",
            tool.helix_deg
        )));
    }
    if tool.helix_deg != 0.0 && !(tool.diameter_m > 0.0 && tool.diameter_m.is_finite()) {
        return Err(Error::BadInput(
            "a helical tool needs its diameter (diameter_m > 0) for the axial lag".into(),
        ));
    }
    Ok(())
}

fn check_rpm(rpm: &[f64]) -> Result<()> {
    if let Some(r) = rpm.iter().find(|r| !(**r > 0.0 && r.is_finite())) {
        return Err(Error::BadInput(format!(
            "spindle speeds must be positive and finite, got {r}"
        )));
    }
    Ok(())
}

/// Entry and exit angles `[φst, φex]` of the immersion.
fn engagement(cut: &Cut) -> (f64, f64) {
    let a = cut.radial_immersion;
    if cut.down_milling {
        ((2.0 * a - 1.0).clamp(-1.0, 1.0).acos(), PI)
    } else {
        (0.0, (1.0 - 2.0 * a).clamp(-1.0, 1.0).acos())
    }
}

/// `∫_a^b W(φ) dφ` of the per-tooth directional matrix.
fn w_integral(a: f64, b: f64, kr: f64) -> M2 {
    let prim = |p: f64| -> M2 {
        let (s2, c2) = (2.0 * p).sin_cos();
        [
            [
                0.25 * c2 - 0.5 * kr * (p - 0.5 * s2),
                -0.5 * (p + 0.5 * s2) + 0.25 * kr * c2,
            ],
            [
                0.5 * (p - 0.5 * s2) + 0.25 * kr * c2,
                -0.25 * c2 - 0.5 * kr * (p + 0.5 * s2),
            ],
        ]
    };
    let (pa, pb) = (prim(a), prim(b));
    let mut out = pb;
    m2_add(&mut out, &pa, -1.0);
    out
}

/// `∫ g(φ) W(φ) dφ` over the tooth angles `[alpha, beta]` (length ≤ 2π).
fn engaged_integral(alpha: f64, beta: f64, st: f64, ex: f64, kr: f64) -> M2 {
    let k = (alpha / (2.0 * PI)).floor();
    let (a, b) = (alpha - 2.0 * PI * k, beta - 2.0 * PI * k);
    let mut out = [[0.0; 2]; 2];
    for shift in [0.0, -2.0 * PI] {
        let lo = (a + shift).max(st);
        let hi = (b + shift).min(ex);
        if hi > lo {
            m2_add(&mut out, &w_integral(lo, hi, kr), 1.0);
        }
    }
    out
}

/// The average directional matrix `A0 = (1/τ) ∫_0^τ A(t) dt = (N/2π) ∫ g W dφ`.
pub fn average_directional_matrix(tool: &Tool, cut: &Cut) -> Result<[[f64; 2]; 2]> {
    check_inputs(tool, cut)?;
    let (st, ex) = engagement(cut);
    let mut a0 = w_integral(st, ex, cut.kr);
    let s = tool.teeth as f64 / (2.0 * PI);
    a0.iter_mut().flatten().for_each(|v| *v *= s);
    Ok(a0)
}

// ---------------------------------------------------------------------------------------
// the plant: the model's x–y block

/// Channel indices `[[xx, xy], [yx, yy]]` (cross channels optional).
fn xy_channels(model: &ModalModel) -> Result<[[Option<usize>; 2]; 2]> {
    if model.modes.is_empty() {
        return Err(Error::BadInput("the model has no modes".into()));
    }
    if !model.is_valid() {
        return Err(Error::BadInput(
            "the model has an unstable mode or non-finite coefficients; refit it first".into(),
        ));
    }
    let ax = [Axis::X, Axis::Y];
    let mut idx = [[None; 2]; 2];
    for o in 0..2 {
        for j in 0..2 {
            idx[o][j] = model.channel_index(Channel::new(ax[o], ax[j]));
        }
    }
    if idx[0][0].is_none() || idx[1][1].is_none() {
        let have: Vec<String> = model.channels.iter().map(|c| c.channel.name()).collect();
        return Err(Error::BadInput(format!(
            "stability lobes need the direct channels xx and yy (a zero yy is fine for a \
             one-axis study); the model has [{}]",
            have.join(", ")
        )));
    }
    Ok(idx)
}

/// `G(iω)` = `[[xx, xy], [yx, yy]]` including the residual compliance.
fn frf_matrix(model: &ModalModel, idx: &[[Option<usize>; 2]; 2], w: f64) -> [[Complex64; 2]; 2] {
    let s = Complex64::new(0.0, w);
    let mut g = [[Complex64::new(0.0, 0.0); 2]; 2];
    for o in 0..2 {
        for j in 0..2 {
            if let Some(ci) = idx[o][j] {
                g[o][j] = model.eval_s(ci, s);
            }
        }
    }
    g
}

/// One second-order state pair `(q, q̇)` driven by force axis `axis`.
#[derive(Debug, Clone, Copy)]
struct Pair {
    mode: Mode,
    axis: usize,
    /// `c[o] = [b0, b1]`: contribution of `(q, q̇)` to response `o`.
    c: [[f64; 2]; 2],
}

/// The modal state space of the x–y block. Pairs with no output are dropped; a
/// residual compliance `d` becomes a well-damped pseudo-mode ten times above the
/// highest mode (`b0 = d ω²`), as the delay equation with feedthrough would be neutral.
fn plant(model: &ModalModel, idx: &[[Option<usize>; 2]; 2]) -> Vec<Pair> {
    let mut pairs = Vec::new();
    for (k, mode) in model.modes.iter().enumerate() {
        for j in 0..2 {
            let mut c = [[0.0; 2]; 2];
            for o in 0..2 {
                if let Some(ci) = idx[o][j] {
                    let n = model.channels[ci].num[k];
                    c[o] = [n.b0, n.b1];
                }
            }
            if c.iter().flatten().any(|v| *v != 0.0) {
                pairs.push(Pair {
                    mode: *mode,
                    axis: j,
                    c,
                });
            }
        }
    }
    let wmax = model.modes.iter().map(|m| m.wn).fold(0.0, f64::max);
    let pseudo = Mode {
        wn: 10.0 * wmax,
        zeta: std::f64::consts::FRAC_1_SQRT_2,
    };
    for j in 0..2 {
        let mut c = [[0.0; 2]; 2];
        for o in 0..2 {
            if let Some(ci) = idx[o][j] {
                c[o][0] = model.channels[ci].d * pseudo.wn * pseudo.wn;
            }
        }
        if c.iter().flatten().any(|v| *v != 0.0) {
            pairs.push(Pair {
                mode: pseudo,
                axis: j,
                c,
            });
        }
    }
    pairs
}

// ---------------------------------------------------------------------------------------
// zero-order approximation

/// Eigenvalues of a complex 2×2 matrix.
fn eig2(m: &[[Complex64; 2]; 2]) -> [Complex64; 2] {
    let tr = m[0][0] + m[1][1];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let h = tr * 0.5;
    let r = (h * h - det).sqrt();
    [h + r, h - r]
}

/// Chatter frequency grid \[rad/s\]: geometric, fine enough for the lightest damping.
fn zoa_grid(model: &ModalModel) -> Vec<f64> {
    let wmin = model
        .modes
        .iter()
        .map(|m| m.wn)
        .fold(f64::INFINITY, f64::min);
    let wmax = model.modes.iter().map(|m| m.wn).fold(0.0, f64::max);
    let zmin = model
        .modes
        .iter()
        .map(|m| m.zeta)
        .fold(f64::INFINITY, f64::min)
        .clamp(1e-3, 0.2);
    let (lo, hi) = (0.5 * wmin, 2.0 * wmax);
    let mut ratio = 1.0 + zmin / 8.0;
    let mut n = ((hi / lo).ln() / ratio.ln()).ceil() as usize + 1;
    if n > 40_000 {
        n = 40_000;
        ratio = (hi / lo).powf(1.0 / (n - 1) as f64);
    }
    (0..n).map(|i| lo * ratio.powi(i as i32)).collect()
}

/// `n` spindle speeds from `lo` to `hi` rpm, log-spaced (`[lo]` when `n <= 1`): the grid
/// of `mtwin lobes`.
pub fn log_speeds(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![lo];
    }
    let r = (hi / lo).powf(1.0 / (n - 1) as f64);
    (0..n).map(|i| lo * r.powi(i as i32)).collect()
}

/// The tool-tip model of a lobe diagram: `model` with a rigid (zero) `xx` or `yy`
/// channel added where it has none, and the channels so added (for a note to the user).
pub fn with_rigid_tool_tip(mut model: ModalModel) -> (ModalModel, Vec<Channel>) {
    let mut added = Vec::new();
    for axis in [Axis::X, Axis::Y] {
        let ch = Channel::new(axis, axis);
        if model.channel_index(ch).is_none() {
            model.channels.push(crate::model::ChannelModel {
                channel: ch,
                num: vec![crate::model::ModeNum { b0: 0.0, b1: 0.0 }; model.modes.len()],
                d: 0.0,
            });
            added.push(ch);
        }
    }
    (model, added)
}

/// Zero-order (Altintas–Budak) stability lobes at the requested spindle speeds.
///
/// The chatter frequency is scanned from half the lowest to twice the highest mode
/// frequency; the two eigenvalue branches of `A0 G(iωc)` are tracked along it, every lobe
/// `k` is a curve `(rpm_k(ωc), ap(ωc))`, and `ap_lim(rpm)` is the minimum over all curve
/// segments passing `rpm` (linear interpolation between scan points).
pub fn lobes_zoa(
    model: &ModalModel,
    tool: &Tool,
    cut: &Cut,
    rpm: &[f64],
) -> Result<Vec<LobePoint>> {
    check_inputs(tool, cut)?;
    check_rpm(rpm)?;
    let idx = xy_channels(model)?;
    let a0 = average_directional_matrix(tool, cut)?;
    let nt = tool.teeth as f64;
    let mut out: Vec<LobePoint> = rpm
        .iter()
        .map(|&r| LobePoint {
            rpm: r,
            ap_lim_m: f64::INFINITY,
            chatter_hz: 0.0,
        })
        .collect();
    if rpm.is_empty() {
        return Ok(out);
    }
    let mut order: Vec<usize> = (0..rpm.len()).collect();
    order.sort_by(|&a, &b| rpm[a].total_cmp(&rpm[b]));
    let sorted: Vec<f64> = order.iter().map(|&i| rpm[i]).collect();
    let (nmin, nmax) = (sorted[0], sorted[sorted.len() - 1]);

    // the branch-tracked eigenvalues of A0 G(iω) at every scan frequency
    let grid = zoa_grid(model);
    let eig_at = |w: f64| -> [Complex64; 2] {
        let g = frf_matrix(model, &idx, w);
        let mut p = [[Complex64::new(0.0, 0.0); 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                p[i][j] = g[0][j] * a0[i][0] + g[1][j] * a0[i][1];
            }
        }
        eig2(&p)
    };
    let mut lams: Vec<[Complex64; 2]> = Vec::with_capacity(grid.len());
    for &w in &grid {
        let mut l = eig_at(w);
        if let Some(q) = lams.last() {
            let keep = (l[0] - q[0]).norm() + (l[1] - q[1]).norm();
            let swap = (l[1] - q[0]).norm() + (l[0] - q[1]).norm();
            if swap < keep {
                l.swap(0, 1);
            }
        }
        lams.push(l);
    }
    // (ap, ε) of an eigenvalue; None where Re λ ≤ 0 (no positive depth)
    let ap_eps = |lam: Complex64| -> Option<(f64, f64)> {
        (lam.re > 0.0 && lam.re.is_finite() && lam.im.is_finite()).then(|| {
            (
                1.0 / (2.0 * cut.kt * lam.re),
                PI + 2.0 * lam.im.atan2(lam.re),
            )
        })
    };
    let lobe_rpm = |w: f64, eps: f64, k: f64| 60.0 * w / (nt * (eps + 2.0 * PI * k));

    // one curve segment [wa, wb] of a branch with Re λ > 0 at both ends
    let mut process = |wa: f64, wb: f64, la: Complex64, lb: Complex64| {
        let (Some((_, ea)), Some((_, eb))) = (ap_eps(la), ap_eps(lb)) else {
            return;
        };
        // lobes k whose speed range may meet [nmin, nmax]
        let kmax = ((60.0 * wb / (nt * nmin) - ea.min(eb)) / (2.0 * PI)).ceil();
        let kmin = ((60.0 * wa / (nt * nmax) - ea.max(eb)) / (2.0 * PI)).floor();
        let (kmin, kmax) = (kmin.max(0.0) as usize, kmax.max(0.0) as usize);
        for k in kmin..=kmax {
            let kf = k as f64;
            let ra = lobe_rpm(wa, ea, kf);
            let rb = lobe_rpm(wb, eb, kf);
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            let start = sorted.partition_point(|&n| n < lo);
            for (s, &n) in sorted.iter().enumerate().skip(start) {
                if n > hi {
                    break;
                }
                // regula falsi (Illinois) in ω for rpm_k(ω) = n on this branch: the exact
                // point of the curve (near a resonance it bends too fast to interpolate)
                let (mut w0, mut w1, mut f0, mut f1) = (wa, wb, ra - n, rb - n);
                let (mut ap, mut wc) = (f64::INFINITY, 0.5 * (wa + wb));
                let mut ok = true;
                let mut side = 0i8;
                for _ in 0..100 {
                    let mut wm = if f1 != f0 {
                        (w0 * f1 - w1 * f0) / (f1 - f0)
                    } else {
                        0.5 * (w0 + w1)
                    };
                    if !(wm > w0.min(w1) && wm < w0.max(w1)) {
                        wm = 0.5 * (w0 + w1);
                    }
                    let t = (wm - wa) / (wb - wa);
                    let guess = la + (lb - la) * t;
                    let l = eig_at(wm);
                    let lm = if (l[0] - guess).norm() <= (l[1] - guess).norm() {
                        l[0]
                    } else {
                        l[1]
                    };
                    let Some((apm, em)) = ap_eps(lm) else {
                        ok = false;
                        break;
                    };
                    (ap, wc) = (apm, wm);
                    let fm = lobe_rpm(wm, em, kf) - n;
                    if fm.abs() <= 1e-10 * n || (w1 - w0).abs() < 1e-13 * wm {
                        break;
                    }
                    if (fm < 0.0) == (f0 < 0.0) {
                        (w0, f0) = (wm, fm);
                        if side == -1 {
                            f1 *= 0.5;
                        }
                        side = -1;
                    } else {
                        (w1, f1) = (wm, fm);
                        if side == 1 {
                            f0 *= 0.5;
                        }
                        side = 1;
                    }
                }
                let pt = &mut out[order[s]];
                if ok && ap < pt.ap_lim_m {
                    pt.ap_lim_m = ap;
                    pt.chatter_hz = wc / (2.0 * PI);
                }
            }
        }
    };
    let pick = |w: f64, guess: Complex64| {
        let l = eig_at(w);
        if (l[0] - guess).norm() <= (l[1] - guess).norm() {
            l[0]
        } else {
            l[1]
        }
    };
    for i in 0..grid.len().saturating_sub(1) {
        let (wa, wb) = (grid[i], grid[i + 1]);
        for b in 0..2 {
            let (la, lb) = (lams[i][b], lams[i + 1][b]);
            match (ap_eps(la).is_some(), ap_eps(lb).is_some()) {
                (true, true) => process(wa, wb, la, lb),
                (false, false) => {}
                (va, _) => {
                    // Re λ changes sign inside: the lobe's asymptote (ap → ∞). Find the
                    // edge, so the steep part next to it is not lost between samples.
                    let (mut good, mut bad) = if va { (wa, wb) } else { (wb, wa) };
                    let mut lg = if va { la } else { lb };
                    for _ in 0..50 {
                        let wm = 0.5 * (good + bad);
                        let t = (wm - wa) / (wb - wa);
                        let lm = pick(wm, la + (lb - la) * t);
                        if ap_eps(lm).is_some() {
                            (good, lg) = (wm, lm);
                        } else {
                            bad = wm;
                        }
                    }
                    if va {
                        process(wa, good, la, lg);
                    } else {
                        process(good, wb, lg, lb);
                    }
                }
            }
        }
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// semi-discretisation

/// One step of the period grid: length \[s\] and the unit directional average
/// (multiply by `ap Kt`), `None` in free flight.
#[derive(Debug, Clone, Copy)]
struct Step {
    h: f64,
    a: Option<M2>,
}

/// The period grid at one speed and depth (the depth only matters with a helix).
fn period_grid(tool: &Tool, cut: &Cut, rpm: f64, ap: f64, opts: &SdOptions) -> Vec<Step> {
    let (st, ex) = engagement(cut);
    let nt = tool.teeth;
    let pitch = 2.0 * PI / nt as f64;
    let omega = 2.0 * PI * rpm / 60.0;
    let lag = if tool.helix_deg != 0.0 {
        (2.0 * ap * tool.helix_deg.to_radians().tan() / tool.diameter_m).abs()
    } else {
        0.0
    };
    let slices = if lag > 0.0 {
        opts.helix_slices.max(1)
    } else {
        1
    };
    // lag of slice s (a negative helix just mirrors the lag direction; its magnitude is
    // what spreads the engagement, the sign only shifts the origin)
    let lags: Vec<f64> = (0..slices)
        .map(|s| lag * (s as f64 + 0.5) / slices as f64)
        .collect();
    let window = ex - st + lag;
    let m = opts.steps.max(2);
    let mut nodes: Vec<f64> = Vec::with_capacity(m + 2);
    if window >= pitch - 1e-12 {
        nodes.extend((0..=m).map(|i| st + pitch * i as f64 / m as f64));
    } else {
        nodes.extend((0..=m).map(|i| st + window * i as f64 / m as f64));
        nodes.push(st + pitch);
    }
    let mut steps = Vec::with_capacity(nodes.len() - 1);
    for i in 0..nodes.len() - 1 {
        let (ta, tb) = (nodes[i], nodes[i + 1]);
        let mut a = [[0.0; 2]; 2];
        for j in 0..nt {
            let off = pitch * j as f64;
            for &l in &lags {
                m2_add(
                    &mut a,
                    &engaged_integral(ta + off - l, tb + off - l, st, ex, cut.kr),
                    1.0,
                );
            }
        }
        let scale = 1.0 / ((tb - ta) * slices as f64);
        a.iter_mut().flatten().for_each(|v| *v *= scale);
        let engaged = a.iter().flatten().any(|v| *v != 0.0);
        steps.push(Step {
            h: (tb - ta) / omega,
            a: engaged.then_some(a),
        });
    }
    steps
}

/// The monodromy matrix over one tooth period (row-major, `na × na`).
///
/// State `z = [x (n); p_0 … p_{M−1}]`, `p_i` = the displacement at node `i` one period
/// earlier (outputs the model has no response in are left out). All `na` basis vectors are propagated at once as the columns of row vectors.
fn monodromy(pairs: &[Pair], steps: &[Step], apkt: f64) -> Result<(usize, Vec<f64>)> {
    let np = pairs.len();
    let n = 2 * np;
    let mm = steps.len();
    // only outputs the model actually has get a history (an SDOF study has no y)
    let active: Vec<usize> = (0..2)
        .filter(|&o| pairs.iter().any(|p| p.c[o] != [0.0, 0.0]))
        .collect();
    let no = active.len();
    let na = n + no * mm;
    let mut x = vec![0.0; n * na];
    for i in 0..n {
        x[i * na + i] = 1.0;
    }
    let out_r = |x: &[f64]| -> [Vec<f64>; 2] {
        let mut r = [vec![0.0; na], vec![0.0; na]];
        for (p, pr) in pairs.iter().enumerate() {
            let (q, v) = (&x[2 * p * na..(2 * p + 1) * na], &x[(2 * p + 1) * na..]);
            for o in 0..2 {
                let [cq, cv] = pr.c[o];
                if cq == 0.0 && cv == 0.0 {
                    continue;
                }
                for c in 0..na {
                    r[o][c] += cq * q[c] + cv * v[c];
                }
            }
        }
        r
    };
    let unit = |i: usize| -> [Vec<f64>; 2] {
        let mut p = [vec![0.0; na], vec![0.0; na]];
        for (a, &o) in active.iter().enumerate() {
            p[o][n + no * i + a] = 1.0;
        }
        p
    };
    let r0 = out_r(&x);
    let mut rs: Vec<[Vec<f64>; 2]> = Vec::with_capacity(mm);
    let mut r_cur = r0.clone();
    for (i, st) in steps.iter().enumerate() {
        let secs: Vec<SectionStep> = pairs
            .iter()
            .map(|p| SectionStep::new(&p.mode, st.h, Hold::Foh))
            .collect();
        // x ← Φ x
        for (p, s) in secs.iter().enumerate() {
            let (head, tail) = x.split_at_mut((2 * p + 1) * na);
            let q = &mut head[2 * p * na..];
            let v = &mut tail[..na];
            let f = s.phi;
            for c in 0..na {
                let (a, b) = (q[c], v[c]);
                q[c] = f[0][0] * a + f[0][1] * b;
                v[c] = f[1][0] * a + f[1][1] * b;
            }
        }
        if let Some(a) = st.a {
            let k = a.map(|row| row.map(|v| v * apkt));
            // δ_i = r_i − p_i, and the delayed value at the step's end
            let pi = unit(i);
            let pn = if i + 1 < mm { unit(i + 1) } else { r0.clone() };
            let mut u0 = [vec![0.0; na], vec![0.0; na]];
            let mut um = [vec![0.0; na], vec![0.0; na]];
            for o in 0..2 {
                for c in 0..na {
                    let d0 = r_cur[0][c] - pi[0][c];
                    let d1 = r_cur[1][c] - pi[1][c];
                    u0[o][c] = k[o][0] * d0 + k[o][1] * d1;
                    um[o][c] = k[o][0] * pn[0][c] + k[o][1] * pn[1][c];
                }
            }
            // w = Φx + G0 K δ_i − G1 K p_{i+1};  C G1 (2×2)
            let mut cg1 = [[0.0; 2]; 2];
            for (p, (s, pr)) in secs.iter().zip(pairs).enumerate() {
                let j = pr.axis;
                for o in 0..2 {
                    cg1[o][j] += pr.c[o][0] * s.g1[0] + pr.c[o][1] * s.g1[1];
                }
                for row in 0..2 {
                    let (g0, g1) = (s.g0[row], s.g1[row]);
                    let xr = &mut x[(2 * p + row) * na..(2 * p + row + 1) * na];
                    for c in 0..na {
                        xr[c] += g0 * u0[j][c] - g1 * um[j][c];
                    }
                }
            }
            // (I − C G1 K) r_{i+1} = C w
            let cw = out_r(&x);
            let mut mat = [[0.0; 2]; 2];
            for o in 0..2 {
                for j in 0..2 {
                    mat[o][j] = if o == j { 1.0 } else { 0.0 }
                        - (cg1[o][0] * k[0][j] + cg1[o][1] * k[1][j]);
                }
            }
            let det = mat[0][0] * mat[1][1] - mat[0][1] * mat[1][0];
            if det.abs() <= 1e-12 || !det.is_finite() {
                return Err(Error::Numerical(format!(
                    "semi-discretisation step is singular (det {det:e}); use more steps"
                )));
            }
            let inv = [
                [mat[1][1] / det, -mat[0][1] / det],
                [-mat[1][0] / det, mat[0][0] / det],
            ];
            let mut kr1 = [vec![0.0; na], vec![0.0; na]];
            for c in 0..na {
                let r1 = [
                    inv[0][0] * cw[0][c] + inv[0][1] * cw[1][c],
                    inv[1][0] * cw[0][c] + inv[1][1] * cw[1][c],
                ];
                for j in 0..2 {
                    kr1[j][c] = k[j][0] * r1[0] + k[j][1] * r1[1];
                }
            }
            // x = w + G1 K r_{i+1}
            for (p, (s, pr)) in secs.iter().zip(pairs).enumerate() {
                for row in 0..2 {
                    let g1 = s.g1[row];
                    let xr = &mut x[(2 * p + row) * na..(2 * p + row + 1) * na];
                    for c in 0..na {
                        xr[c] += g1 * kr1[pr.axis][c];
                    }
                }
            }
        }
        rs.push(std::mem::replace(&mut r_cur, out_r(&x)));
    }
    let mut u = x;
    u.reserve(no * mm * na);
    for r in &rs {
        for &o in &active {
            u.extend_from_slice(&r[o]);
        }
    }
    Ok((na, u))
}

/// Everything of a cutting condition that does not change with the depth of cut.
struct SdProblem {
    pairs: Vec<Pair>,
    tool: Tool,
    cut: Cut,
    opts: SdOptions,
}

impl SdProblem {
    fn new(model: &ModalModel, tool: &Tool, cut: &Cut, opts: &SdOptions) -> Result<Self> {
        check_inputs(tool, cut)?;
        if opts.steps < 2 || opts.steps > 2000 {
            return Err(Error::BadInput(format!(
                "semi-discretisation steps must be in [2, 2000], got {}",
                opts.steps
            )));
        }
        if !(opts.rel_tol > 0.0 && opts.rel_tol < 0.5) {
            return Err(Error::BadInput(format!(
                "relative tolerance must be in (0, 0.5), got {}",
                opts.rel_tol
            )));
        }
        let idx = xy_channels(model)?;
        let pairs = plant(model, &idx);
        if pairs.is_empty() {
            return Err(Error::BadInput(
                "the x–y block of the model is identically zero".into(),
            ));
        }
        Ok(SdProblem {
            pairs,
            tool: *tool,
            cut: *cut,
            opts: *opts,
        })
    }

    fn floquet(&self, rpm: f64, ap: f64) -> Result<Floquet> {
        let steps = period_grid(&self.tool, &self.cut, rpm, ap, &self.opts);
        let (na, mut u) = monodromy(&self.pairs, &steps, ap * self.cut.kt)?;
        if u.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "monodromy matrix is not finite; check the model and cutting data".into(),
            ));
        }
        balance(na, &mut u);
        // A QR deflation test relative to the diagonal struggles with the many (near-)zero
        // multipliers of the history: shift them away from zero by σ > ρ and shift back;
        // on a rare stall retry with another σ (the eigenvalues are the same).
        let bound = (0..na)
            .map(|i| u[i * na..(i + 1) * na].iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let mut eig = None;
        for sigma in [1.0 + bound, 0.5 + 1.37 * bound] {
            let mut m = u.clone();
            for i in 0..na {
                m[i * na + i] += sigma;
            }
            if let Some(e) = eigenvalues(na, &m) {
                eig = Some((e, sigma));
                break;
            }
            // fall back on nalgebra's Schur iteration
            let dm = DMatrix::from_row_slice(na, na, &m);
            if let Some(schur) = nalgebra::Schur::try_new(dm, f64::EPSILON, 300 * na) {
                eig = Some((schur.complex_eigenvalues().iter().copied().collect(), sigma));
                break;
            }
        }
        let (eig, sigma) = eig.ok_or_else(|| {
            Error::Numerical("eigenvalues of the monodromy did not converge".into())
        })?;
        let mut best = Complex64::new(0.0, 0.0);
        for e in eig.iter() {
            let e = *e - sigma;
            if e.norm() > best.norm() {
                best = e;
            }
        }
        Ok(Floquet {
            spectral_radius: best.norm(),
            multiplier: best,
        })
    }

    /// [`SdProblem::limit`], then a search for unstable islands below the limit (a lower
    /// lobe, e.g. a flip lobe or the tip of a tongue, that the bracketing from the ZOA
    /// guess jumped over): ρ at [`ISLAND_PROBES`] depths evenly below the limit; at every
    /// local maximum of ρ there (and at an unstable probe) the maximum of ρ is refined by
    /// golden section, and if it reaches 1 the limit is the first crossing below it. Near
    /// a tongue's tip the island is thin in depth but ρ's hump around it is wide, so the
    /// probes see the hump; the earlier guard (probes at 80 % and 50 %) missed such
    /// islands for some speeds next to the tip, and the limit jumped late.
    fn limit_guarded(&self, rpm: f64, guess: f64) -> Result<(f64, Floquet)> {
        let (mut ap, mut fl) = self.limit(rpm, guess)?;
        // a probe whose monodromy's eigenvalues do not converge tells nothing: NaN, never
        // a hump (the guard must not fail a limit the bracketing found)
        let rho = |a: f64| -> Result<f64> {
            Ok(self.floquet(rpm, a).map_or(f64::NAN, |f| f.spectral_radius))
        };
        'outer: for _ in 0..6 {
            if !ap.is_finite() || ap <= 0.0 {
                break;
            }
            let n = ISLAND_PROBES;
            let depths: Vec<f64> = (0..=n + 1)
                .map(|j| ap * j as f64 / (n + 1) as f64)
                .collect();
            let mut r = Vec::with_capacity(n + 2);
            // no cut, no regeneration: the free structure decays (ρ < 1)
            r.push(0.0);
            for &d in &depths[1..=n] {
                r.push(rho(d)?);
            }
            // ρ at the limit itself (≥ 1, the upper end of its bracket)
            r.push(fl.spectral_radius);
            for j in 1..=n {
                // a hump, or the probe next to the limit, where a hump may sit between
                // it and the limit (ρ dips after an island, then rises to the limit)
                let hump = r[j] >= r[j - 1] && (r[j] >= r[j + 1] || j == n);
                if !(r[j] >= 1.0 || (hump && r[j] > ISLAND_RHO_MIN)) {
                    continue;
                }
                // golden section for the maximum of ρ in (depths[j-1], depths[j+1])
                let (mut a, mut b) = (depths[j - 1], depths[j + 1]);
                let (mut best_d, mut best_r) = (depths[j], r[j]);
                let g = 0.5 * (5f64.sqrt() - 1.0);
                let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
                let (mut rc, mut rd) = (rho(c)?, rho(d)?);
                for _ in 0..30 {
                    // an island thinner than this near its tip shifts the tip by a hair
                    if best_r >= 1.0 || (b - a) <= ISLAND_DEPTH_TOL * ap {
                        break;
                    }
                    if rc > best_r {
                        (best_d, best_r) = (c, rc);
                    }
                    if rd > best_r {
                        (best_d, best_r) = (d, rd);
                    }
                    if best_r >= 1.0 {
                        break;
                    }
                    if rc >= rd {
                        (b, d, rd) = (d, c, rc);
                        c = b - g * (b - a);
                        rc = rho(c)?;
                    } else {
                        (a, c, rc) = (c, d, rd);
                        d = a + g * (b - a);
                        rd = rho(d)?;
                    }
                }
                if best_r >= 1.0 {
                    // the first crossing between the last stable probe below and it
                    let lo = if r[j - 1] < 1.0 { depths[j - 1] } else { 0.0 };
                    let (a2, f2) = self.crossing(rpm, lo, best_d)?;
                    if a2 < ap * (1.0 - ISLAND_DEPTH_TOL) {
                        (ap, fl) = (a2, f2);
                        continue 'outer;
                    }
                }
            }
            break;
        }
        Ok((ap, fl))
    }

    /// `ln ρ` at `ap` with the Floquet result.
    fn ln_rho(&self, rpm: f64, ap: f64) -> Result<(f64, Floquet)> {
        let fl = self.floquet(rpm, ap)?;
        Ok((fl.spectral_radius.max(1e-300).ln(), fl))
    }

    /// The first depth in `(lo, hi]` where ρ reaches 1, with ρ(`lo`) < 1 ≤ ρ(`hi`), by
    /// Illinois regula falsi on ln ρ (a crossing of a bracket, never outside it).
    fn crossing(&self, rpm: f64, lo: f64, hi: f64) -> Result<(f64, Floquet)> {
        // at zero depth the free structure decays: ln ρ < 0 (not computed: its
        // monodromy is the one whose eigenvalues may not converge)
        let flo = if lo > 0.0 {
            self.ln_rho(rpm, lo)?.0
        } else {
            -1.0
        };
        let (fhi, fl_hi) = self.ln_rho(rpm, hi)?;
        self.illinois(rpm, (lo, flo), (hi, fhi, fl_hi))
    }

    /// Illinois regula falsi on `ln ρ(ap)` inside the bracket `lo` (ln ρ < 0) .. `hi`
    /// (ln ρ ≥ 0, with its Floquet result) to `opts.rel_tol`: the upper end's depth
    /// and result.
    fn illinois(
        &self,
        rpm: f64,
        (mut lo, mut flo): (f64, f64),
        (mut hi, mut fhi, mut fl_hi): (f64, f64, Floquet),
    ) -> Result<(f64, Floquet)> {
        let mut side = 0i8;
        for _ in 0..60 {
            if hi - lo <= self.opts.rel_tol * hi {
                break;
            }
            let mut c = (lo * fhi - hi * flo) / (fhi - flo);
            if !(c > lo && c < hi) {
                c = 0.5 * (lo + hi);
            }
            let (fc, flc) = self.ln_rho(rpm, c)?;
            if fc < 0.0 {
                (lo, flo) = (c, fc);
                if side == -1 {
                    fhi *= 0.5;
                }
                side = -1;
            } else {
                (hi, fhi, fl_hi) = (c, fc, flc);
                if side == 1 {
                    flo *= 0.5;
                }
                side = 1;
            }
        }
        Ok((0.5 * (lo + hi), fl_hi))
    }

    /// The smallest unstable depth near `guess` by bracketing and Illinois on ln ρ.
    fn limit(&self, rpm: f64, guess: f64) -> Result<(f64, Floquet)> {
        let f = |ap: f64| self.ln_rho(rpm, ap);
        let start = if guess.is_finite() && guess > 0.0 {
            guess
        } else {
            1e-3
        };
        let mut a0 = start;
        let (mut lo, mut flo, mut hi, mut fhi, mut fl_hi);
        let (fa, fla) = f(a0)?;
        if fa < 0.0 {
            (lo, flo) = (a0, fa);
            // SD and ZOA mostly agree within ±20 %: a tight first step, then doubling
            let mut factor = 1.25;
            loop {
                a0 *= factor;
                factor = 2.0;
                let (fb, flb) = f(a0)?;
                if fb >= 0.0 {
                    (hi, fhi, fl_hi) = (a0, fb, flb);
                    break;
                }
                (lo, flo) = (a0, fb);
                if a0 > 1e3 * start {
                    return Ok((f64::INFINITY, flb));
                }
            }
        } else {
            (hi, fhi, fl_hi) = (a0, fa, fla);
            let mut factor = 0.8;
            loop {
                a0 *= factor;
                factor = 0.5;
                let (fb, flb) = f(a0)?;
                if fb < 0.0 {
                    (lo, flo) = (a0, fb);
                    break;
                }
                (hi, fhi, fl_hi) = (a0, fb, flb);
                if a0 < 1e-9 * start {
                    return Ok((0.0, flb));
                }
            }
        }
        self.illinois(rpm, (lo, flo), (hi, fhi, fl_hi))
    }
}

/// Chatter frequency of a multiplier `μ` at tooth period `tau`: the alias
/// `(±arg μ / 2π + k)/τ` closest to `near_hz`.
fn chatter_from_multiplier(mu: Complex64, tau: f64, near_hz: f64) -> f64 {
    let th = mu.arg().abs() / (2.0 * PI);
    let ft = 1.0 / tau;
    let mut best = th * ft;
    for sign in [1.0, -1.0] {
        let base = sign * th;
        let k = (near_hz / ft - base).round();
        for kk in [k - 1.0, k, k + 1.0] {
            let f = (base + kk) * ft;
            if f > 0.0 && (f - near_hz).abs() < (best - near_hz).abs() {
                best = f;
            }
        }
    }
    best
}

/// Floquet analysis of one cutting condition by the semi-discretisation.
pub fn floquet_sd(
    model: &ModalModel,
    tool: &Tool,
    cut: &Cut,
    rpm: f64,
    ap: f64,
    opts: &SdOptions,
) -> Result<Floquet> {
    check_rpm(&[rpm])?;
    if !(ap >= 0.0 && ap.is_finite()) {
        return Err(Error::BadInput(format!(
            "depth of cut must be ≥ 0, got {ap}"
        )));
    }
    SdProblem::new(model, tool, cut, opts)?.floquet(rpm, ap)
}

/// Is the cut at `rpm`, depth `ap` \[m\] stable? Returns `(stable, spectral radius)` by the
/// semi-discretisation with default [`SdOptions`].
pub fn stable_sd(
    model: &ModalModel,
    tool: &Tool,
    cut: &Cut,
    rpm: f64,
    ap: f64,
) -> Result<(bool, f64)> {
    let f = floquet_sd(model, tool, cut, rpm, ap, &SdOptions::default())?;
    Ok((f.spectral_radius < 1.0, f.spectral_radius))
}

/// Semi-discretisation stability lobes at the requested spindle speeds (parallel over
/// speeds). Each limit is the first depth where the spectral radius reaches 1, found by
/// bracketing from the ZOA limit and regula falsi on `ln ρ(ap)` to `opts.rel_tol`, then
/// searched below for unstable islands (ρ at 8 depths under the limit, each hump of ρ
/// above 0.99 refined by golden section; an island found gives the limit at its lower
/// edge, and the search repeats below it). Then continuity across neighbouring speeds: where
/// the next lower or higher speed's limit lies more than 1 % below a speed's own and the
/// cut is unstable 1 % above that depth at this speed too, the search runs again from
/// there, so a lobe present at both speeds is found at both (repeated while limits
/// change, at most 4 times).
/// The chatter frequency is the alias of the critical multiplier's phase closest to the
/// ZOA chatter frequency (a flip multiplier gives an odd multiple of half the tooth
/// passing frequency).
pub fn lobes_sd(
    model: &ModalModel,
    tool: &Tool,
    cut: &Cut,
    rpm: &[f64],
    opts: &SdOptions,
) -> Result<Vec<LobePoint>> {
    check_rpm(rpm)?;
    let prob = SdProblem::new(model, tool, cut, opts)?;
    let zoa = lobes_zoa(model, tool, cut, rpm)?;
    let near_default = model.modes.iter().map(|m| m.freq_hz()).fold(0.0, f64::max);
    let mut lim: Vec<(f64, Floquet)> = zoa
        .par_iter()
        .map(|z| prob.limit_guarded(z.rpm, z.ap_lim_m))
        .collect::<Result<_>>()?;
    // Continuity across neighbouring speeds: a limit well below this speed's, found at
    // the next lower or higher speed, is looked for here too (one spectral radius just
    // above it; where unstable, the search from there, islands below included), so a
    // lobe is not lost between two speeds that both cross it. A limit that stays
    // different is a new lobe's tip between them.
    let mut order: Vec<usize> = (0..rpm.len()).collect();
    order.sort_by(|&a, &b| rpm[a].total_cmp(&rpm[b]));
    for _ in 0..4 {
        let found: Vec<Option<(f64, Floquet)>> = (0..order.len())
            .into_par_iter()
            .map(|p| {
                let i = order[p];
                let mut best: Option<(f64, Floquet)> = None;
                for q in [p.checked_sub(1), Some(p + 1)].into_iter().flatten() {
                    let Some(&j) = order.get(q) else { continue };
                    let (aj, ai) = (lim[j].0, best.map_or(lim[i].0, |b| b.0));
                    if !(aj.is_finite() && aj > 0.0 && aj < ai * (1.0 - ISLAND_DEPTH_TOL)) {
                        continue;
                    }
                    // unstable here just above the neighbour's limit: the lobe is here
                    // too, its lower edge below (a probe that does not converge says
                    // nothing)
                    let probe = aj * (1.0 + ISLAND_DEPTH_TOL);
                    if probe >= ai
                        || prob
                            .floquet(rpm[i], probe)
                            .map_or(true, |f| f.spectral_radius < 1.0)
                    {
                        continue;
                    }
                    let (a, f) = prob.limit_guarded(rpm[i], probe)?;
                    if a < ai * (1.0 - ISLAND_DEPTH_TOL) {
                        best = Some((a, f));
                    }
                }
                Ok(best)
            })
            .collect::<Result<_>>()?;
        let mut changed = false;
        for (i, f) in found
            .into_iter()
            .enumerate()
            .filter_map(|(p, f)| Some((order[p], f?)))
        {
            lim[i] = f;
            changed = true;
        }
        if !changed {
            break;
        }
    }
    Ok(zoa
        .iter()
        .zip(lim)
        .map(|(z, (ap, fl))| {
            let tau = 60.0 / (z.rpm * tool.teeth as f64);
            let near = if z.chatter_hz > 0.0 {
                z.chatter_hz
            } else {
                near_default
            };
            LobePoint {
                rpm: z.rpm,
                ap_lim_m: ap,
                chatter_hz: if ap.is_finite() {
                    chatter_from_multiplier(fl.multiplier, tau, near)
                } else {
                    0.0
                },
            }
        })
        .collect())
}

/// Writes a lobe diagram as CSV (atomically): `rpm, ap_lim_zoa_m, ap_lim_sd_m,
/// chatter_hz_zoa, chatter_hz_sd`. Both lists must hold the same speeds; either may be
/// empty, and its two columns are then left out (no column is ever empty): ZOA alone
/// is `rpm, ap_lim_zoa_m, chatter_hz_zoa`, SD alone `rpm, ap_lim_sd_m, chatter_hz_sd`.
/// A limit with no chatter found is written `inf` (its chatter frequency 0).
pub fn write_lobes_csv(path: &Path, zoa: &[LobePoint], sd: &[LobePoint]) -> Result<()> {
    let n = zoa.len().max(sd.len());
    if !zoa.is_empty() && !sd.is_empty() {
        if zoa.len() != sd.len() {
            return Err(Error::BadInput(format!(
                "ZOA and SD lobes differ in length ({} vs {})",
                zoa.len(),
                sd.len()
            )));
        }
        if let Some((a, b)) = zoa
            .iter()
            .zip(sd)
            .find(|(a, b)| (a.rpm - b.rpm).abs() > 1e-9 * a.rpm.abs())
        {
            return Err(Error::BadInput(format!(
                "ZOA and SD lobes are at different speeds ({} vs {} rpm)",
                a.rpm, b.rpm
            )));
        }
    }
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            "inf".to_string()
        }
    };
    let (has_z, has_d) = (!zoa.is_empty(), !sd.is_empty());
    let mut header = vec!["rpm"];
    header.extend(has_z.then_some("ap_lim_zoa_m"));
    header.extend(has_d.then_some("ap_lim_sd_m"));
    header.extend(has_z.then_some("chatter_hz_zoa"));
    header.extend(has_d.then_some("chatter_hz_sd"));
    let mut s = header.join(",");
    s.push('\n');
    for i in 0..n {
        let (z, d) = (zoa.get(i), sd.get(i));
        let rpm = z.or(d).map(|p| p.rpm).unwrap_or(0.0);
        let mut row = vec![rpm.to_string()];
        row.extend(z.map(|p| num(p.ap_lim_m)));
        row.extend(d.map(|p| num(p.ap_lim_m)));
        row.extend(z.map(|p| num(p.chatter_hz)));
        row.extend(d.map(|p| num(p.chatter_hz)));
        s.push_str(&row.join(","));
        s.push('\n');
    }
    crate::atomic::write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slotting_average_matches_altintas() {
        // Altintas: slotting A0 = (N/2π)·½·[[−Kr π, −π], [π, −Kr π]] (his ½ absorbed).
        let tool = Tool {
            teeth: 4,
            diameter_m: 0.01,
            helix_deg: 0.0,
        };
        let cut = Cut {
            radial_immersion: 1.0,
            down_milling: true,
            kt: 1e9,
            kr: 0.3,
        };
        let a0 = average_directional_matrix(&tool, &cut).unwrap();
        let e = [[-0.3 * 1.0, -1.0], [1.0, -0.3]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((a0[i][j] - e[i][j]).abs() < 1e-12, "{a0:?}");
            }
        }
    }

    #[test]
    fn grid_average_equals_a0() {
        // the step averages of a period grid integrate to the average matrix
        for (ai, down, helix) in [(1.0, true, 0.0), (0.05, true, 0.0), (0.3, false, 30.0)] {
            let tool = Tool {
                teeth: 3,
                diameter_m: 0.012,
                helix_deg: helix,
            };
            let cut = Cut {
                radial_immersion: ai,
                down_milling: down,
                kt: 1e9,
                kr: 0.3,
            };
            let steps = period_grid(&tool, &cut, 6000.0, 0.004, &SdOptions::default());
            let tau: f64 = steps.iter().map(|s| s.h).sum();
            assert!((tau - 60.0 / 18000.0).abs() < 1e-15);
            let mut avg = [[0.0; 2]; 2];
            for s in &steps {
                if let Some(a) = s.a {
                    m2_add(&mut avg, &a, s.h / tau);
                }
            }
            let a0 = average_directional_matrix(&tool, &cut).unwrap();
            for i in 0..2 {
                for j in 0..2 {
                    assert!((avg[i][j] - a0[i][j]).abs() < 1e-12, "{avg:?} vs {a0:?}");
                }
            }
        }
    }
}
