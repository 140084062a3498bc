//! Welch H1/H2/Hv against a naive implementation written from the definition (direct
//! O(n²) DFT), over odd, prime and power-of-two lengths; MIMO H1; option errors.

#![allow(clippy::needless_range_loop)] // naive reference code reads best with indices

use crate::common::systems::{approx_eq, record, Noise};
use identify::axis::{Axis, Channel};
use identify::spectra::{estimate_frf, Estimator, Excitation, FrfOptions};
use identify::timeseries::ResponseKind;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Direct DFT lines 1 ..= (n+1)/2 - 1 of `x` (length n).
fn naive_dft(x: &[f64]) -> Vec<Complex64> {
    let n = x.len();
    (1..n.div_ceil(2))
        .map(|k| {
            x.iter()
                .enumerate()
                .map(|(i, &v)| {
                    // k·i reduced modulo n: the same angle, exact at any size
                    v * Complex64::from_polar(1.0, -2.0 * PI * ((k * i) % n) as f64 / n as f64)
                })
                .sum()
        })
        .collect()
}

/// Textbook H1, H2, Hv and coherence with periodic Hann, hop n - round(n/2).
fn naive_welch(f: &[f64], y: &[f64], n: usize) -> [Vec<Complex64>; 4] {
    let w: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos())
        .collect();
    let hop = n - (0.5 * n as f64).round() as usize;
    let nl = n.div_ceil(2) - 1;
    let (mut gff, mut gyy) = (vec![0.0; nl], vec![0.0; nl]);
    let mut gfy = vec![Complex64::new(0.0, 0.0); nl];
    let mut s = 0;
    while s + n <= f.len() {
        let fw: Vec<f64> = (0..n).map(|i| f[s + i] * w[i]).collect();
        let yw: Vec<f64> = (0..n).map(|i| y[s + i] * w[i]).collect();
        let (fk, yk) = (naive_dft(&fw), naive_dft(&yw));
        for k in 0..nl {
            gff[k] += fk[k].norm_sqr();
            gyy[k] += yk[k].norm_sqr();
            gfy[k] += fk[k].conj() * yk[k];
        }
        s += hop;
    }
    let h1 = (0..nl).map(|k| gfy[k] / gff[k]).collect();
    let h2 = (0..nl).map(|k| gyy[k] / gfy[k].conj()).collect();
    // Hv: eigenvector of the smallest eigenvalue of [[Gff, Gyf], [Gfy, Gyy]] (TLS).
    let hv = (0..nl)
        .map(|k| {
            let (a, d, b) = (gff[k], gyy[k], gfy[k]);
            let lmin = 0.5 * (a + d) - (0.25 * (a - d) * (a - d) + b.norm_sqr()).sqrt();
            // (C - lmin) v = 0 with C = [[a, conj(b)], [b, d]]: v = [conj(b), lmin - a]
            // wᴴz = 0 ⇒ Y = -conj(w1/w2) F
            let (v1, v2) = (b.conj(), Complex64::new(lmin - a, 0.0));
            -(v1 / v2).conj()
        })
        .collect();
    let coh = (0..nl)
        .map(|k| Complex64::new(gfy[k].norm_sqr() / (gff[k] * gyy[k]), 0.0))
        .collect();
    [h1, h2, hv, coh]
}

/// A response that is not a pure gain: FIR filter of the force plus noise.
fn test_signals(len: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut noise = Noise::new(seed);
    let f = noise.vec(len, 3.0);
    let taps = [0.5, -0.3, 0.2, 0.1, -0.05];
    let y: Vec<f64> = (0..len)
        .map(|i| {
            let s: f64 = taps
                .iter()
                .enumerate()
                .filter(|(j, _)| *j <= i)
                .map(|(j, t)| t * f[i - j])
                .sum();
            1e-6 * (s + 0.3 * noise.gauss())
        })
        .collect();
    (f, y)
}

