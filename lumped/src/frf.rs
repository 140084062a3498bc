//! The analytic truth: receptance `G (K − ω²M + iωC)⁻¹ Gᵀ` at the TCP.

use crate::structure::{Assembly, Machine, Pose};
use nalgebra::{DMatrix, Matrix3};
use num_complex::Complex64;

/// Axis letters of the TCP channels.
pub const AXES: [char; 3] = ['x', 'y', 'z'];

/// Receptance matrices at a list of frequencies: `h[i][(out, in)]` in m/N.
#[derive(Clone, Debug)]
pub struct Frf {
    /// The pose.
    pub pose: Pose,
    /// Frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// 3×3 receptance per frequency, `(out, in)`.
    pub h: Vec<Matrix3<Complex64>>,
}

impl Frf {
    /// One channel, e.g. `channel(1, 0)` = `yx` (response y per force x).
    pub fn channel(&self, out: usize, inp: usize) -> Vec<Complex64> {
        self.h.iter().map(|m| m[(out, inp)]).collect()
    }
}

impl Assembly {
    /// Exact receptance at `f_hz` (3×3, `(out, in)`, m/N).
    pub fn receptance(&self, f_hz: f64) -> Matrix3<Complex64> {
        let w = 2.0 * std::f64::consts::PI * f_hz;
        let n = self.n();
        let z = DMatrix::from_fn(n, n, |i, j| {
            Complex64::new(self.k[(i, j)] - w * w * self.m[(i, j)], w * self.c[(i, j)])
        });
        let gt = self.g.transpose().map(|v| Complex64::new(v, 0.0));
        let x = z
            .lu()
            .solve(&gt)
            .unwrap_or_else(|| DMatrix::from_element(n, 3, Complex64::new(f64::NAN, f64::NAN)));
        let g = self.g.map(|v| Complex64::new(v, 0.0));
        let h = g * x;
        Matrix3::from_fn(|i, j| h[(i, j)])
    }
}

impl Machine {
    /// The exact receptance at `pose` for each frequency (no sensor mass).
    pub fn analytic_frf(&self, pose: Pose, freqs_hz: &[f64]) -> Frf {
        self.analytic_frf_loaded(pose, freqs_hz, 0.0)
    }

    /// The exact receptance with a point mass `tip_mass` (kg) at the tool tip (what an
    /// accelerometer of that mass sees).
    pub fn analytic_frf_loaded(&self, pose: Pose, freqs_hz: &[f64], tip_mass: f64) -> Frf {
        let asm = self.assemble(pose, tip_mass);
        Frf {
            pose,
            freqs_hz: freqs_hz.to_vec(),
            h: freqs_hz.iter().map(|&f| asm.receptance(f)).collect(),
        }
    }
}

/// `n` frequencies evenly spaced from `lo` to `hi` (inclusive).
pub fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}
