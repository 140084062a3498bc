//! Helpers of the fit tests: seeded noise, .npy and complex-text readers, a textbook H1
//! estimate.

use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

pub use super::data_dir;

/// Adds complex Gaussian noise of relative RMS `rel` (per line, relative to |h|).
pub fn add_noise(h: &[Complex64], rel: f64, seed: u64) -> Vec<Complex64> {
    let mut rng = StdRng::seed_from_u64(seed);
    h.iter()
        .map(|v| {
            let (a, b) = gauss_pair(&mut rng);
            v + Complex64::new(a, b) * (v.norm() * rel / std::f64::consts::SQRT_2)
        })
        .collect()
}

/// Two independent standard normal numbers (Box–Muller).
pub fn gauss_pair(rng: &mut StdRng) -> (f64, f64) {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen::<f64>();
    let r = (-2.0 * u1.ln()).sqrt();
    let t = 2.0 * std::f64::consts::PI * u2;
    (r * t.cos(), r * t.sin())
}

/// Reads a little-endian float64 C-order .npy file; returns (shape, data).
pub fn read_npy(path: &std::path::Path) -> (Vec<usize>, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY", "not a .npy file");
    let major = bytes[6];
    let (hlen, start) = if major == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        )
    };
    let header = std::str::from_utf8(&bytes[start..start + hlen]).unwrap();
    assert!(header.contains("'descr': '<f8'"), "header {header}");
    assert!(header.contains("'fortran_order': False"), "header {header}");
    let sh = header.split("'shape': (").nth(1).unwrap();
    let sh = &sh[..sh.find(')').unwrap()];
    let shape: Vec<usize> = sh
        .split(',')
        .filter(|t| !t.trim().is_empty())
        .map(|t| t.trim().parse().unwrap())
        .collect();
    let body = &bytes[start + hlen..];
    let n: usize = shape.iter().product();
    assert_eq!(body.len(), 8 * n, "body size");
    let data = body
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (shape, data)
}

/// Fit (paper eq. 5) of `model` channel `ci` against `truth` on `freqs`.
pub fn fit_vs(
    model: &identify::model::ModalModel,
    ci: usize,
    freqs: &[f64],
    truth: &[Complex64],
) -> f64 {
    let est: Vec<Complex64> = freqs.iter().map(|&f| model.eval_hz(ci, f)).collect();
    identify::frf::fit_percent(truth, &est)
}
