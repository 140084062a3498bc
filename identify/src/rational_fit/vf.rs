//! Relaxed vector fitting with common poles (Gustavsen & Semlyen 1999, relaxation
//! Gustavsen 2006, the fast QR-based multi-channel form of Deschrijver et al. 2008).
//!
//! One iteration is a Sanathanan–Koerner step written in the partial-fraction basis of
//! the current poles: find `σ(s) = d̃ + Σ c̃ᵢ φᵢ(s)` and per channel `Σ rᵢ φᵢ + d` with
//! `W (Σ r φ + d − h σ) ≈ 0` and the relaxation `Re Σₖ σ(sₖ) = N`; the zeros of `σ`
//! (eigenvalues of `A − b c̃ᵀ / d̃`) are the new poles. Unstable poles are flipped
//! into the left half plane. A complex pair `p, p̄` uses the real basis functions
//! `1/(s−p) + 1/(s−p̄)` and `j/(s−p) − j/(s−p̄)`.
//!
//! Only the σ block of each channel's triangular factor is needed. It comes from the
//! channel's Gram matrix, which the partial-fraction structure of the basis gives from
//! a few sums per pole (O(lines × poles), no design matrix; see `structured_gram`),
//! when that matrix is well conditioned; otherwise from the design, by its Gram matrix or
//! its Householder QR.

use super::data::Prepared;
use crate::linalg::{lstsq, trailing_r, trailing_r_of_gram, Tall};
use crate::model::Mode;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// The poles have settled when none moves by more than this (relative). The vector
/// fitting converges linearly (about 0.15 per iteration near the fixed point), and its
/// poles only start the automatic order search and the Levenberg–Marquardt refinement of
/// the true error: 1e-5 instead of 1e-7 saves two or three relocations per order with the
/// same final fits.
const SETTLED: f64 = 1e-5;

/// Smallest relative damping a relocated pole keeps (|Re p| ≥ this × |p|).
const MIN_REL_DAMPING: f64 = 1e-6;

/// Number of real basis columns for `poles` (2 per complex pair, 1 per real pole).
fn n_basis(poles: &[Complex64]) -> usize {
    poles.iter().map(|p| if p.im > 0.0 { 2 } else { 1 }).sum()
}

/// Complex basis values φᵢ(s) for one line.
fn basis_row(s: Complex64, poles: &[Complex64], out: &mut Vec<Complex64>) {
    out.clear();
    let j = Complex64::new(0.0, 1.0);
    for &p in poles {
        if p.im > 0.0 {
            let a = 1.0 / (s - p);
            let b = 1.0 / (s - p.conj());
            out.push(a + b);
            out.push(j * a - j * b);
        } else {
            out.push(1.0 / (s - p));
        }
    }
}

