//! Eigenvalues of small real matrices, eigenvalues only: Parlett–Reinsch balancing, the
//! implicit double-shift Hessenberg QR iteration (EISPACK `hqr`) and, for a general
//! matrix, nalgebra's Householder reduction to Hessenberg form first.
//!
//! Three places need eigenvalues and nothing else: the roots of every order's
//! denominator in the stabilization diagram (a companion matrix, which is already upper
//! Hessenberg), the relocated poles of each vector-fitting iteration and the Floquet
//! multipliers of the semi-discretised milling model. nalgebra's `complex_eigenvalues`
//! computes the whole real Schur form; without the Schur vectors or the form itself the
//! QR sweeps only touch the active block, and a companion matrix needs no reduction.
//! The callers fall back on nalgebra's Schur iteration when [`hqr`] does not converge.

use nalgebra::DMatrix;
use num_complex::Complex64;

/// Parlett–Reinsch balancing (powers of two) of a row-major square matrix in place.
pub(crate) fn balance(n: usize, a: &mut [f64]) {
    for _ in 0..20 {
        let mut done = true;
        for i in 0..n {
            let mut c = 0.0;
            let mut r = 0.0;
            for j in 0..n {
                if j != i {
                    c += a[j * n + i].abs();
                    r += a[i * n + j].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / 2.0 {
                cc *= 2.0;
                rr /= 2.0;
                f *= 2.0;
            }
            while cc >= rr * 2.0 {
                cc /= 2.0;
                rr *= 2.0;
                f /= 2.0;
            }
            if (cc + rr) < 0.95 * s {
                done = false;
                for j in 0..n {
                    a[i * n + j] /= f;
                    a[j * n + i] *= f;
                }
            }
        }
        if done {
            break;
        }
    }
}

/// Eigenvalues of a real upper Hessenberg matrix (row-major, overwritten) by the
/// implicit double-shift QR iteration with exceptional shifts (EISPACK `hqr`, as in
/// Numerical Recipes §11.6), eigenvalues only. `None` if it does not converge.
pub(crate) fn hqr(n: usize, h: &mut [f64]) -> Option<Vec<Complex64>> {
    // 1-based access as in the reference formulation
    let ix = |i: usize, j: usize| (i - 1) * n + (j - 1);
    let mut wr = vec![0.0; n + 1];
    let mut wi = vec![0.0; n + 1];
    let mut anorm = 0.0;
    for i in 1..=n {
        for j in i.saturating_sub(1).max(1)..=n {
            anorm += h[ix(i, j)].abs();
        }
    }
    let mut nn = n;
    let mut t = 0.0;
    while nn >= 1 {
        let mut its = 0;
        loop {
            let mut l = nn;
            while l >= 2 {
                let mut s = h[ix(l - 1, l - 1)].abs() + h[ix(l, l)].abs();
                if s == 0.0 {
                    s = anorm;
                }
                if h[ix(l, l - 1)].abs() + s == s {
                    h[ix(l, l - 1)] = 0.0;
                    break;
                }
                l -= 1;
            }
            let mut x = h[ix(nn, nn)];
            if l == nn {
                wr[nn] = x + t;
                wi[nn] = 0.0;
                nn -= 1;
            } else {
                let mut y = h[ix(nn - 1, nn - 1)];
                let mut w = h[ix(nn, nn - 1)] * h[ix(nn - 1, nn)];
                if l == nn - 1 {
                    let p = 0.5 * (y - x);
                    let q = p * p + w;
                    let mut z = q.abs().sqrt();
                    x += t;
                    if q >= 0.0 {
                        z = p + z.copysign(p);
                        wr[nn - 1] = x + z;
                        wr[nn] = x + z;
                        if z != 0.0 {
                            wr[nn] = x - w / z;
                        }
                        wi[nn - 1] = 0.0;
                        wi[nn] = 0.0;
                    } else {
                        wr[nn - 1] = x + p;
                        wr[nn] = x + p;
                        wi[nn - 1] = -z;
                        wi[nn] = z;
                    }
                    nn -= 2;
                } else {
                    if its == 60 {
                        return None;
                    }
                    if its == 10 || its == 20 || its == 40 {
                        // exceptional shift
                        t += x;
                        for i in 1..=nn {
                            h[ix(i, i)] -= x;
                        }
                        let s = h[ix(nn, nn - 1)].abs() + h[ix(nn - 1, nn - 2)].abs();
                        x = 0.75 * s;
                        y = x;
                        w = -0.4375 * s * s;
                    }
                    its += 1;
                    let (mut p, mut q, mut r, mut z);
                    let mut m = nn - 2;
                    loop {
                        z = h[ix(m, m)];
                        let rr = x - z;
                        let ss = y - z;
                        p = (rr * ss - w) / h[ix(m + 1, m)] + h[ix(m, m + 1)];
                        q = h[ix(m + 1, m + 1)] - z - rr - ss;
                        r = h[ix(m + 2, m + 1)];
                        let s = p.abs() + q.abs() + r.abs();
                        p /= s;
                        q /= s;
                        r /= s;
                        if m == l {
                            break;
                        }
                        let u = h[ix(m, m - 1)].abs() * (q.abs() + r.abs());
                        let v = p.abs()
                            * (h[ix(m - 1, m - 1)].abs() + z.abs() + h[ix(m + 1, m + 1)].abs());
                        if u + v == v {
                            break;
                        }
                        m -= 1;
                    }
                    for i in m + 2..=nn {
                        h[ix(i, i - 2)] = 0.0;
                        if i != m + 2 {
                            h[ix(i, i - 3)] = 0.0;
                        }
                    }
                    let mut k = m;
                    while k < nn {
                        if k != m {
                            p = h[ix(k, k - 1)];
                            q = h[ix(k + 1, k - 1)];
                            r = 0.0;
                            if k != nn - 1 {
                                r = h[ix(k + 2, k - 1)];
                            }
                            x = p.abs() + q.abs() + r.abs();
                            if x != 0.0 {
                                p /= x;
                                q /= x;
                                r /= x;
                            }
                        }
                        let s = (p * p + q * q + r * r).sqrt().copysign(p);
                        if s != 0.0 {
                            if k == m {
                                if l != m {
                                    h[ix(k, k - 1)] = -h[ix(k, k - 1)];
                                }
                            } else {
                                h[ix(k, k - 1)] = -s * x;
                            }
                            p += s;
                            x = p / s;
                            y = q / s;
                            z = r / s;
                            q /= p;
                            r /= p;
                            // rows k, k+1 (and k+2), columns k..=nn
                            let (row_k, rest) = h[ix(k, 1)..].split_at_mut(n);
                            let (row_k1, rest) = rest.split_at_mut(n);
                            let cols = k - 1..nn;
                            let pair = row_k[cols.clone()]
                                .iter_mut()
                                .zip(&mut row_k1[cols.clone()]);
                            if k != nn - 1 {
                                for ((a, b), c) in pair.zip(&mut rest[cols]) {
                                    let pp = *a + q * *b + r * *c;
                                    *c -= pp * z;
                                    *b -= pp * y;
                                    *a -= pp * x;
                                }
                            } else {
                                for (a, b) in pair {
                                    let pp = *a + q * *b;
                                    *b -= pp * y;
                                    *a -= pp * x;
                                }
                            }
                            // columns k, k+1 (and k+2), rows l..=min(nn, k+3)
                            let width = if k != nn - 1 { 3 } else { 2 };
                            for i in l..=nn.min(k + 3) {
                                let c = &mut h[ix(i, k)..ix(i, k) + width];
                                let mut pp = x * c[0] + y * c[1];
                                if width == 3 {
                                    pp += z * c[2];
                                    c[2] -= pp * r;
                                }
                                c[1] -= pp * q;
                                c[0] -= pp;
                            }
                        }
                        k += 1;
                    }
                }
            }
            if nn < 2 || l + 1 >= nn {
                break;
            }
        }
    }
    if wr.iter().chain(&wi).any(|v| !v.is_finite()) {
        return None;
    }
    Some((1..=n).map(|i| Complex64::new(wr[i], wi[i])).collect())
}

/// All eigenvalues of a general real matrix (row-major): see [`matrix_eigenvalues`].
pub(crate) fn eigenvalues(n: usize, a: &[f64]) -> Option<Vec<Complex64>> {
    matrix_eigenvalues(DMatrix::from_row_slice(n, n, a))
}

/// All eigenvalues of a general real matrix: Householder Hessenberg reduction
/// (nalgebra) and [`hqr`].
pub(crate) fn matrix_eigenvalues(m: DMatrix<f64>) -> Option<Vec<Complex64>> {
    hqr_of(&nalgebra::linalg::Hessenberg::new(m).unpack_h())
}

/// [`matrix_eigenvalues`], or nalgebra's Schur iteration on the same Hessenberg form when
/// [`hqr`] does not converge.
pub(crate) fn eigenvalues_or_schur(m: DMatrix<f64>) -> Vec<Complex64> {
    let hm = nalgebra::linalg::Hessenberg::new(m).unpack_h();
    hqr_of(&hm).unwrap_or_else(|| hm.complex_eigenvalues().iter().copied().collect())
}

/// [`hqr`] of an upper Hessenberg matrix (entries below the subdiagonal ignored).
fn hqr_of(hm: &DMatrix<f64>) -> Option<Vec<Complex64>> {
    let n = hm.nrows();
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        for j in i.saturating_sub(1)..n {
            h[i * n + j] = hm[(i, j)];
        }
    }
    hqr(n, &mut h)
}

/// Roots of the monic polynomial `zⁿ + c[0] zⁿ⁻¹ + … + c[n−1]` as the eigenvalues of its
/// companion matrix (first row `−c`, ones below the diagonal), balanced first as LAPACK's
/// `dgeev` (numpy and MATLAB `roots`) does; a diagonal similarity keeps the Hessenberg
/// form. Should [`hqr`] not converge, nalgebra's Schur iteration on the same matrix.
pub(crate) fn companion_roots(c: &[f64]) -> Vec<Complex64> {
    let n = c.len();
    let mut h = balanced_companion(c);
    hqr(n, &mut h).unwrap_or_else(|| {
        let m = DMatrix::from_row_slice(n, n, &balanced_companion(c));
        m.complex_eigenvalues().iter().copied().collect()
    })
}

/// The balanced companion matrix of [`companion_roots`], row-major.
fn balanced_companion(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    let mut h = vec![0.0; n * n];
    for (j, cj) in c.iter().enumerate() {
        h[j] = -cj;
    }
    for i in 1..n {
        h[i * n + i - 1] = 1.0;
    }
    balance(n, &mut h);
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hqr_matches_nalgebra() {
        let mut lcg = crate::test_util::Lcg(12345);
        let mut rnd = || lcg.uniform();
        for n in [1, 2, 3, 5, 8, 13, 16, 31, 64] {
            let a: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
            let mine = eigenvalues(n, &a).unwrap();
            let theirs = DMatrix::from_row_slice(n, n, &a).complex_eigenvalues();
            assert_eq!(mine.len(), n);
            for e in theirs.iter() {
                let d = mine
                    .iter()
                    .map(|m| (m - e).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(d < 1e-9, "n {n}: {e} not found ({d})");
            }
        }
        // a shift register (nilpotent) plus a rotation block
        let n = 30;
        let mut a = vec![0.0; n * n];
        for i in 1..n - 2 {
            a[i * n + i - 1] = 1.0;
        }
        a[(n - 2) * n + n - 1] = -0.9;
        a[(n - 1) * n + n - 2] = 0.9;
        let e = eigenvalues(n, &a).unwrap();
        let rho = e.iter().map(|z| z.norm()).fold(0.0, f64::max);
        assert!((rho - 0.9).abs() < 1e-12, "{rho}");
    }

    #[test]
    fn companion_roots_match_nalgebra() {
        // z^n + c: roots on circles, a cluster of lightly damped poles near the unit
        // circle (as a stabilization diagram's denominators have) and wide scales.
        let poles: Vec<Complex64> = (0..20)
            .map(|k| Complex64::from_polar(0.999 - 1e-3 * k as f64, 0.05 + 0.15 * k as f64))
            .collect();
        let mut p = vec![Complex64::new(1.0, 0.0)];
        for q in poles.iter().flat_map(|q| [*q, q.conj()]) {
            let mut next = vec![Complex64::new(0.0, 0.0); p.len() + 1];
            for (i, a) in p.iter().enumerate() {
                next[i] += a;
                next[i + 1] -= a * q;
            }
            p = next;
        }
        let c: Vec<f64> = p[1..].iter().map(|z| z.re).collect();
        let companion = |c: &[f64]| {
            let n = c.len();
            let mut m = DMatrix::<f64>::zeros(n, n);
            for j in 0..n {
                m[(0, j)] = -c[j];
            }
            for i in 1..n {
                m[(i, i - 1)] = 1.0;
            }
            m
        };
        let worst = |roots: &[Complex64]| {
            poles
                .iter()
                .map(|q| {
                    roots
                        .iter()
                        .map(|m| (m - q).norm())
                        .fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max)
        };
        let mine = companion_roots(&c);
        assert_eq!(mine.len(), 40);
        let theirs: Vec<Complex64> = companion(&c)
            .complex_eigenvalues()
            .iter()
            .copied()
            .collect();
        // the coefficients alone fix these clustered roots to ~1e-7: as accurate as
        // nalgebra's Schur form of the unbalanced matrix, or better
        let (e_mine, e_theirs) = (worst(&mine), worst(&theirs));
        assert!(e_mine < 1e-6, "{e_mine}");
        eprintln!("clustered roots: worst error {e_mine:.2e} (nalgebra {e_theirs:.2e})");
        assert!(
            e_mine <= 2.0 * e_theirs + 1e-12,
            "{e_mine} vs nalgebra {e_theirs}"
        );
        for c in [vec![2.0, -3.0, 1e-6], vec![0.0, 0.0, -1.0], vec![1e8, 1.0]] {
            let theirs = companion(&c).complex_eigenvalues();
            let mine = companion_roots(&c);
            for e in theirs.iter() {
                let d = mine
                    .iter()
                    .map(|m| (m - e).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(d <= 1e-9 * e.norm().max(1.0), "{c:?}: {e} not found ({d})");
            }
        }
    }
}
