//! Small dense helpers on top of nalgebra: real least squares with column scaling.

use nalgebra::{DMatrix, DVector};

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

    #[test]
    fn lstsq_recovers_exact_solution() {
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 1e6, 2.0, 3e6, 3.0, -1e6, 4.0, 2e6]);
        let x = DVector::from_vec(vec![0.5, -2e-6]);
        let b = &a * &x;
        let y = lstsq(&a, &b).unwrap();
        assert!((y[0] - 0.5).abs() < 1e-12 && (y[1] + 2e-6).abs() < 1e-18);
    }
}
