//! Helpers shared by the tests.
#![allow(dead_code)]

use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// Full-record DFT of a real signal.
pub fn dft(x: &[f64]) -> Vec<Complex64> {
    let mut v: Vec<Complex64> = x.iter().map(|&r| Complex64::new(r, 0.0)).collect();
    FftPlanner::new().plan_fft_forward(v.len()).process(&mut v);
    v
}

/// `|a − b| ≤ abs + rel·|b|`.
pub fn approx_eq(a: f64, b: f64, abs: f64, rel: f64) -> bool {
    (a - b).abs() <= abs + rel * b.abs()
}