/// The Gram matrix `Re(Dᴴ D)` of one channel's design `D = [Φ̃ W, −diag(h) Φ̃ W]`
/// (`Φ̃` = the basis of `poles` and a constant column, `W` = the weights), built in
/// O(lines × poles) instead of O(lines × columns²) and without the design itself.
///
/// With `s = jω` on the imaginary axis, `conj(1/(s − q)) = −1/(s + q̄)`, and every entry
/// of `Ψᴴ diag(v) Ψ` for the partial fractions `ψ_a = 1/(s − q_a)` splits into partial
/// fractions: `Σ_k v_k conj(ψ_a) ψ_b = −(S_v(q_b) − S_v(−q̄_a)) / (q_b + q̄_a)` with the
/// sums `S_v(q) = Σ_k v_k / (s_k − q)`, for `v = w², w² h, w² |h|²`; the real basis of a
/// pair is `Φ̃ = Ψ̃ T`. Both poles of an entry lie in the left half plane, so
/// `Re(q_b + q̄_a) < 0` and the divisor never vanishes; `None` when it is tiny against
/// the poles or an entry is not finite (the caller then forms the design).
fn structured_gram(
    s: &[Complex64],
    w: &[f64],
    h: &[Complex64],
    poles: &[Complex64],
) -> Option<DMatrix<f64>> {
    let (q, t) = partial_fractions(poles);
    let kq = q.len();
    let m = kq + 1;
    // the fitted lines, column by column (y = Im s; v = w², w² h, w² |h|²)
    let mut cols: [Vec<f64>; 5] = Default::default();
    let mut tot = [Complex64::default(); 3];
    for ((&sk, &wk), &hk) in s.iter().zip(w).zip(h) {
        let w2 = wk * wk;
        if w2 == 0.0 {
            continue;
        }
        let v = [w2, hk.re * w2, hk.im * w2, hk.norm_sqr() * w2];
        tot[0] += v[0];
        tot[1] += Complex64::new(v[1], v[2]);
        tot[2] += v[3];
        cols[0].push(sk.im);
        for (c, x) in cols[1..].iter_mut().zip(v) {
            c.push(x);
        }
    }
    // S_v(q_a) and S_v(−q̄_a). With s = jy, 1/(s + q̄) = −conj(1/(s − q)): one division
    // per line and pole, and for real v, S_v(−q̄) = −conj(S_v(q)).
    let mut sq = vec![[Complex64::default(); 3]; kq];
    let mut sm = vec![[Complex64::default(); 3]; kq];
    for (a, &qa) in q.iter().enumerate() {
        let sums = pole_sums(&cols, qa);
        let c = |i: usize| Complex64::new(sums[2 * i], sums[2 * i + 1]);
        let (s1, s2, s3, t2) = (c(0), c(1), c(2), c(3));
        sq[a] = [s1, s2, s3];
        sm[a] = [-s1.conj(), -t2, -s3.conj()];
    }
    // Ψ̃ᴴ diag(v) Ψ̃, then Φ̃ᴴ diag(v) Φ̃ = Tᴴ (…) T
    let mut blocks = Vec::with_capacity(3);
    for i in 0..3 {
        let mut c = DMatrix::<Complex64>::zeros(m, m);
        for a in 0..kq {
            for b in 0..kq {
                let den = q[b] + q[a].conj();
                if !(den.norm() > 1e-12 * (q[a].norm() + q[b].norm())) {
                    return None;
                }
                c[(a, b)] = -(sq[b][i] - sm[a][i]) / den;
            }
            c[(a, kq)] = -sm[a][i];
            c[(kq, a)] = sq[a][i];
        }
        c[(kq, kq)] = tot[i];
        blocks.push(t.adjoint() * c * &t);
    }
    // D = [Φ̃ W, −diag(h) Φ̃ W]: Dᴴ D = [[B(w²), −B(w² h)], [−B(w² h)ᴴ, B(w² |h|²)]]
    let g = DMatrix::from_fn(2 * m, 2 * m, |r, c| match (r < m, c < m) {
        (true, true) => blocks[0][(r, c)].re,
        (true, false) => -blocks[1][(r, c - m)].re,
        (false, true) => -blocks[1][(c, r - m)].re,
        (false, false) => blocks[2][(r - m, c - m)].re,
    });
    g.iter().all(|v| v.is_finite()).then_some(g)
}

/// The partial fractions `ψ_a = 1/(s − q_a)` under the real basis of `poles` (a pair
/// gives `q = p, p̄`, a real pole itself) and the matrix `T` with `Φ̃ = Ψ̃ T`, where
/// `Ψ̃`, `Φ̃` end with the constant column ([`basis_row`] in matrix form).
fn partial_fractions(poles: &[Complex64]) -> (Vec<Complex64>, DMatrix<Complex64>) {
    let (one, j) = (Complex64::new(1.0, 0.0), Complex64::new(0.0, 1.0));
    let mut q = Vec::with_capacity(2 * poles.len());
    for &p in poles {
        q.push(p);
        if p.im > 0.0 {
            q.push(p.conj());
        }
    }
    let kq = q.len();
    let mut t = DMatrix::<Complex64>::zeros(kq + 1, kq + 1);
    let mut col = 0;
    for &p in poles {
        if p.im > 0.0 {
            // 1/(s−p) + 1/(s−p̄) and j/(s−p) − j/(s−p̄)
            t[(col, col)] = one;
            t[(col + 1, col)] = one;
            t[(col, col + 1)] = j;
            t[(col + 1, col + 1)] = -j;
            col += 2;
        } else {
            t[(col, col)] = one;
            col += 1;
        }
    }
    t[(kq, kq)] = one;
    (q, t)
}