#[test]
fn welch_matches_naive_definition() {
    let dt = 1e-3;
    // 4099 and 4100 points: 2049 lines, one past a chunk of the parallel accumulation;
    // 4097: 2048 lines, exactly one chunk
    let sizes = [
        (64, 1000),
        (97, 1009),
        (100, 777),
        (128, 129),
        (31, 500),
        (4099, 8300),
        (4100, 9000),
        (4097, 6200),
    ];
    for (n, len) in sizes {
        let (f, y) = test_signals(len, n as u64);
        let naive = naive_welch(&f, &y, n);
        for (e, est) in [Estimator::H1, Estimator::H2, Estimator::Hv]
            .into_iter()
            .enumerate()
        {
            let opts = FrfOptions {
                estimator: est,
                excitation: Excitation::Continuous,
                nfft: Some(n),
                ..FrfOptions::default()
            };
            let r = record(dt, f.clone(), y.clone(), ResponseKind::Displacement);
            let out = estimate_frf(&[r], &opts).unwrap();
            let ch = &out.frf.channels[0];
            assert_eq!(ch.channel, Channel::new(Axis::X, Axis::X));
            let nl = n.div_ceil(2) - 1;
            assert_eq!(out.frf.freqs_hz.len(), nl);
            assert!((out.df_hz - 1.0 / (n as f64 * dt)).abs() < 1e-12);
            for k in 0..nl {
                assert!((out.frf.freqs_hz[k] - (k + 1) as f64 * out.df_hz).abs() < 1e-9);
                assert!(
                    approx_eq(ch.h[k], naive[e][k], 0.0, 1e-9),
                    "n {n} {est:?} line {k}: {} vs {}",
                    ch.h[k],
                    naive[e][k]
                );
                let g = ch.coherence.as_ref().unwrap()[k];
                assert!(
                    (g - naive[3][k].re).abs() < 1e-9,
                    "coherence n {n} line {k}"
                );
            }
            assert_eq!(
                out.hits_used,
                (len - n) / (n - (0.5 * n as f64).round() as usize) + 1
            );
        }
    }
}

#[test]
fn acceleration_is_divided_by_minus_omega_squared() {
    let dt = 1.0 / 1024.0;
    let (f, y) = test_signals(2048, 7);
    let opts = FrfOptions {
        excitation: Excitation::Continuous,
        nfft: Some(256),
        ..FrfOptions::default()
    };
    let d = estimate_frf(
        &[record(dt, f.clone(), y.clone(), ResponseKind::Displacement)],
        &opts,
    )
    .unwrap();
    let a = estimate_frf(&[record(dt, f, y, ResponseKind::Acceleration)], &opts).unwrap();
    for (k, fr) in d.frf.freqs_hz.iter().enumerate() {
        let w = 2.0 * PI * fr;
        let expect = d.frf.channels[0].h[k] / (-w * w);
        assert!(approx_eq(a.frf.channels[0].h[k], expect, 0.0, 1e-12));
    }
    assert!(d.frf.freqs_hz[0] > 0.0, "0 Hz excluded");
}

#[test]
fn records_with_the_same_input_are_averaged() {
    let dt = 1e-3;
    let (f, y) = test_signals(2000, 3);
    let n = 128;
    let opts = FrfOptions {
        excitation: Excitation::Continuous,
        nfft: Some(n),
        ..FrfOptions::default()
    };
    let whole = estimate_frf(
        &[
            record(
                dt,
                f[..1024].to_vec(),
                y[..1024].to_vec(),
                ResponseKind::Displacement,
            ),
            record(
                dt,
                f[1024..].to_vec(),
                y[1024..].to_vec(),
                ResponseKind::Displacement,
            ),
        ],
        &opts,
    )
    .unwrap();
    // naive: accumulate both parts
    let (a, b) = (
        naive_welch(&f[..1024], &y[..1024], n),
        naive_welch(&f[1024..], &y[1024..], n),
    );
    // H1 of the sum = (Gfy_a + Gfy_b)/(Gff_a + Gff_b); check via the averages count and
    // that the estimate lies between per-part estimates' weighted combination.
    assert_eq!(whole.hits_used, 15 + 14);
    let h = &whole.frf.channels[0].h;
    for k in 0..h.len() {
        // the combined estimate is close to both parts (same system)
        assert!((h[k] - a[0][k]).norm() < 0.5 * a[0][k].norm() + 1e-7);
        assert!((h[k] - b[0][k]).norm() < 0.5 * b[0][k].norm() + 1e-7);
    }
}

