//! Nonlinear refinement of the true weighted error `Σ |W (H − F)|²` by
//! Levenberg–Marquardt over the modes `(ln ω, ln ζ)` with the linear numerators
//! eliminated (variable projection, Kaufman's Jacobian).
//!
//! For fixed modes every channel is a linear least-squares problem in the modal basis
//! `s/den_k(s)`, `1/den_k(s)`, `1`; its residual `r = (I − QQᵀ) y` depends on the modes
//! only. The Jacobian of `r` with respect to one mode parameter is approximated by
//! `−(I − QQᵀ) (∂A/∂θ) x`, which keeps the exact Gauss–Newton direction at the optimum
//! and needs one QR per channel per iteration — or, when the channel's design matrix is
//! well conditioned, one Gram matrix (see `linalg`), about five times cheaper. The Gram
//! matrices are first taken from partial-fraction sums without forming the design at all
//! ([`super::pf_gram`]); the design (Gram, then QR) is the fallback.

use super::data::Prepared;
use super::pf_gram::{self, PfGram};
use crate::linalg::{lstsq, ScaledGram, Tall};
use crate::model::Mode;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Result of a linear solve or a refinement.
#[derive(Debug, Clone)]
pub(crate) struct Solved {
    /// Modes in scaled units.
    pub modes: Vec<Mode>,
    /// Per channel `[b1_0, b0_0, …, d]` in the scaled basis.
    pub coefs: Vec<Vec<f64>>,
    /// Weighted squared error Σ w² |h − model|² (scaled units).
    pub cost: f64,
    /// Levenberg–Marquardt iterations taken.
    pub iterations: usize,
}

/// The lines of one channel's design rows and `1/den` of every mode on them
/// (`inv_den[i * modes + j]`; the Jacobian reuses them).
struct Rows {
    lines: Vec<usize>,
    inv_den: Vec<Complex64>,
}

/// The real-form design matrix (with its transpose) and weighted data of one channel
/// (rows of lines with positive weight: real parts then imaginary parts interleaved).
fn design(p: &Prepared, ci: usize, modes: &[Mode]) -> (Tall, DVector<f64>, Rows) {
    let lines = p.fitted[ci].clone();
    let m = 2 * modes.len() + 1;
    let mut a = Tall::zeros(lines.len(), m);
    let mut y = DVector::<f64>::zeros(2 * lines.len());
    let mut inv_den = Vec::with_capacity(lines.len() * modes.len());
    for (i, &k) in lines.iter().enumerate() {
        let w = p.w[ci][k];
        let s = p.s[k];
        for (j, md) in modes.iter().enumerate() {
            let inv = 1.0 / md.den(s);
            inv_den.push(inv);
            let inv = inv * w;
            a.set(i, 2 * j, s * inv);
            a.set(i, 2 * j + 1, inv);
        }
        a.set(i, m - 1, Complex64::new(w, 0.0));
        let hw = p.h[ci][k] * w;
        y[2 * i] = hw.re;
        y[2 * i + 1] = hw.im;
    }
    (a, y, Rows { lines, inv_den })
}

/// `V = (∂A/∂θ) x` of one channel (with its transpose): two columns per mode (`ln ω`,
/// `ln ζ`), rows as in [`design`].
fn derivatives(p: &Prepared, ci: usize, modes: &[Mode], rows: &Rows, x: &[f64]) -> Tall {
    let n = modes.len();
    let mut v = Tall::zeros(rows.lines.len(), 2 * n);
    for (i, &k) in rows.lines.iter().enumerate() {
        let w = p.w[ci][k];
        let s = p.s[k];
        for (j, md) in modes.iter().enumerate() {
            let inv = rows.inv_den[i * n + j];
            let num = s * x[2 * j] + x[2 * j + 1];
            let g = -(num * w) * (inv * inv);
            let [dw, dz] = md.den_log_derivatives(s);
            v.set(i, 2 * j, g * dw);
            v.set(i, 2 * j + 1, g * dz);
        }
    }
    v
}

