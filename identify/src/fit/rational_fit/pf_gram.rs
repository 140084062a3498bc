//! Gram matrices of the variable projection's columns from partial-fraction sums, without
//! the design matrix.
//!
//! Every column the variable projection needs — the modal basis `s/den_j`, `1/den_j`, the
//! constant, and the derivative columns `num_j (∂den_j/∂θ) / den_j²` — is a complex
//! function `f(s)` of the line, weighted by `w`, and a combination of
//! `ξ = 1/(s − q)`, `1/(s − q)²` over the poles `q` of the modes, and `1`. The inner
//! product of two real-form columns (real parts, then imaginary parts) is
//! `Re Σ_k w_k² conj(f(s_k)) g(s_k)`: a bilinear form in the Hermitian Gram matrix `M` of
//! that basis. `M` follows from two sums per pole, `S₁(q) = Σ w²/(s − q)` and
//! `S₂(q) = Σ w²/(s − q)²`: with `s = jy`, `conj(1/(s − q_a)) = −1/(s − c)` for
//! `c = −q̄_a`, and for `u = s − c`, `t = s − q_b`, `δ = q_b − c = q_b + q̄_a`
//!
//! ```text
//! 1/(u t)   = (1/t − 1/u) / δ
//! 1/(u² t)  = (1/t − 1/u) / δ² − 1/(δ u²)
//! 1/(u t²)  = 1/(δ t²) − (1/t − 1/u) / δ²
//! 1/(u² t²) = (1/t² + 1/u²) / δ² − 2 (1/t − 1/u) / δ³
//! ```
//!
//! and, on the imaginary axis and for real weights, `S₁(−q̄) = −conj(S₁(q))`,
//! `S₂(−q̄) = conj(S₂(q))`. Forming the Gram matrices then costs one division per line and
//! pole instead of a pass over a tall matrix per pair of columns. Both poles of an entry
//! are stable, so `Re δ < 0` and `δ` never vanishes; a mode near critical damping (its two
//! poles close together) is left to the design matrix.

use crate::model::Mode;
use nalgebra::DMatrix;
use num_complex::Complex64;

/// A column as a combination of the basis: up to four (basis index, coefficient) terms
/// (unused terms have a zero coefficient).
pub(crate) type Column = [(usize, Complex64); 4];

/// Largest damping ratio for which a mode's columns are expanded into its poles (the
/// expansion divides by `p − p̄`, which vanishes at critical damping).
const MAX_ZETA: f64 = 0.5;

/// The poles of `modes` (mode `j`: `q[2j] = p`, `q[2j + 1] = p̄`, `Im p > 0`); `None`
/// when a mode is not clearly underdamped (see [`MAX_ZETA`]).
pub(crate) fn mode_poles(modes: &[Mode]) -> Option<Vec<Complex64>> {
    let mut q = Vec::with_capacity(2 * modes.len());
    for md in modes {
        if !(md.zeta > 0.0 && md.zeta < MAX_ZETA && md.wn > 0.0 && md.wn.is_finite()) {
            return None;
        }
        let p = Complex64::new(-md.zeta * md.wn, md.wn * (1.0 - md.zeta * md.zeta).sqrt());
        q.push(p);
        q.push(p.conj());
    }
    Some(q)
}

/// The Hermitian Gram matrix `M` of the basis `1/(s − q_i)` (index `i`), `1/(s − q_i)²`
/// (index `k + i`) and `1` (index `2k`) over weighted lines.
pub(crate) struct PfGram {
    m: DMatrix<Complex64>,
}

/// `1/(jy − q)` as (re, im), with one real division.
#[inline(always)]
pub(crate) fn resolvent(y: f64, q: Complex64) -> (f64, f64) {
    let x = y - q.im;
    let d = 1.0 / (q.re * q.re + x * x);
    (-q.re * d, -x * d)
}

/// `S₁(q)` and `S₂(q)` over the lines `y` (`s = jy`) with weights `v` ([`crate::lanes`]).
fn sums(y: &[f64], v: &[f64], q: Complex64) -> (Complex64, Complex64) {
    let [a, b, c, d] = crate::lanes::sum(y.len(), |k| {
        let (rr, ri) = resolvent(y[k], q);
        let vk = v[k];
        [
            vk * rr,
            vk * ri,
            vk * (rr * rr - ri * ri),
            vk * (2.0 * rr * ri),
        ]
    });
    (Complex64::new(a, b), Complex64::new(c, d))
}

