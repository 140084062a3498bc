//! Hits that ring into the next: a free decay's modal amplitudes by least squares over
//! known poles, and its continuation in time.
//!
//! Between two hits the response is a free decay, a sum of the modes' damped
//! oscillations `Re(c e^{p t})`. With the poles `p` of a first fit, the amplitudes `c`
//! are a linear least-squares problem over the measured samples; continued past the
//! window, the decay is what an earlier hit adds to the next hit's record (its
//! "ring-in"), or what a hit's record lacks after the next hit cuts it (its "ring-out").
//! Only the poles come from the model; the amplitudes come from the data each time.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Relative singular-value cut of the normal equations (columns scaled to unit norm).
const RCOND: f64 = 1e-10;
/// A mode's fitted amplitude is kept when its Wald statistic (two degrees of freedom)
/// against the residual's noise at the mode's frequency exceeds this (about 4 σ).
const SIGNIFICANT_CHI2: f64 = 16.0;
/// Lines of the residual's spectrum on each side of a mode that set its noise level.
const NOISE_LINES: usize = 8;

/// The modes hits are separated by: every pole of a first fit (upper half plane,
/// rad/s) spans the free decays; only those marked `continued` (the modes that ring
/// into the next hit where the data see them) are taken off or continued.
#[derive(Debug, Clone, PartialEq)]
pub struct HitSeparation {
    /// The poles.
    pub poles: Vec<Complex64>,
    /// Per pole: continued past its window.
    pub continued: Vec<bool>,
}

/// A fitted free decay: `y(i) = Σ_m a_m Re(e^{p_m (i - origin) dt}) + b_m Im(...)`.
pub(super) struct FreeDecay {
    /// Per pole: `e^{p dt}` and the two coefficients.
    terms: Vec<(Complex64, f64, f64)>,
    origin: usize,
}

impl FreeDecay {
    /// Least-squares fit of `y[lo..hi]` over `poles` (upper half plane, rad/s); only the
    /// modes marked in `keep` whose amplitude stands out of the residual's noise at their
    /// frequency (a Wald test, [`SIGNIFICANT_CHI2`]) are continued, the others only
    /// absorb what they explain. `None` when the window is too short for the unknowns or
    /// no kept mode is significant.
    pub(super) fn fit(
        y: &[f64],
        lo: usize,
        hi: usize,
        poles: &[Complex64],
        keep: &[bool],
        dt: f64,
    ) -> Option<FreeDecay> {
        let hi = hi.min(y.len());
        let m = 2 * poles.len();
        if poles.is_empty() || hi <= lo || hi - lo < 4 * m.max(4) {
            return None;
        }
        let steps: Vec<Complex64> = poles.iter().map(|p| (p * dt).exp()).collect();
        // columns: Re and Im of e^{p (i - lo) dt}; accumulate the normal equations
        let mut g = DMatrix::<f64>::zeros(m, m);
        let mut r = DVector::<f64>::zeros(m);
        let mut z: Vec<Complex64> = vec![Complex64::new(1.0, 0.0); poles.len()];
        let mut row = vec![0.0; m];
        for &v in &y[lo..hi] {
            for (k, zk) in z.iter().enumerate() {
                row[2 * k] = zk.re;
                row[2 * k + 1] = zk.im;
            }
            for a in 0..m {
                if row[a] == 0.0 {
                    continue;
                }
                r[a] += row[a] * v;
                for b in a..m {
                    g[(a, b)] += row[a] * row[b];
                }
            }
            for (zk, s) in z.iter_mut().zip(&steps) {
                *zk *= s;
            }
        }
        for a in 0..m {
            for b in 0..a {
                g[(a, b)] = g[(b, a)];
            }
        }
        // unit-norm columns, then a truncated pseudo-inverse
        let scale: Vec<f64> = (0..m)
            .map(|a| {
                let d = g[(a, a)].sqrt();
                if d > 0.0 {
                    1.0 / d
                } else {
                    0.0
                }
            })
            .collect();
        for a in 0..m {
            r[a] *= scale[a];
            for b in 0..m {
                g[(a, b)] *= scale[a] * scale[b];
            }
        }
        let svd = g.svd(true, true);
        let top = svd.singular_values.max();
        if !(top.is_finite() && top > 0.0) {
            return None;
        }
        let x = svd.solve(&r, RCOND * top).ok()?;
        // covariance shape of the scaled coefficients: the pseudo-inverse of g
        let ginv = svd.pseudo_inverse(RCOND * top).ok()?;
        let coef: Vec<f64> = (0..m).map(|a| x[a] * scale[a]).collect();
        // the residual, for the noise level at each kept mode's frequency
        let mut resid = Vec::with_capacity(hi - lo);
        let mut z: Vec<Complex64> = vec![Complex64::new(1.0, 0.0); poles.len()];
        for &v in &y[lo..hi] {
            let mut fit = 0.0;
            for (k, zk) in z.iter_mut().enumerate() {
                fit += coef[2 * k] * zk.re + coef[2 * k + 1] * zk.im;
                *zk *= steps[k];
            }
            resid.push(v - fit);
        }
        let len = resid.len() as f64;
        let mut terms = Vec::new();
        for (k, p) in poles.iter().enumerate() {
            if !keep.get(k).copied().unwrap_or(false) {
                continue;
            }
            // white-equivalent noise variance at the mode: mean |R(f)|² / N over the
            // lines around it
            let df = 1.0 / (len * dt);
            let f0 = p.im / (2.0 * std::f64::consts::PI);
            let mut power = 0.0;
            let mut lines = 0.0f64;
            for j in -(NOISE_LINES as i64)..=NOISE_LINES as i64 {
                let f = f0 + j as f64 * df;
                if f <= 0.0 {
                    continue;
                }
                let w = Complex64::new(0.0, -2.0 * std::f64::consts::PI * f * dt).exp();
                let mut acc = Complex64::new(0.0, 0.0);
                let mut rot = Complex64::new(1.0, 0.0);
                for &v in &resid {
                    acc += rot * v;
                    rot *= w;
                }
                power += acc.norm_sqr() / len;
                lines += 1.0;
            }
            let sigma2 = power / lines.max(1.0);
            // Wald statistic of (a, b) in scaled coordinates: x' C⁻¹ x, C = σ² g⁻¹
            let (i, j) = (2 * k, 2 * k + 1);
            let (caa, cab, cbb) = (ginv[(i, i)], ginv[(i, j)], ginv[(j, j)]);
            let det = caa * cbb - cab * cab;
            if det <= 0.0 {
                continue;
            }
            let (xa, xb) = (x[i], x[j]);
            let chi2 = (cbb * xa * xa - 2.0 * cab * xa * xb + caa * xb * xb) / det / sigma2;
            let chi2 = if chi2.is_nan() { 0.0 } else { chi2 };
            if chi2 > SIGNIFICANT_CHI2 {
                terms.push((steps[k], coef[i], coef[j]));
            }
        }
        if terms.is_empty() || terms.iter().any(|t| !(t.1.is_finite() && t.2.is_finite())) {
            return None;
        }
        Some(FreeDecay { terms, origin: lo })
    }