/// Numerators for fixed modes (linear least squares per channel) and the cost.
pub(crate) fn solve_linear(p: &Prepared, modes: &[Mode]) -> Option<Solved> {
    let mut coefs = Vec::with_capacity(p.channels.len());
    let mut cost = 0.0;
    for ci in 0..p.channels.len() {
        let (a, y, _) = design(p, ci, modes);
        if a.a.nrows() == 0 {
            coefs.push(vec![0.0; a.a.ncols()]);
            continue;
        }
        let gram = if a.a.nrows() >= a.a.ncols() {
            ScaledGram::new(&a).map(|g| g.solve(&a, &y))
        } else {
            None
        };
        let (x, r) = match gram {
            Some((x, r)) if x.iter().all(|v| v.is_finite()) => (x, r),
            _ => {
                let x = lstsq(&a.a, &y)?;
                let r = &y - &a.a * &x;
                (x, r)
            }
        };
        a.release();
        cost += r.norm_squared();
        coefs.push(x.iter().copied().collect());
    }
    Some(Solved {
        modes: modes.to_vec(),
        coefs,
        cost,
        iterations: 0,
    })
}

/// One channel's part of [`evaluate`]: numerators `x`, cost, `JᵀJ`, `Jᵀr`.
type ChannelSystem = (Vec<f64>, f64, DMatrix<f64>, DVector<f64>);

/// [`evaluate`] for one channel through the Gram matrix (normal equations with one
/// refinement step): `Jᵀr = −Vᵀr` (the residual is orthogonal to the range of A) and
/// `JᵀJ = VᵀV − (L⁻¹ D⁻¹ AᵀV)ᵀ(L⁻¹ D⁻¹ AᵀV)`. `None` when the design matrix is too
/// ill-conditioned for it or the projected Jacobian loses its precision to cancellation.
fn channel_gram(
    p: &Prepared,
    ci: usize,
    modes: &[Mode],
    a: &Tall,
    y: &DVector<f64>,
    rows: &Rows,
) -> Option<ChannelSystem> {
    let g = ScaledGram::new(a)?;
    let (x, r) = g.solve(a, y);
    let x: Vec<f64> = x.iter().copied().collect();
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let v = derivatives(p, ci, modes, rows, &x);
    let Some(jtj) = projected_jtj(&g, &v.at * &v.a, &a.at * &v.a) else {
        v.release();
        return None;
    };
    let jtr = -(&v.at * &r);
    v.release();
    Some((x, r.norm_squared(), jtj, jtr))
}

/// `JᵀJ = VᵀV − (L⁻¹ D⁻¹ AᵀV)ᵀ(L⁻¹ D⁻¹ AᵀV)` from the scaled Gram factorisation `g` of `A`.
/// `None` when the projected part keeps less than 1e-6 of a derivative column (its
/// precision lost to cancellation) or the triangular solve fails.
fn projected_jtj(g: &ScaledGram, vtv: DMatrix<f64>, mut atv: DMatrix<f64>) -> Option<DMatrix<f64>> {
    for (i, d) in g.d.iter().enumerate() {
        atv.row_mut(i).unscale_mut(*d);
    }
    let z = g.chol.l().solve_lower_triangular(&atv)?;
    let jtj = &vtv - z.transpose() * &z;
    (0..jtj.nrows())
        .all(|i| jtj[(i, i)] >= 1e-6 * vtv[(i, i)])
        .then_some(jtj)
}