/// For one pole `q` and the fitted lines `cols` = (Im s, w², Re w²h, Im w²h, w²|h|²):
/// the sums over the lines of `w² r`, `w²h r`, `w²|h|² r` and `w²h r̄` with
/// `r = 1/(s − q)`, as four (re, im) pairs ([`crate::lanes`]; with `s = jy` one real
/// division per line).
fn pole_sums(cols: &[Vec<f64>; 5], q: Complex64) -> [f64; 8] {
    crate::lanes::sum(cols[0].len(), |k| {
        let (rr, ri) = super::pf_gram::resolvent(cols[0][k], q);
        let (w2, vr, vi, w2h2) = (cols[1][k], cols[2][k], cols[3][k], cols[4][k]);
        [
            w2 * rr,
            w2 * ri,
            vr * rr - vi * ri,
            vr * ri + vi * rr,
            w2h2 * rr,
            w2h2 * ri,
            vr * rr + vi * ri,
            vi * rr - vr * ri,
        ]
    })
}

/// `Σ_k 1/(s_k − q)` over the lines `s` (on the imaginary axis; [`crate::lanes`]).
fn resolvent_sum(s: &[Complex64], q: Complex64) -> Complex64 {
    let [re, im] = crate::lanes::sum(s.len(), |k| {
        let (re, im) = super::pf_gram::resolvent(s[k].im, q);
        [re, im]
    });
    Complex64::new(re, im)
}

/// Runs up to `iters` pole relocations on `poles` (scaled units, one entry per pair with
/// Im > 0 or per real pole). Stops early when the poles settle. Returns the number of
/// iterations done.
pub(crate) fn relocate(p: &Prepared, poles: &mut Vec<Complex64>, iters: usize) -> usize {
    let mut jumps = 0;
    for it in 0..iters {
        let Some(new) = step(p, poles) else {
            return it;
        };
        let change = pole_change(poles, &new);
        *poles = new;
        if change < SETTLED {
            return it + 1;
        }
        // A pole the data do not support keeps jumping (often between a pair and two
        // real poles); more iterations only shuffle it. Stop after three such jumps in
        // a row once the first iterations are done.
        jumps = if change > 0.5 { jumps + 1 } else { 0 };
        if it >= 4 && jumps >= 3 {
            return it + 1;
        }
    }
    iters
}

fn pole_change(old: &[Complex64], new: &[Complex64]) -> f64 {
    if old.len() != new.len() {
        return f64::INFINITY;
    }
    let mut a: Vec<Complex64> = old.to_vec();
    let mut b: Vec<Complex64> = new.to_vec();
    let key = |x: &Complex64, y: &Complex64| x.norm().total_cmp(&y.norm());
    a.sort_by(key);
    b.sort_by(key);
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).norm() / x.norm().max(1e-12))
        .fold(0.0, f64::max)
}

