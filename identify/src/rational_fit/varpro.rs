//! Nonlinear refinement of the true weighted error `Σ |W (H − F)|²` by
//! Levenberg–Marquardt over the modes `(ln ω, ln ζ)` with the linear numerators
//! eliminated (variable projection, Kaufman's Jacobian).
//!
//! For fixed modes every channel is a linear least-squares problem in the modal basis
//! `s/den_k(s)`, `1/den_k(s)`, `1`; its residual `r = (I − QQᵀ) y` depends on the modes
//! only. The Jacobian of `r` with respect to one mode parameter is approximated by
//! `−(I − QQᵀ) (∂A/∂θ) x`, which keeps the exact Gauss–Newton direction at the optimum
//! and needs one QR per channel per iteration — or, when the channel's design matrix is
//! well conditioned, one Gram matrix (see `linalg`), about five times cheaper.

use super::data::Prepared;
use super::linalg::{lstsq, ScaledGram, Tall};
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
    let lines: Vec<usize> = (0..p.n_lines()).filter(|&k| p.w[ci][k] > 0.0).collect();
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
            // ∂den/∂ln ω = ω (2ζ s + 2ω), ∂den/∂ln ζ = 2ζω s
            v.set(i, 2 * j, g * ((s * (2.0 * md.zeta) + 2.0 * md.wn) * md.wn));
            v.set(i, 2 * j + 1, g * (s * (2.0 * md.zeta * md.wn)));
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
    let vtv = &v.at * &v.a;
    let mut b = &a.at * &v.a;
    for (i, d) in g.d.iter().enumerate() {
        b.row_mut(i).unscale_mut(*d);
    }
    let z = g.chol.l().solve_lower_triangular(&b)?;
    let jtj = &vtv - z.transpose() * &z;
    // the projected part must keep a fair share of every derivative column
    if (0..jtj.nrows()).any(|i| !(jtj[(i, i)] >= 1e-6 * vtv[(i, i)])) {
        v.release();
        return None;
    }
    let jtr = -(&v.at * &r);
    v.release();
    Some((x, r.norm_squared(), jtj, jtr))
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
    for ci in 0..p.channels.len() {
        let (a, y, rows) = design(p, ci, modes);
        let m = a.a.ncols();
        if a.a.nrows() < m {
            a.release();
            coefs.push(vec![0.0; m]);
            continue;
        }
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