impl PfGram {
    /// Over the lines `s = j y` with weights `v` (the squared amplitude weights) and the
    /// poles `q` (all in the open left half plane). `None` when an entry is not finite or
    /// a divisor is tiny against the poles.
    pub(crate) fn new(y: &[f64], v: &[f64], q: &[Complex64]) -> Option<PfGram> {
        let k = q.len();
        let n = 2 * k + 1;
        let s: Vec<(Complex64, Complex64)> = q.iter().map(|&qa| sums(y, v, qa)).collect();
        let mut m = DMatrix::<Complex64>::zeros(n, n);
        for a in 0..k {
            // sums at c = −q̄_a
            let (u1, u2) = (-s[a].0.conj(), s[a].1.conj());
            for b in 0..k {
                let (t1, t2) = s[b];
                let d = q[b] + q[a].conj();
                if !(d.norm() > 1e-12 * (q[a].norm() + q[b].norm())) {
                    return None;
                }
                let id = 1.0 / d;
                let dt = (t1 - u1) * id;
                // conj(ξ_a) carries (−1)^α
                m[(a, b)] = -dt;
                m[(k + a, b)] = (dt - u2) * id;
                m[(a, k + b)] = (dt - t2) * id;
                m[(k + a, k + b)] = ((t2 + u2) - 2.0 * dt) * id * id;
            }
            m[(n - 1, a)] = s[a].0;
            m[(n - 1, k + a)] = s[a].1;
            m[(a, n - 1)] = s[a].0.conj();
            m[(k + a, n - 1)] = s[a].1.conj();
        }
        m[(n - 1, n - 1)] = Complex64::new(crate::lanes::sum(v.len(), |i| [v[i]])[0], 0.0);
        m.iter()
            .all(|z| z.re.is_finite() && z.im.is_finite())
            .then_some(PfGram { m })
    }

    /// `Re Σ w² conj(f) g` of two columns.
    fn inner(&self, f: &Column, g: &Column) -> f64 {
        let mut acc = 0.0;
        for &(a, ca) in f.iter().filter(|t| t.1 != Complex64::default()) {
            let mut row = Complex64::default();
            for &(b, cb) in g.iter().filter(|t| t.1 != Complex64::default()) {
                row += self.m[(a, b)] * cb;
            }
            acc += (ca.conj() * row).re;
        }
        acc
    }

    /// The real Gram matrix `[Re Σ w² conj(f_i) g_j]` of two column lists.
    pub(crate) fn cross(&self, f: &[Column], g: &[Column]) -> DMatrix<f64> {
        DMatrix::from_fn(f.len(), g.len(), |i, j| self.inner(&f[i], &g[j]))
    }

    /// The (symmetric) Gram matrix of one column list.
    pub(crate) fn gram(&self, f: &[Column]) -> DMatrix<f64> {
        let n = f.len();
        let mut out = DMatrix::zeros(n, n);
        for i in 0..n {
            for j in i..n {
                let v = self.inner(&f[i], &f[j]);
                out[(i, j)] = v;
                out[(j, i)] = v;
            }
        }
        out
    }
}

/// The modal basis of [`super::varpro`] (`s/den_j`, `1/den_j` per mode, then `1`) over
/// the poles `q` of [`mode_poles`].
pub(crate) fn basis_columns(q: &[Complex64]) -> Vec<Column> {
    let k = q.len();
    let zero = (0, Complex64::default());
    let mut cols = Vec::with_capacity(k + 1);
    for j in 0..k / 2 {
        let (p, pb) = (q[2 * j], q[2 * j + 1]);
        let id = 1.0 / (p - pb);
        // 1/den = (1/(s−p) − 1/(s−p̄)) / Δ, s/den = (p/(s−p) − p̄/(s−p̄)) / Δ
        cols.push([(2 * j, p * id), (2 * j + 1, -pb * id), zero, zero]);
        cols.push([(2 * j, id), (2 * j + 1, -id), zero, zero]);
    }
    cols.push([(2 * k, Complex64::new(1.0, 0.0)), zero, zero, zero]);
    cols
}

/// The derivative columns of [`super::varpro`] (`ln ω`, then `ln ζ` per mode) for the
/// numerators `x` (`[b1_0, b0_0, …]`): `−num_j (∂den_j/∂θ) / den_j²` expanded at the double
/// poles `p`, `p̄` of each mode.
pub(crate) fn derivative_columns(modes: &[Mode], q: &[Complex64], x: &[f64]) -> Vec<Column> {
    let k = q.len();
    let mut cols = Vec::with_capacity(k);
    for (j, md) in modes.iter().enumerate() {
        let (x0, x1) = (x[2 * j], x[2 * j + 1]);
        let (p, pb) = (q[2 * j], q[2 * j + 1]);
        let dl = p - pb;
        let (id2, id3) = (1.0 / (dl * dl), 1.0 / (dl * dl * dl));
        // P = −num · ∂den/∂θ (degree 2) and P' = −(x0 ∂den/∂θ + num · 2ζω) of both columns
        let slope = 2.0 * md.zeta * md.wn;
        for c in 0..2 {
            let pp = |s: Complex64| -(s * x0 + x1) * md.den_log_derivatives(s)[c];
            let dp = |s: Complex64| -(md.den_log_derivatives(s)[c] * x0 + (s * x0 + x1) * slope);
            // residues of P/((s−p)²(s−p̄)²): at p, 1/(s−p)²: P(p)/Δ², 1/(s−p): P'(p)/Δ² − 2P(p)/Δ³;
            // at p̄ the same with Δ → −Δ
            cols.push([
                (2 * j, dp(p) * id2 - 2.0 * pp(p) * id3),
                (2 * j + 1, dp(pb) * id2 + 2.0 * pp(pb) * id3),
                (k + 2 * j, pp(p) * id2),
                (k + 2 * j + 1, pp(pb) * id2),
            ]);
        }
    }
    cols
}
