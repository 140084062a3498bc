//! Real impact-hammer test (pyFRF data): textbook H1 over 5 hits, receptance, automatic
//! order, fit of the model to the H1 in 200–4500 Hz where the coherence is > 0.95.

use crate::common::fit::{data_dir, read_npy};
use identify::axis::{Axis, Channel};
use identify::frf::{fit_percent, Frf, FrfChannel};
use identify::rational_fit::{fit_frf, FitOptions};
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Plain H1 = Σ conj(F) A / Σ |F|² and coherence over the hits, lines 0..n/2.
fn h1() -> (Vec<f64>, Vec<Complex64>, Vec<f64>) {
    let dir = data_dir().join("pyfrf_impact_hammer");
    let mut planner = FftPlanner::<f64>::new();
    let mut sfa = Vec::new();
    let mut sff = Vec::new();
    let mut saa = Vec::new();
    let mut fs = 0.0;
    let mut n = 0;
    for i in 1..=5 {
        let (shape, data) = read_npy(&dir.join(format!("measurements_{i}.npy")));
        assert_eq!(shape, vec![3, 25600]);
        n = shape[1];
        let t = &data[..n];
        fs = (n - 1) as f64 / (t[n - 1] - t[0]);
        let fft = planner.plan_fft_forward(n);
        let mut f: Vec<Complex64> = data[n..2 * n].iter().map(|&v| v.into()).collect();
        let mut a: Vec<Complex64> = data[2 * n..3 * n].iter().map(|&v| v.into()).collect();
        fft.process(&mut f);
        fft.process(&mut a);
        if sfa.is_empty() {
            sfa = vec![Complex64::default(); n / 2 + 1];
            sff = vec![0.0; n / 2 + 1];
            saa = vec![0.0; n / 2 + 1];
        }
        for k in 0..=n / 2 {
            sfa[k] += f[k].conj() * a[k];
            sff[k] += f[k].norm_sqr();
            saa[k] += a[k].norm_sqr();
        }
    }
    let df = fs / n as f64;
    let freqs: Vec<f64> = (0..=n / 2).map(|k| k as f64 * df).collect();
    let h: Vec<Complex64> = (0..=n / 2).map(|k| sfa[k] / sff[k]).collect();
    let coh: Vec<f64> = (0..=n / 2)
        .map(|k| sfa[k].norm_sqr() / (sff[k] * saa[k]))
        .collect();
    (freqs, h, coh)
}

#[test]
fn impact_hammer_receptance_fit() {
    let (freqs, acc, coh) = h1();
    assert!((freqs[1] - 1.0).abs() < 1e-6, "1 Hz lines expected");
    let keep: Vec<usize> = (0..freqs.len())
        .filter(|&k| freqs[k] >= 200.0 && freqs[k] <= 4500.0 && coh[k] > 0.95)
        .collect();
    assert!(
        keep.len() > 4000,
        "coherence should be good in most of the band"
    );
    let f: Vec<f64> = keep.iter().map(|&k| freqs[k]).collect();
    let h: Vec<Complex64> = keep
        .iter()
        .map(|&k| {
            let w = 2.0 * PI * freqs[k];
            acc[k] / (-w * w)
        })
        .collect();
    let frf = Frf {
        freqs_hz: f.clone(),
        channels: vec![FrfChannel {
            channel: Channel::new(Axis::X, Axis::X),
            h: h.clone(),
            coherence: Some(keep.iter().map(|&k| coh[k]).collect()),
        }],
    };
    let res = fit_frf(&frf, &FitOptions::default()).unwrap();
    eprintln!("{}", res.report);
    let est: Vec<Complex64> = f.iter().map(|&x| res.model.eval_hz(0, x)).collect();
    let fit = fit_percent(&h, &est);
    eprintln!(
        "impact: {} modes chosen automatically, receptance fit {fit:.3} %",
        res.model.modes.len()
    );
    assert!(res.automatic_order && res.model.is_valid());
    assert!(fit >= 97.0, "fit {fit}");
}
