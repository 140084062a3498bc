//! Relaxed vector fitting with common poles (Gustavsen & Semlyen 1999, relaxation
//! Gustavsen 2006, the fast QR-based multi-channel form of Deschrijver et al. 2008).
//!
//! One iteration is a Sanathanan–Koerner step written in the partial-fraction basis of
//! the current poles: find `σ(s) = d̃ + Σ c̃ᵢ φᵢ(s)` and per channel `Σ rᵢ φᵢ + d` with
//! `W (Σ r φ + d − h σ) ≈ 0` and the relaxation `Re Σₖ σ(sₖ) = N`; the zeros of `σ`
//! (eigenvalues of `A − b c̃ᵀ / d̃`) are the new poles. Unstable poles are flipped
//! into the left half plane. A complex pair `p, p̄` uses the real basis functions
//! `1/(s−p) + 1/(s−p̄)` and `j/(s−p) − j/(s−p̄)`.

use super::data::Prepared;
use super::linalg::{lstsq, trailing_r, Tall};
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
    let phis: Vec<Vec<Complex64>> = (0..nl)
        .map(|k| {
            basis_row(p.s[k], poles, &mut phi);
            phi.clone()
        })
        .collect();
    let n_ch = p.channels.len();
    let mut big = DMatrix::<f64>::zeros(n_ch * m + 1, m);
    let mut row = 0;
    let mut relax_scale = 0.0;
    for ci in 0..n_ch {
        let lines: Vec<usize> = (0..nl).filter(|&k| p.w[ci][k] > 0.0).collect();
        if lines.is_empty() {
            continue;
        }
        let mut d = Tall::zeros(lines.len(), 2 * m);
        for (i, &k) in lines.iter().enumerate() {
            let w = p.w[ci][k];
            let h = p.h[ci][k];
            for (j, f) in phis[k].iter().enumerate() {
                d.set(i, j, f * w);
                d.set(i, m + j, -(f * h) * w);
            }
            d.set(i, nb, Complex64::new(w, 0.0));
            d.set(i, m + nb, -h * w);
            relax_scale += (h * w).norm_sqr();
        }
        if d.a.nrows() < 2 * m {
            // too few lines in this channel for its own unknowns: skip it for σ
            d.release();
            continue;
        }
        // only the σ block of R is needed: from the Gram matrix when it is well
        // conditioned (about 5x faster), else from the Householder QR
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
    let mut sum = vec![0.0; m];
    for ph in &phis {
        for (j, f) in ph.iter().enumerate() {
            sum[j] += f.re;
        }
    }
    sum[nb] = nl as f64;
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
    let eig = h.complex_eigenvalues();
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