/// One relaxed SK / VF pole relocation.
fn step(p: &Prepared, poles: &[Complex64]) -> Option<Vec<Complex64>> {
    let nb = n_basis(poles);
    let m = nb + 1; // per block: φ columns + constant
    let nl = p.n_lines();
    let mut phi = Vec::with_capacity(nb);
    let n_ch = p.channels.len();
    let mut big = DMatrix::<f64>::zeros(n_ch * m + 1, m);
    let mut row = 0;
    let mut relax_scale = 0.0;
    for ci in 0..n_ch {
        let lines = &p.fitted[ci];
        if lines.is_empty() {
            continue;
        }
        relax_scale += lines
            .iter()
            .map(|&k| (p.h[ci][k] * p.w[ci][k]).norm_sqr())
            .sum::<f64>();
        if lines.len() < m {
            // too few lines in this channel for its own unknowns: skip it for σ
            continue;
        }
        // only the σ block of R is needed: from the Gram matrix when it is well
        // conditioned — built from partial-fraction sums, or from the design — else from
        // the Householder QR of the design
        if let Some(r22) =
            structured_gram(&p.s, &p.w[ci], &p.h[ci], poles).and_then(|g| trailing_r_of_gram(g, m))
        {
            big.view_mut((row, 0), (m, m)).copy_from(&r22);
            row += m;
            continue;
        }
        let mut d = Tall::zeros(lines.len(), 2 * m);
        for (i, &k) in lines.iter().enumerate() {
            let w = p.w[ci][k];
            let h = p.h[ci][k];
            basis_row(p.s[k], poles, &mut phi);
            for (j, f) in phi.iter().enumerate() {
                d.set(i, j, f * w);
                d.set(i, m + j, -(f * h) * w);
            }
            d.set(i, nb, Complex64::new(w, 0.0));
            d.set(i, m + nb, -h * w);
        }
        let r22 = match trailing_r(&d, m) {
            Some(r) => {
                d.release();
                r
            }
            None => d.into_a().qr().r().view((m, m), (m, m)).into_owned(),
        };
        big.view_mut((row, 0), (m, m)).copy_from(&r22);
        row += m;
    }
    if row == 0 {
        return None;
    }
    // relaxation row: Re Σ_k σ(s_k) = N, scaled like the data
    let scale = relax_scale.sqrt() / nl as f64;
    // Σ_k φ̃_j(s_k) = (Σ_k ψ̃(s_k)) T, the constant column giving N
    let (q, t) = partial_fractions(poles);
    let mut psi_sum: Vec<Complex64> = q.iter().map(|&qa| resolvent_sum(&p.s, qa)).collect();
    psi_sum.push(Complex64::new(nl as f64, 0.0));
    let sum: Vec<f64> = (0..m)
        .map(|j| {
            psi_sum
                .iter()
                .zip(t.column(j).iter())
                .map(|(u, t)| u * t)
                .sum::<Complex64>()
                .re
        })
        .collect();
    for j in 0..m {
        big[(row, j)] = sum[j] * scale;
    }
    let mut rhs = DVector::<f64>::zeros(row + 1);
    rhs[row] = nl as f64 * scale;
    let big = big.rows(0, row + 1).into_owned();
    let x = lstsq(&big, &rhs)?;
    let mut dt = x[nb];
    if dt.abs() < 1e-8 {
        dt = 1e-8_f64.copysign(if dt == 0.0 { 1.0 } else { dt });
    }
    // zeros of σ: eig(A − b cᵀ / d̃)
    let mut a = DMatrix::<f64>::zeros(nb, nb);
    let mut b = DVector::<f64>::zeros(nb);
    let mut col = 0;
    for &pl in poles {
        if pl.im > 0.0 {
            a[(col, col)] = pl.re;
            a[(col, col + 1)] = pl.im;
            a[(col + 1, col)] = -pl.im;
            a[(col + 1, col + 1)] = pl.re;
            b[col] = 2.0;
            col += 2;
        } else {
            a[(col, col)] = pl.re;
            b[col] = 1.0;
            col += 1;
        }
    }
    let c = x.rows(0, nb).transpose() / dt;
    let h = a - &b * c;
    if h.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let eig = crate::eigen::eigenvalues_or_schur(h);
    let mut out: Vec<Complex64> = Vec::with_capacity(poles.len());
    for z in eig.iter() {
        if z.im < 0.0 {
            continue;
        }
        let mag = z.norm();
        let mut re = -z.re.abs(); // flip unstable poles
        if mag > 0.0 && re > -MIN_REL_DAMPING * mag {
            re = -MIN_REL_DAMPING * mag;
        }
        if mag == 0.0 {
            re = -1e-6;
        }
        out.push(Complex64::new(re, z.im));
    }
    if out.iter().any(|z| !z.re.is_finite() || !z.im.is_finite()) {
        return None;
    }
    Some(out)
}