/// [`evaluate`] for one channel without its design matrix: the Gram matrices `AᵀA`,
/// `AᵀV`, `VᵀV` from partial-fraction sums ([`super::pf_gram`]; poles `q` of
/// [`pf_gram::mode_poles`]), the numerators (normal equations with one refinement
/// step), the residual and `Vᵀr` from passes over the lines; otherwise as
/// [`channel_gram`], with the same guards. `None` when the caller should form the design.
fn channel_pf(p: &Prepared, ci: usize, modes: &[Mode], q: &[Complex64]) -> Option<ChannelSystem> {
    use crate::lanes::sum;
    let n = modes.len();
    let m = 2 * n + 1;
    let lines = &p.fitted[ci];
    let nl = lines.len();
    // the fitted lines (s = jy), weights, weighted data
    let y: Vec<f64> = lines.iter().map(|&k| p.s[k].im).collect();
    let w: Vec<f64> = lines.iter().map(|&k| p.w[ci][k]).collect();
    let v: Vec<f64> = w.iter().map(|w| w * w).collect();
    let hr: Vec<f64> = lines.iter().map(|&k| p.h[ci][k].re * p.w[ci][k]).collect();
    let hi: Vec<f64> = lines.iter().map(|&k| p.h[ci][k].im * p.w[ci][k]).collect();
    let pg = PfGram::new(&y, &v, q)?;
    let acols = pf_gram::basis_columns(q);
    let g = ScaledGram::of_gram(pg.gram(&acols))?;
    // 1/den of every mode on the lines, mode by mode (re, im)
    let inv: Vec<(Vec<f64>, Vec<f64>)> = modes
        .iter()
        .map(|md| {
            y.iter()
                .map(|&yk| {
                    // conj(den)/|den|²: one division
                    let d = md.den(Complex64::new(0.0, yk));
                    let r = 1.0 / d.norm_sqr();
                    (d.re * r, -d.im * r)
                })
                .unzip()
        })
        .collect();
    // Aᵀe of a weighted residual e = (re, im): Re(conj(w φ) e), φ = s/den, 1/den, 1
    let at_of = |er: &[f64], ei: &[f64]| -> DVector<f64> {
        let mut out = DVector::<f64>::zeros(m);
        for (j, (ir, ii)) in inv.iter().enumerate() {
            // conj(1/den) e w = f, Re(conj(s) f) = y Im f
            let [a, b] = sum(nl, |k| {
                let (fr, fi) = (ir[k] * er[k] + ii[k] * ei[k], ir[k] * ei[k] - ii[k] * er[k]);
                [w[k] * y[k] * fi, w[k] * fr]
            });
            out[2 * j] = a;
            out[2 * j + 1] = b;
        }
        out[m - 1] = sum(nl, |k| [w[k] * er[k]])[0];
        out
    };
    // weighted residual w (h − model) at the numerators x
    let resid = |x: &DVector<f64>| -> (Vec<f64>, Vec<f64>) {
        let mut mr = vec![x[m - 1]; nl];
        let mut mi = vec![0.0; nl];
        for (j, (ir, ii)) in inv.iter().enumerate() {
            let (x0, x1) = (x[2 * j], x[2 * j + 1]);
            for k in 0..nl {
                // (x1 + j y x0) / den
                let (nr, ni) = (x1, y[k] * x0);
                mr[k] += nr * ir[k] - ni * ii[k];
                mi[k] += nr * ii[k] + ni * ir[k];
            }
        }
        for k in 0..nl {
            mr[k] = hr[k] - w[k] * mr[k];
            mi[k] = hi[k] - w[k] * mi[k];
        }
        (mr, mi)
    };
    let mut x = g.solve_normal(&at_of(&hr, &hi));
    let (r0, i0) = resid(&x);
    x += g.solve_normal(&at_of(&r0, &i0));
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let (rr, ri) = resid(&x);
    let x: Vec<f64> = x.iter().copied().collect();
    let vcols = pf_gram::derivative_columns(modes, q, &x);
    let jtj = projected_jtj(&g, pg.gram(&vcols), pg.cross(&acols, &vcols))?;
    // Jᵀr = −Vᵀr, V as in [`derivatives`]: g ∂den/∂θ with g = −w num/den²
    let mut jtr = DVector::<f64>::zeros(2 * n);
    for (j, (md, (ir, ii))) in modes.iter().zip(&inv).enumerate() {
        let (x0, x1) = (x[2 * j], x[2 * j + 1]);
        let [a, b] = sum(nl, |k| {
            let s = Complex64::new(0.0, y[k]);
            let iv = Complex64::new(ir[k], ii[k]);
            let gr = (-(s * x0 + x1) * w[k] * (iv * iv)).conj() * Complex64::new(rr[k], ri[k]);
            md.den_log_derivatives(s).map(|d| (d.conj() * gr).re)
        });
        jtr[2 * j] = -a;
        jtr[2 * j + 1] = -b;
    }
    let cost = sum(nl, |k| [rr[k] * rr[k] + ri[k] * ri[k]])[0];
    Some((x, cost, jtj, jtr))
}