    /// The decay at samples `from..from + out.len()` (same index frame as the fit),
    /// added to `out` times `factor`.
    pub(super) fn add_to(&self, from: usize, out: &mut [f64], factor: f64) {
        if from < self.origin {
            return;
        }
        let steps = (from - self.origin) as i32;
        for &(s, a, b) in &self.terms {
            if a == 0.0 && b == 0.0 {
                continue;
            }
            let mut z = s.powi(steps);
            for o in out.iter_mut() {
                if z.norm_sqr() < 1e-40 {
                    break;
                }
                *o += factor * (a * z.re + b * z.im);
                z *= s;
            }
        }
    }
}

/// A mode whose envelope keeps more than this fraction after a hit's record length
/// rings into the next hit.
pub const RINGING_LEVEL: f64 = 0.01;

/// Samples after which every pole's envelope has fallen below `level`, at most `cap`.
pub(super) fn decay_samples(poles: &[Complex64], dt: f64, level: f64, cap: usize) -> usize {
    poles
        .iter()
        .map(|p| {
            let rate = -p.re;
            if rate <= 0.0 {
                cap
            } else {
                ((-level.ln()) / (rate * dt)).ceil().min(cap as f64) as usize
            }
        })
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_free_decay_is_continued_from_its_poles() {
        let dt = 1e-4;
        let poles = [
            Complex64::new(-6.9, 2.0 * std::f64::consts::PI * 58.0),
            Complex64::new(-60.0, 2.0 * std::f64::consts::PI * 830.0),
        ];
        let y: Vec<f64> = (0..6000)
            .map(|i| {
                let t = i as f64 * dt;
                0.3 * (poles[0] * t).exp().re - 0.1 * (poles[0] * t).exp().im
                    + 2.0 * (poles[1] * t).exp().im
            })
            .collect();
        let fd = FreeDecay::fit(&y, 500, 3000, &poles, &[true, true], dt).expect("fit");
        let mut out = vec![0.0; 3000];
        fd.add_to(3000, &mut out, 1.0);
        let err = out
            .iter()
            .zip(&y[3000..])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
        assert_eq!(decay_samples(&poles, dt, 1e-3, 100_000), 10012);
    }
}