#[test]
fn mimo_h1_separates_two_uncorrelated_inputs() {
    let dt = 1e-3;
    let len = 8192;
    let mut noise = Noise::new(11);
    let fx = noise.vec(len, 10.0);
    let fy = noise.vec(len, 7.0);
    // static gains + one-sample delay on the y path
    let dx: Vec<f64> = (0..len)
        .map(|i| 2e-6 * fx[i] + 3e-6 * if i > 0 { fy[i - 1] } else { 0.0 })
        .collect();
    let mut r = record(dt, fx, dx, ResponseKind::Displacement);
    r.force[1] = Some(fy);
    let out = estimate_frf(
        &[r],
        &FrfOptions {
            excitation: Excitation::Continuous,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(out.frf.channels.len(), 2);
    let xx = out.frf.channel(Channel::new(Axis::X, Axis::X)).unwrap();
    let xy = out.frf.channel(Channel::new(Axis::X, Axis::Y)).unwrap();
    for (k, f) in out.frf.freqs_hz.iter().enumerate() {
        let delay = Complex64::from_polar(1.0, -2.0 * PI * f * dt);
        assert!(
            approx_eq(xx.h[k], Complex64::new(2e-6, 0.0), 1e-9, 0.02),
            "{k}"
        );
        assert!(approx_eq(xy.h[k], 3e-6 * delay, 1e-9, 0.02), "{k}");
        assert!(xx.coherence.as_ref().unwrap()[k] > 0.99);
    }
    // H2 is refused for several inputs
    let mut r = record(dt, vec![1.0; 64], vec![1.0; 64], ResponseKind::Displacement);
    r.force[0] = Some(Noise::new(1).vec(4096, 1.0));
    r.force[1] = Some(Noise::new(2).vec(4096, 1.0));
    r.response[0] = Some(Noise::new(3).vec(4096, 1.0));
    let e = estimate_frf(
        &[r],
        &FrfOptions {
            estimator: Estimator::H2,
            excitation: Excitation::Continuous,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("H1"), "{e}");
}

#[test]
fn auto_nfft_rule_and_fmax() {
    let dt = 1.0 / 2048.0;
    let (f, y) = test_signals(20_000, 5);
    let out = estimate_frf(
        &[record(dt, f, y, ResponseKind::Displacement)],
        &FrfOptions {
            fmax_hz: Some(300.0),
            ..Default::default()
        },
    )
    .unwrap();
    // largest power of two with >= 8 averages at 50 % overlap: 4096 (8 segments)
    assert!(out.method.contains("Welch"), "{}", out.method);
    assert!((out.df_hz - 0.5).abs() < 1e-12, "{}", out.df_hz);
    assert!(out.hits_used >= 8);
    assert!(*out.frf.freqs_hz.last().unwrap() <= 300.0);
    assert!(out.exp_window_sigma.is_none());
}

#[test]
fn bad_inputs_are_clear_errors() {
    let dt = 1e-3;
    assert!(estimate_frf(&[], &FrfOptions::default()).is_err());
    let zero = record(
        dt,
        vec![0.0; 100],
        vec![1.0; 100],
        ResponseKind::Displacement,
    );
    let e = estimate_frf(&[zero], &FrfOptions::default()).unwrap_err();
    assert!(e.is_bad_input() && e.to_string().contains("force"), "{e}");
    let (f, y) = test_signals(1000, 1);
    let a = record(dt, f.clone(), y.clone(), ResponseKind::Displacement);
    let b = record(dt * 2.0, f, y, ResponseKind::Displacement);
    let e = estimate_frf(&[a, b], &FrfOptions::default()).unwrap_err();
    assert!(e.to_string().contains("sample rate"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    /// Whatever the data and options: a clean error or finite output, never a panic;
    /// the grid is strictly increasing and excludes 0 Hz.
    #[test]
    fn never_panics(
        len in 16usize..400,
        seed in 0u64..1000,
        exc in 0usize..4,
        est in 0usize..3,
        nfft in proptest::option::of(1usize..500),
        spike in proptest::bool::ANY,
        acc in proptest::bool::ANY,
    ) {
        let mut noise = Noise::new(seed);
        let mut f = noise.vec(len, 1.0);
        if spike {
            for v in f.iter_mut() { *v *= 0.01; }
            f[len / 3] = 50.0;
        }
        let y = noise.vec(len, 1e-6);
        let kind = if acc { ResponseKind::Acceleration } else { ResponseKind::Displacement };
        let opts = FrfOptions {
            excitation: [Excitation::Auto, Excitation::Impact, Excitation::Continuous, Excitation::Chirp][exc],
            estimator: [Estimator::H1, Estimator::H2, Estimator::Hv][est],
            nfft,
            ..FrfOptions::default()
        };
        if let Ok(out) = estimate_frf(&[record(1e-3, f, y, kind)], &opts) {
            proptest::prop_assert!(out.frf.freqs_hz.first().is_some_and(|&f0| f0 > 0.0));
            proptest::prop_assert!(out.frf.freqs_hz.windows(2).all(|w| w[1] > w[0]));
            for c in &out.frf.channels {
                proptest::prop_assert_eq!(c.h.len(), out.frf.freqs_hz.len());
                proptest::prop_assert!(c.h.iter().all(|z| z.re.is_finite() && z.im.is_finite()));
                proptest::prop_assert!(c.coherence.as_ref().unwrap().iter().all(|g| (0.0..=1.0).contains(g)));
            }
        }
    }
}
