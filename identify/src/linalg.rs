//! Small dense helpers on top of nalgebra: real least squares with column scaling, and
//! the Gram-matrix (normal equations) shortcuts the fitting loops use when the problem is
//! well enough conditioned for them.
//!
//! The fitting loops solve many tall least-squares problems (thousands of rows, tens of
//! columns). A Householder QR of such a matrix costs about five times a matrix product
//! `aᵀa` (which nalgebra hands to the `matrixmultiply` kernels; the callers build the
//! transposed matrix `at` alongside `a`, so that no tall matrix is copied to transpose
//! it). The normal equations
//! square the condition number, so every Gram shortcut here scales the columns to unit
//! norm, checks the smallest Cholesky pivot against [`MIN_PIVOT`] and returns `None` when
//! it is smaller: the caller then takes the QR path. With the pivot bound the Gram
//! result carries a relative error below about `1e-15 / MIN_PIVOT²` = 1e-7.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use num_complex::Complex64;
use std::cell::RefCell;

/// Buffers the fitting loops hand back for reuse (per thread, at most [`POOL_SIZE`]).
/// The loops build tall matrices of a few MB many times; fresh allocations of that size
/// go to the operating system each time (page faults cost as much as the arithmetic).
const POOL_SIZE: usize = 8;

thread_local! {
    static POOL: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

/// A zero `rows × cols` matrix, its buffer taken from this thread's pool when one is
/// large enough.
pub(crate) fn pooled_zeros(rows: usize, cols: usize) -> DMatrix<f64> {
    let n = rows * cols;
    let mut v = POOL
        .with(|p| {
            let mut p = p.borrow_mut();
            let best = (0..p.len())
                .filter(|&i| p[i].capacity() >= n)
                .min_by_key(|&i| p[i].capacity());
            best.map(|i| p.swap_remove(i))
        })
        .unwrap_or_default();
    v.clear();
    v.resize(n, 0.0);
    DMatrix::from_vec(rows, cols, v)
}

/// Hands the buffer of `m` back to this thread's pool (dropped when the pool is full).
pub(crate) fn release(m: DMatrix<f64>) {
    let v: Vec<f64> = m.data.into();
    if v.capacity() < 4096 {
        return;
    }
    POOL.with(|p| {
        let mut p = p.borrow_mut();
        if p.len() < POOL_SIZE {
            p.push(v);
        } else if let Some(i) = (0..p.len()).min_by_key(|&i| p[i].capacity()) {
            if p[i].capacity() < v.capacity() {
                p[i] = v;
            }
        }
    });
}

/// A tall real-form matrix (each frequency line is two rows: real part, imaginary part)
/// and its transpose, written together: the Gram products need `aᵀ` with contiguous
/// rows, the QR fallback needs `a`, and transposing the tall matrix afterwards costs
/// more than writing both. Buffers come from the pool.
pub(crate) struct Tall {
    /// The matrix.
    pub a: DMatrix<f64>,
    /// Its transpose.
    pub at: DMatrix<f64>,
}

impl Tall {
    /// Zeros, `2 × lines` rows, `cols` columns.
    pub(crate) fn zeros(lines: usize, cols: usize) -> Tall {
        Tall {
            a: pooled_zeros(2 * lines, cols),
            at: pooled_zeros(cols, 2 * lines),
        }
    }

    /// Sets the two rows of `line` in column `col` to `z` (real part, imaginary part).
    pub(crate) fn set(&mut self, line: usize, col: usize, z: Complex64) {
        let r = 2 * line;
        self.a[(r, col)] = z.re;
        self.a[(r + 1, col)] = z.im;
        self.at[(col, r)] = z.re;
        self.at[(col, r + 1)] = z.im;
    }

    /// The matrix alone (the transpose's buffer goes back to the pool).
    pub(crate) fn into_a(self) -> DMatrix<f64> {
        release(self.at);
        self.a
    }

    /// Both buffers back to the pool.
    pub(crate) fn release(self) {
        release(self.a);
        release(self.at);
    }
}

/// Smallest pivot of the column-scaled Cholesky factor for which the Gram shortcuts are
/// used (about the reciprocal condition number of the scaled matrix).
pub(crate) const MIN_PIVOT: f64 = 1e-4;

/// The Cholesky factorisation of the column-scaled Gram matrix of `a`, with the column
/// norms: `a = a_s D` (`D` = diag of the column norms), `a_sᵀ a_s = L Lᵀ`.
pub(crate) struct ScaledGram {
    /// Column norms of `a`.
    pub d: Vec<f64>,
    /// Cholesky factorisation of `D⁻¹ aᵀa D⁻¹`.
    pub chol: Cholesky<f64, Dyn>,
}

impl ScaledGram {
    /// Of `t.a`. `None` when a column is zero or not finite, or the smallest pivot is
    /// below [`MIN_PIVOT`].
    pub(crate) fn new(t: &Tall) -> Option<ScaledGram> {
        Self::of_gram(&t.at * &t.a)
    }

    /// From the Gram matrix `aᵀa` itself.
    pub(crate) fn of_gram(g: DMatrix<f64>) -> Option<ScaledGram> {
        let n = g.ncols();
        let d: Vec<f64> = (0..n).map(|j| g[(j, j)].sqrt()).collect();
        if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return None;
        }
        let gs = DMatrix::from_fn(n, n, |i, j| g[(i, j)] / (d[i] * d[j]));
        let chol = gs.cholesky()?;
        let l = chol.l_dirty();
        let min_piv = (0..n).map(|i| l[(i, i)]).fold(f64::INFINITY, f64::min);
        (min_piv >= MIN_PIVOT).then_some(ScaledGram { d, chol })
    }

    /// Least-squares solution of `a x ≈ y` from the normal equations with one step of
    /// iterative refinement on the residual (corrected semi-normal equations); returns
    /// `x` and the residual `y − a x`.
    pub(crate) fn solve(&self, t: &Tall, y: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
        let (a, at) = (&t.a, &t.at);
        let mut x = self.solve_normal(&(at * y));
        let mut r = y - a * &x;
        x += self.solve_normal(&(at * &r));
        r = y - a * &x;
        (x, r)
    }

    /// `(aᵀa)⁻¹ rhs` through the scaled factorisation.
    pub(crate) fn solve_normal(&self, rhs: &DVector<f64>) -> DVector<f64> {
        let n = self.d.len();
        let rs = DVector::from_iterator(n, rhs.iter().zip(&self.d).map(|(v, d)| v / d));
        let xs = self.chol.solve(&rs);
        DVector::from_iterator(n, xs.iter().zip(&self.d).map(|(v, d)| v / d))
    }
}

