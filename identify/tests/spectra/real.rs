//! The real impact-hammer test (ladisk/pyFRF, 5 hits): hits found, coherence, resonances.

#![allow(clippy::needless_range_loop)] // naive reference code reads best with indices

use crate::common::systems::shared;
use identify::read::read_timeseries;
use identify::spectra::{estimate_frf, Estimator, FrfOptions};

#[test]
fn real_impact_test_five_hits_high_coherence_known_resonances() {
    let ts = read_timeseries(&shared("data/pyfrf_impact_hammer/impact_5hits.csv")).unwrap();
    let est = estimate_frf(std::slice::from_ref(&ts), &FrfOptions::default()).unwrap();
    println!("{}", est.method);
    println!(
        "warnings {:?}\ndropped {:?}",
        est.warnings, est.hits_dropped
    );
    assert!(est.method.contains("impact"));
    assert_eq!(est.hits_used, 5);
    assert!(est.hits_dropped.is_empty());
    let (lo, hi) = est.excitation_band_hz.unwrap();
    println!("force within 20 dB of its peak: {lo:.1}..{hi:.1} Hz");
    assert!(lo < 5.0 && hi > 4500.0, "{lo} {hi}");
    let frf = est.frf.band(200.0, 4500.0);
    let ch = &frf.channels[0];
    let coh = ch.coherence.as_ref().unwrap();
    let good = coh.iter().filter(|&&g| g > 0.99).count() as f64 / coh.len() as f64;
    let mut sorted = coh.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "200-4500 Hz: {:.1} % of lines with coherence > 0.99, median {:.5}, sigma {:?}",
        good * 100.0,
        sorted[sorted.len() / 2],
        est.exp_window_sigma
    );
    assert!(good > 0.9, "{good}");
    assert!(sorted[sorted.len() / 2] > 0.998);
    // Resonances near 810, 900, 2640, 3669, 4128 Hz: a local maximum of |H| within ±2 %
    // that stands above the band edges.
    let mag: Vec<f64> = frf.channels[0].h.iter().map(|z| z.norm()).collect();
    for target in [810.0, 900.0, 2640.0, 3669.0, 4128.0] {
        let idx: Vec<usize> = (0..frf.freqs_hz.len())
            .filter(|&k| (frf.freqs_hz[k] - target).abs() <= 0.02 * target)
            .collect();
        let kmax = *idx
            .iter()
            .max_by(|&&a, &&b| mag[a].total_cmp(&mag[b]))
            .unwrap();
        let f = frf.freqs_hz[kmax];
        println!(
            "resonance near {target}: peak at {f} Hz, |H| {:.3e} m/N",
            mag[kmax]
        );
        assert!(
            kmax != idx[0] && kmax != *idx.last().unwrap(),
            "no peak near {target}"
        );
        assert!(mag[kmax] > 1.3 * mag[idx[0]].max(mag[*idx.last().unwrap()]));
    }
    // H2 and Hv agree with H1 where coherence is high
    for e in [Estimator::H2, Estimator::Hv] {
        let o = estimate_frf(
            std::slice::from_ref(&ts),
            &FrfOptions {
                estimator: e,
                ..Default::default()
            },
        )
        .unwrap()
        .frf
        .band(200.0, 4500.0);
        let d = o.channels[0]
            .h
            .iter()
            .zip(&ch.h)
            .zip(coh)
            .filter(|(_, &g)| g > 0.999)
            .map(|((a, b), _)| (a - b).norm() / b.norm())
            .fold(0.0, f64::max);
        println!("{e:?} vs H1 where coherence > 0.999: max rel. difference {d:.4}");
        assert!(d < 0.05);
    }
}