/// [`evaluate`] for one channel through the Householder QR of the column-scaled design
/// matrix (the robust path).
fn channel_qr(
    p: &Prepared,
    ci: usize,
    modes: &[Mode],
    a: DMatrix<f64>,
    y: &DVector<f64>,
    rows: &Rows,
) -> Option<ChannelSystem> {
    let m = a.ncols();
    let np = 2 * modes.len();
    // column scaling for the QR, undone on x
    let mut asc = a;
    let mut cs = vec![1.0; m];
    for (j, c) in cs.iter_mut().enumerate() {
        let nrm = asc.column(j).norm();
        if nrm > 0.0 && nrm.is_finite() {
            *c = 1.0 / nrm;
            asc.column_mut(j).scale_mut(*c);
        }
    }
    let qr = asc.qr();
    let mut qty = y.clone();
    qr.q_tr_mul(&mut qty);
    let r = qr.r();
    let xs = r.solve_upper_triangular(&qty.rows(0, m).into_owned())?;
    let x: Vec<f64> = xs.iter().zip(&cs).map(|(v, c)| v * c).collect();
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // [V | y]: applying the QR's reflections gives, below row m, the parts orthogonal
    // to the range of A: P V and P y = r (no explicit Q).
    let n_rows = y.len();
    let mut vy = DMatrix::<f64>::zeros(n_rows, np + 1);
    let v = derivatives(p, ci, modes, rows, &x);
    vy.columns_mut(0, np).copy_from(&v.a);
    v.release();
    vy.column_mut(np).copy_from(y);
    qr.q_tr_mul(&mut vy);
    let tail = vy.rows(m, n_rows - m);
    let pv = tail.columns(0, np);
    let res = tail.column(np);
    // J = -PV, Jᵀr = -(PV)ᵀ r
    Some((x, res.norm_squared(), pv.tr_mul(&pv), -pv.tr_mul(&res)))
}

/// Cost, coefficients, and the Gauss–Newton system `(JᵀJ, Jᵀr)` at `modes`.
fn evaluate(p: &Prepared, modes: &[Mode]) -> Option<(Solved, DMatrix<f64>, DVector<f64>)> {
    let n = modes.len();
    let np = 2 * n;
    let mut jtj = DMatrix::<f64>::zeros(np, np);
    let mut jtr = DVector::<f64>::zeros(np);
    let mut coefs = Vec::with_capacity(p.channels.len());
    let mut cost = 0.0;
    let q = pf_gram::mode_poles(modes);
    for ci in 0..p.channels.len() {
        let m = 2 * n + 1;
        if 2 * p.fitted[ci].len() < m {
            coefs.push(vec![0.0; m]);
            continue;
        }
        if let Some((x, c, j2, r2)) = q.as_ref().and_then(|q| channel_pf(p, ci, modes, q)) {
            cost += c;
            jtj += j2;
            jtr += r2;
            coefs.push(x);
            continue;
        }
        let (a, y, rows) = design(p, ci, modes);
        let (x, c, j2, r2) = match channel_gram(p, ci, modes, &a, &y, &rows) {
            Some(sys) => {
                a.release();
                sys
            }
            None => channel_qr(p, ci, modes, a.into_a(), &y, &rows)?,
        };
        cost += c;
        jtj += j2;
        jtr += r2;
        coefs.push(x);
    }
    Some((
        Solved {
            modes: modes.to_vec(),
            coefs,
            cost,
            iterations: 0,
        },
        jtj,
        jtr,
    ))
}

const LN_ZETA_MIN: f64 = -11.5; // ζ ≥ 1e-5
const LN_ZETA_MAX: f64 = 3.0; // ζ ≤ 20
const LN_W_MIN: f64 = -9.2; // ω ≥ 1e-4 × band top
const LN_W_MAX: f64 = 4.6; // ω ≤ 100 × band top

fn to_theta(modes: &[Mode]) -> Vec<f64> {
    modes
        .iter()
        .flat_map(|m| [m.wn.ln(), m.zeta.ln()])
        .collect()
}

fn from_theta(t: &[f64]) -> Vec<Mode> {
    t.chunks(2)
        .map(|c| Mode {
            wn: c[0].clamp(LN_W_MIN, LN_W_MAX).exp(),
            zeta: c[1].clamp(LN_ZETA_MIN, LN_ZETA_MAX).exp(),
        })
        .collect()
}