/// The trailing `(n − k) × (n − k)` block of the `R` factor of the QR of `t.a` (up to the
/// signs of its rows) from the Cholesky factor of the column-scaled Gram matrix: one
/// matrix product instead of a QR of the tall matrix. `None` when the scaled Gram
/// matrix is too ill-conditioned (see the module docs): use the QR.
pub(crate) fn trailing_r(t: &Tall, k: usize) -> Option<DMatrix<f64>> {
    if t.a.nrows() < t.a.ncols() {
        return None;
    }
    trailing_r_of_gram(&t.at * &t.a, k)
}

/// [`trailing_r`] from the Gram matrix `aᵀa` of a matrix with at least as many rows as
/// columns.
pub(crate) fn trailing_r_of_gram(g: DMatrix<f64>, k: usize) -> Option<DMatrix<f64>> {
    let n = g.ncols();
    if k > n {
        return None;
    }
    let g = ScaledGram::of_gram(g)?;
    let l = g.chol.l();
    // R = Lᵀ D (a = a_s D, a_s = Q Lᵀ)
    let out = DMatrix::from_fn(n - k, n - k, |i, j| l[(k + j, k + i)] * g.d[k + j]);
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// Least-squares solution of `a x ≈ b` (a tall, real) by Householder QR after scaling
/// every column to unit norm; falls back to the SVD when `R` is singular.
/// Returns `None` when the problem has no finite solution.
pub(crate) fn lstsq(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let n = a.ncols();
    let mut scaled = a.clone();
    let mut scale = vec![1.0; n];
    for (j, sc) in scale.iter_mut().enumerate() {
        let nrm = scaled.column(j).norm();
        if nrm > 0.0 && nrm.is_finite() {
            *sc = 1.0 / nrm;
            scaled.column_mut(j).scale_mut(*sc);
        }
    }
    let x = if a.nrows() >= n {
        let qr = scaled.clone().qr();
        let mut rhs = b.clone();
        qr.q_tr_mul(&mut rhs);
        let r = qr.r();
        let diag_max = (0..n).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
        let well = (0..n).all(|i| r[(i, i)].abs() > 1e-12 * diag_max);
        if well {
            r.solve_upper_triangular(&rhs.rows(0, n).into_owned())
        } else {
            None
        }
    } else {
        None
    };
    let x = match x {
        Some(x) => x,
        None => {
            let svd = scaled.svd(true, true);
            let eps = 1e-12 * svd.singular_values.max();
            svd.solve(b, eps).ok()?
        }
    };
    let out = DVector::from_iterator(n, x.iter().zip(&scale).map(|(v, s)| v * s));
    out.iter().all(|v| v.is_finite()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tall(rows: usize, cols: usize, seed: u64) -> DMatrix<f64> {
        let mut lcg = crate::test_util::Lcg(seed);
        DMatrix::from_fn(rows, cols, |_, j| lcg.uniform() * 10f64.powi(j as i32 % 4))
    }

    #[test]
    fn trailing_r_matches_the_householder_r_up_to_row_signs() {
        let a = tall(400, 9, 3);
        let k = 4;
        let r = a.clone().qr().r();
        let tall = Tall {
            at: a.transpose(),
            a: a.clone(),
        };
        let t = trailing_r(&tall, k).expect("well conditioned");
        for i in 0..(9 - k) {
            let sign = r[(k + i, k + i)].signum() * t[(i, i)].signum();
            for j in 0..(9 - k) {
                let (x, y) = (r[(k + i, k + j)], sign * t[(i, j)]);
                assert!(
                    (x - y).abs() <= 1e-10 * r[(k + i, k + i)].abs(),
                    "{i},{j}: {x} vs {y}"
                );
            }
        }
    }

    #[test]
    fn gram_shortcuts_refuse_an_ill_conditioned_matrix() {
        let mut a = tall(300, 5, 8);
        // column 4 = column 3 + 1e-9 of noise: cond ~ 1e9
        let c3 = a.column(3).into_owned();
        let c0 = a.column(0).into_owned();
        a.column_mut(4).copy_from(&(c3 + c0 * 1e-9));
        let tall = Tall {
            at: a.transpose(),
            a,
        };
        assert!(ScaledGram::new(&tall).is_none());
        assert!(trailing_r(&tall, 2).is_none());
    }

    #[test]
    fn gram_solve_agrees_with_the_qr_least_squares() {
        let a = tall(500, 7, 5);
        let y = DVector::from_fn(500, |i, _| (i as f64 * 0.37).sin());
        let x_qr = lstsq(&a, &y).unwrap();
        let tall = Tall {
            at: a.transpose(),
            a: a.clone(),
        };
        let g = ScaledGram::new(&tall).unwrap();
        let (x, r) = g.solve(&tall, &y);
        for j in 0..7 {
            assert!(
                (x[j] - x_qr[j]).abs() <= 1e-10 * x_qr[j].abs().max(1e-6),
                "{j}"
            );
        }
        assert!((r - (&y - &a * &x_qr)).norm() <= 1e-10 * y.norm());
    }

    #[test]
    fn lstsq_recovers_exact_solution() {
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 1e6, 2.0, 3e6, 3.0, -1e6, 4.0, 2e6]);
        let x = DVector::from_vec(vec![0.5, -2e-6]);
        let b = &a * &x;
        let y = lstsq(&a, &b).unwrap();
        assert!((y[0] - 0.5).abs() < 1e-12 && (y[1] + 2e-6).abs() < 1e-18);
    }
}
