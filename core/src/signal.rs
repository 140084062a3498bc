//! Record slicing and the second derivative of sampled signals, below `refit`,
//! `output_error` and `diagnose`.

use crate::timeseries::TimeSeries;

/// Sub-record of samples `a..b`.
pub fn slice(ts: &TimeSeries, a: usize, b: usize) -> TimeSeries {
    let cut = |v: &Option<Vec<f64>>| v.as_ref().map(|x| x[a..b].to_vec());
    TimeSeries {
        source: ts.source.clone(),
        t0: ts.t0 + a as f64 * ts.dt,
        dt: ts.dt,
        force: [cut(&ts.force[0]), cut(&ts.force[1]), cut(&ts.force[2])],
        response: [
            cut(&ts.response[0]),
            cut(&ts.response[1]),
            cut(&ts.response[2]),
        ],
        response_kind: ts.response_kind,
        position: [
            cut(&ts.position[0]),
            cut(&ts.position[1]),
            cut(&ts.position[2]),
        ],
        comments: ts.comments.clone(),
    }
}

/// Half-length of the second-derivative kernel of [`second_derivative`].
const D2_HALF: usize = 8;

/// Taps `c_0, c_1..c_K` of a symmetric second-derivative FIR of half-length `k` (units of
/// 1/dt²): the band-limited (sinc-interpolation) kernel `c_j = −2(−1)^j / j²`, tapered by
/// `cos²(πj / 2(k+1))`, with `c_0` set so the gain at 0 Hz is exactly zero. `k = 1` is
/// the central difference `[1, −2, 1]`.
fn d2_kernel(k: usize) -> Vec<f64> {
    if k <= 1 {
        return vec![-2.0, 1.0];
    }
    let mut c = vec![0.0; k + 1];
    for (j, cj) in c.iter_mut().enumerate().skip(1) {
        let jf = j as f64;
        let sign = if j % 2 == 0 { -1.0 } else { 1.0 };
        let taper = (std::f64::consts::PI * jf / (2.0 * (k as f64 + 1.0)))
            .cos()
            .powi(2);
        *cj = 2.0 * sign / (jf * jf) * taper;
    }
    c[0] = -2.0 * c[1..].iter().sum::<f64>();
    c
}

/// Acceleration from sampled displacement: a symmetric FIR second derivative (half-length
/// 8) whose gain is `−ω²` within 0.1 % up to 0.77 of the Nyquist frequency (the central
/// difference `[1, −2, 1]/dt²` falls short by `(2 − 2cos ωdt)/(ωdt)²`: 4 % at a tenth of
/// the sample rate, 37 % at 0.37 fs, a misfit in every accelerometer comparison that the
/// twin did not make); near the ends the widest symmetric kernel that fits, the end
/// samples copied.
pub fn second_derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut a = vec![0.0; n];
    if n < 3 {
        return a;
    }
    let kernels: Vec<Vec<f64>> = (0..=D2_HALF).map(d2_kernel).collect();
    let inv = 1.0 / (dt * dt);
    for i in 1..n - 1 {
        let k = D2_HALF.min(i).min(n - 1 - i);
        let c = &kernels[k];
        let mut v = c[0] * x[i];
        for (j, cj) in c.iter().enumerate().skip(1) {
            v += cj * (x[i + j] + x[i - j]);
        }
        a[i] = v * inv;
    }
    a[0] = a[1];
    a[n - 1] = a[n - 2];
    a
}

#[cfg(test)]
mod d2_tests {
    use super::*;

    /// The FIR's gain against the exact −ω² at frequencies across the band: within
    /// 0.1 % up to 0.75 Nyquist (the central difference is 37 % short at 0.75 Nyquist).
    #[test]
    fn second_derivative_of_a_sine_is_exact_to_most_of_nyquist() {
        let dt = 1.0 / 10240.0;
        for frac in [0.05, 0.2, 0.4, 0.6, 0.75] {
            let f = frac * 5120.0;
            let w = 2.0 * std::f64::consts::PI * f;
            let x: Vec<f64> = (0..400).map(|i| (w * i as f64 * dt).sin()).collect();
            let a = second_derivative(&x, dt);
            for i in 20..380 {
                let exact = -w * w * x[i];
                assert!(
                    (a[i] - exact).abs() <= 1e-3 * w * w,
                    "{f} Hz, sample {i}: {} vs {exact}",
                    a[i]
                );
            }
        }
        // a constant and a ramp have no acceleration, also at the ends
        let ramp: Vec<f64> = (0..50).map(|i| 3.0 + 0.5 * i as f64).collect();
        assert!(second_derivative(&ramp, 1.0).iter().all(|v| v.abs() < 1e-9));
    }
}