/// Levenberg–Marquardt from `start` (stable modes, scaled units). Never returns a
/// worse cost than the linear solve at `start`.
pub(crate) fn refine(p: &Prepared, start: &[Mode], max_iter: usize) -> Option<Solved> {
    let start: Vec<Mode> = start
        .iter()
        .map(|m| Mode {
            wn: m.wn.clamp(LN_W_MIN.exp(), LN_W_MAX.exp()),
            zeta: m.zeta.clamp(LN_ZETA_MIN.exp(), LN_ZETA_MAX.exp()),
        })
        .collect();
    let mut theta = to_theta(&start);
    let (mut best, mut jtj, mut jtr) = evaluate(p, &start)?;
    let mut lambda = 1e-3;
    let np = theta.len();
    let mut it = 0;
    while it < max_iter && np > 0 {
        it += 1;
        let mut improved = false;
        for _ in 0..12 {
            let mut lhs = jtj.clone();
            for i in 0..np {
                lhs[(i, i)] += lambda * jtj[(i, i)].max(1e-12 * (1.0 + best.cost));
            }
            let rhs = -&jtr;
            let delta = match lhs.clone().cholesky() {
                Some(c) => c.solve(&rhs),
                None => match lhs.lu().solve(&rhs) {
                    Some(d) => d,
                    None => {
                        lambda *= 10.0;
                        continue;
                    }
                },
            };
            // limit a step to a factor e^0.5 per parameter
            let mx = delta.amax();
            let delta = if mx > 0.5 { delta * (0.5 / mx) } else { delta };
            let trial: Vec<f64> = theta.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            let modes = from_theta(&trial);
            match evaluate(p, &modes) {
                Some((sol, j2, r2)) if sol.cost < best.cost => {
                    let rel = (best.cost - sol.cost) / best.cost.max(1e-300);
                    theta = to_theta(&modes);
                    best = sol;
                    jtj = j2;
                    jtr = r2;
                    lambda = (lambda / 3.0).max(1e-9);
                    improved = rel > 1e-6;
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    best.iterations = it;
    Some(best)
}

/// Weighted residual energy per line, summed over channels (scaled units).
pub(crate) fn residual_per_line(p: &Prepared, sol: &Solved) -> Vec<f64> {
    let res = residuals(p, sol);
    (0..p.n_lines())
        .map(|k| res.iter().map(|r| r[k].norm_sqr()).sum())
        .collect()
}

/// Weighted residual per channel and line (scaled units).
pub(crate) fn residuals(p: &Prepared, sol: &Solved) -> Vec<Vec<Complex64>> {
    let n = sol.modes.len();
    sol.coefs
        .iter()
        .enumerate()
        .map(|(ci, x)| {
            (0..p.n_lines())
                .map(|k| {
                    let s = p.s[k];
                    let mut hm = Complex64::new(x[2 * n], 0.0);
                    for (j, m) in sol.modes.iter().enumerate() {
                        hm += (s * x[2 * j] + x[2 * j + 1]) / m.den(s);
                    }
                    (p.h[ci][k] - hm) * p.w[ci][k]
                })
                .collect()
        })
        .collect()
}

/// Lag-one correlation of the weighted residual along frequency, pooled over channels:
/// `Re Σ r_k r̄_{k+1} / Σ |r_k|²` over neighbouring usable lines. About 0 when the
/// residual is measurement noise, near 1 when it is a smooth model error (a missing
/// mode).
pub(crate) fn lag_one_correlation(p: &Prepared, sol: &Solved) -> f64 {
    let res = residuals(p, sol);
    let (mut num, mut den) = (0.0, 0.0);
    for (ci, r) in res.iter().enumerate() {
        for k in 0..r.len() {
            if p.w[ci][k] == 0.0 {
                continue;
            }
            den += r[k].norm_sqr();
            if k + 1 < r.len() && p.w[ci][k + 1] > 0.0 {
                num += (r[k] * r[k + 1].conj()).re;
            }
        }
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

/// Weighted size of each mode's contribution Σ_c Σ_k w² |term|².
pub(crate) fn mode_contributions(p: &Prepared, sol: &Solved) -> Vec<f64> {
    (0..sol.modes.len())
        .map(|j| {
            let m = sol.modes[j];
            let mut acc = 0.0;
            for (ci, x) in sol.coefs.iter().enumerate() {
                for k in 0..p.n_lines() {
                    let s = p.s[k];
                    acc += ((s * x[2 * j] + x[2 * j + 1]) / m.den(s) * p.w[ci][k]).norm_sqr();
                }
            }
            acc
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{Axis, Channel};
    use crate::model::{ChannelModel, ModalModel, ModeNum};
    use crate::rational_fit::{FitOptions, Weighting};

    /// A 2-channel FRF of `modes` (Hz, ζ) with irregular departures, prepared with
    /// irregular weights (some zero).
    fn prepared(modes: &[(f64, f64)], seed: u64) -> Prepared {
        let model = ModalModel {
            modes: modes.iter().map(|&(f, z)| Mode::from_hz(f, z)).collect(),
            channels: [(Axis::X, 1.0), (Axis::Y, -0.6)]
                .iter()
                .map(|&(o, g)| ChannelModel {
                    channel: Channel {
                        output: o,
                        input: Axis::X,
                    },
                    num: (0..modes.len())
                        .map(|k| ModeNum {
                            b1: g * 30.0 * (k as f64 + 1.0),
                            b0: 1e5 * (1.0 + 0.3 * k as f64),
                        })
                        .collect(),
                    d: 1e-7 * g,
                })
                .collect(),
        };
        let nl = 300;
        let freqs: Vec<f64> = (0..nl).map(|k| 50.0 + 5.0 * k as f64).collect();
        let mut frf = model.frf(&freqs);
        let sd = seed as f64;
        for (c, ch) in frf.channels.iter_mut().enumerate() {
            for (k, h) in ch.h.iter_mut().enumerate() {
                let t = k as f64 + 13.0 * c as f64 + sd;
                *h *= Complex64::new(1.0 + 0.05 * (1.7 * t).sin(), 0.05 * (0.37 * t * t).cos());
            }
        }
        let w: Vec<Vec<f64>> = (0..2)
            .map(|c| {
                (0..nl)
                    .map(|k| {
                        if (k + c + seed as usize) % 11 == 3 {
                            0.0
                        } else {
                            1.0 + 0.5 * ((k as f64 + sd) * 0.1).sin()
                        }
                    })
                    .collect()
            })
            .collect();
        let opts = FitOptions {
            weighting: Weighting::Custom(w),
            ..FitOptions::default()
        };
        Prepared::new(&frf, &opts).expect("valid FRF")
    }

    /// Largest difference of two systems' parts, each relative to its scale.
    fn differences(pf: &ChannelSystem, ex: &ChannelSystem) -> [f64; 4] {
        let xs = ex.0.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let dx =
            pf.0.iter()
                .zip(&ex.0)
                .fold(0.0f64, |a, (u, v)| a.max((u - v).abs()))
                / xs;
        let dc = (pf.1 - ex.1).abs() / ex.1;
        let n = ex.2.nrows();
        let mut dj: f64 = 0.0;
        let mut dr: f64 = 0.0;
        for i in 0..n {
            for j in 0..n {
                let sc = (ex.2[(i, i)] * ex.2[(j, j)]).sqrt();
                dj = dj.max((pf.2[(i, j)] - ex.2[(i, j)]).abs() / sc);
            }
            dr = dr.max((pf.3[i] - ex.3[i]).abs() / (ex.2[(i, i)] * ex.1).sqrt());
        }
        [dx, dc, dj, dr]
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// Without the design matrix, every part of a channel's Gauss–Newton system equals
        /// the design's, for modes of any damping from 1e-4 (also off the data's modes).
        #[test]
        fn partial_fraction_system_equals_the_design(
            modes in proptest::collection::vec((80.0f64..1500.0, -4.0f64..-0.5), 1..6),
            shift in 0.9f64..1.1,
            seed in 0u64..1000,
        ) {
            let modes: Vec<(f64, f64)> = modes.iter().map(|&(f, lz)| (f, 10f64.powf(lz))).collect();
            let p = prepared(&modes, seed);
            let at: Vec<Mode> = p.scale_modes(
                &modes.iter().map(|&(f, z)| Mode::from_hz(f * shift, z * shift)).collect::<Vec<_>>(),
            );
            let q = pf_gram::mode_poles(&at).expect("underdamped");
            for ci in 0..2 {
                let (a, y, rows) = design(&p, ci, &at);
                let Some(ex) = channel_gram(&p, ci, &at, &a, &y, &rows) else { continue };
                let pf = channel_pf(&p, ci, &at, &q);
                proptest::prop_assert!(pf.is_some(), "no partial-fraction system where the design has one");
                let d = differences(&pf.unwrap(), &ex);
                // x, cost, Jᵀr to 1e-9; JᵀJ (a difference of two Gram products in both) to 1e-6
                proptest::prop_assert!(
                    d[0] <= 1e-9 && d[1] <= 1e-9 && d[2] <= 1e-6 && d[3] <= 1e-9,
                    "differences (x, cost, JᵀJ, Jᵀr) {d:?}"
                );
            }
        }
    }
}