/// Turns VF poles into modes: each complex pair is a mode; the real poles (an even number
/// when the total order is even) are paired neighbour by neighbour into over-damped
/// sections (ζ ≥ 1). A lone real pole left over is dropped.
pub(crate) fn poles_to_modes(poles: &[Complex64]) -> Vec<Mode> {
    let mut modes: Vec<Mode> = poles
        .iter()
        .filter(|p| p.im > 0.0)
        .map(|&p| Mode::from_pole(p))
        .collect();
    let mut reals: Vec<f64> = poles.iter().filter(|p| p.im <= 0.0).map(|p| p.re).collect();
    reals.sort_by(|a, b| b.total_cmp(a));
    for pair in reals.chunks_exact(2) {
        let (p1, p2) = (pair[0], pair[1]);
        let wn = (p1 * p2).sqrt();
        let zeta = -(p1 + p2) / (2.0 * wn);
        if wn.is_finite() && wn > 0.0 && zeta.is_finite() && zeta >= 1.0 {
            modes.push(Mode { wn, zeta });
        }
    }
    modes
}

/// Poles (one per pair) of modes, the VF representation.
pub(crate) fn modes_to_poles(modes: &[Mode]) -> Vec<Complex64> {
    let mut out = Vec::new();
    for m in modes {
        if m.zeta < 1.0 {
            out.push(m.pole());
        } else {
            out.extend(m.poles());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The partial-fraction Gram matrix equals `aᵀa` of the design it replaces.
    #[test]
    fn structured_gram_matches_the_design() {
        let nl = 400;
        let s: Vec<Complex64> = (0..nl)
            .map(|k| Complex64::new(0.0, 0.05 + 1.2 * k as f64 / nl as f64))
            .collect();
        // light (1e-4) and heavy damping, one real pole
        let poles = vec![
            Complex64::new(-3e-5, 0.3),
            Complex64::new(-2e-3, 0.5),
            Complex64::new(-0.05, 0.8),
            Complex64::new(-0.4, 0.0),
        ];
        let w: Vec<f64> = (0..nl)
            .map(|k| {
                if k % 7 == 3 {
                    0.0
                } else {
                    1.0 + 0.5 * (k as f64 * 0.1).sin()
                }
            })
            .collect();
        // a resonance with irregular (noise-like) departures: a well-conditioned design
        let h: Vec<Complex64> = s
            .iter()
            .enumerate()
            .map(|(k, &sk)| {
                let k = k as f64;
                (1.0 + 0.3 * (1.7 * k).sin()) / (sk * sk + 0.02 * sk + 0.42)
                    + Complex64::new(0.0, 0.2 * (0.37 * k * k).cos())
            })
            .collect();
        let nb = n_basis(&poles);
        let m = nb + 1;
        let mut d = Tall::zeros(nl, 2 * m);
        let mut phi = Vec::new();
        for k in 0..nl {
            basis_row(s[k], &poles, &mut phi);
            phi.push(Complex64::new(1.0, 0.0));
            for (c, f) in phi.iter().enumerate() {
                d.set(k, c, f * w[k]);
                d.set(k, m + c, -(f * h[k]) * w[k]);
            }
        }
        let explicit = &d.at * &d.a;
        let g = structured_gram(&s, &w, &h, &poles).expect("stable poles");
        // compare entries against the geometric mean of their diagonals (the scaled
        // Gram matrix the Cholesky factor sees)
        for r in 0..2 * m {
            for c in 0..2 * m {
                let scale = (explicit[(r, r)] * explicit[(c, c)]).sqrt();
                let err = (g[(r, c)] - explicit[(r, c)]).abs() / scale;
                assert!(err < 1e-10, "entry ({r}, {c}): {err:e}");
            }
        }
        // and the σ block of R agrees (up to the signs of its rows)
        let r_fast = trailing_r_of_gram(g, m).expect("well conditioned");
        let r_qr = d.into_a().qr().r().view((m, m), (m, m)).into_owned();
        for i in 0..m {
            for k in i..m {
                let err = (r_fast[(i, k)].abs() - r_qr[(i, k)].abs()).abs() / r_qr[(i, i)].abs();
                assert!(err < 1e-7, "R({i}, {k}): {err:e}");
            }
        }
    }

    /// The design's Gram matrix, explicitly (the reference).
    fn explicit_gram(
        s: &[Complex64],
        w: &[f64],
        h: &[Complex64],
        poles: &[Complex64],
    ) -> DMatrix<f64> {
        let m = n_basis(poles) + 1;
        let mut d = Tall::zeros(s.len(), 2 * m);
        let mut phi = Vec::new();
        for k in 0..s.len() {
            basis_row(s[k], poles, &mut phi);
            phi.push(Complex64::new(1.0, 0.0));
            for (c, f) in phi.iter().enumerate() {
                d.set(k, c, f * w[k]);
                d.set(k, m + c, -(f * h[k]) * w[k]);
            }
        }
        &d.at * &d.a
    }

    proptest::proptest! {
        /// Any stable poles (damping down to 1e-4, real poles too), weights with zeros and
        /// data: the partial-fraction Gram matrix equals the design's.
        #[test]
        fn structured_gram_equals_the_design_for_random_poles(
            pairs in proptest::collection::vec((0.05f64..1.2, -4.0f64..-0.5), 1..5),
            real in proptest::option::of(0.05f64..2.0),
            seed in 0u64..1000,
        ) {
            let nl = 300;
            let s: Vec<Complex64> = (0..nl)
                .map(|k| Complex64::new(0.0, 0.02 + 1.3 * k as f64 / nl as f64))
                .collect();
            let mut poles: Vec<Complex64> = pairs
                .iter()
                .map(|&(wn, lz)| Complex64::new(-(10f64.powf(lz)) * wn, wn))
                .collect();
            if let Some(r) = real {
                poles.push(Complex64::new(-r, 0.0));
            }
            let x = |k: usize, a: f64| ((k as f64 + seed as f64) * a).sin();
            let w: Vec<f64> = (0..nl).map(|k| if x(k, 0.7) > 0.8 { 0.0 } else { 1.0 + 0.5 * x(k, 0.3) }).collect();
            let h: Vec<Complex64> = (0..nl).map(|k| Complex64::new(x(k, 1.1), x(k, 2.3)) * 3.0).collect();
            let g = structured_gram(&s, &w, &h, &poles).expect("stable poles");
            let e = explicit_gram(&s, &w, &h, &poles);
            for r in 0..e.nrows() {
                for c in 0..e.ncols() {
                    let scale = (e[(r, r)] * e[(c, c)]).sqrt();
                    proptest::prop_assert!((g[(r, c)] - e[(r, c)]).abs() <= 1e-9 * scale,
                        "entry ({}, {}): {} vs {}", r, c, g[(r, c)], e[(r, c)]);
                }
            }
        }
    }

    #[test]
    fn structured_gram_refuses_a_pole_on_the_axis() {
        let s = vec![Complex64::new(0.0, 0.5); 4];
        let poles = vec![Complex64::new(0.0, 0.3)];
        let g = structured_gram(&s, &[1.0; 4], &[Complex64::new(1.0, 0.0); 4], &poles);
        assert!(g.is_none());
    }
}
