//! One identification: 2 channels, 2000 lines, 8 modes (two closely spaced), 1 % noise;
//! automatic order and with the order given. Prints the fit against the analytic truth
//! once, then times `fit_frf` (target well under 50 ms on one core: run with
//! `RAYON_NUM_THREADS=1`). The inverse-variance weighting finds the two weak high modes
//! that the default coherence weighting leaves below the noise of the largest peak; on
//! the real impact data it is much worse (anti-resonance lines dominate), hence not the
//! default.

use criterion::{criterion_group, criterion_main, Criterion};
use identify::axis::{Axis, Channel};
use identify::frf::{fit_percent, Frf};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
use identify::rational_fit::{fit_frf, FitOptions};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn truth() -> ModalModel {
    let fs = [95.0, 180.0, 410.0, 425.0, 760.0, 1100.0, 1550.0, 1900.0];
    let z = [0.03, 0.02, 0.015, 0.02, 0.025, 0.01, 0.03, 0.05];
    let modes: Vec<Mode> = fs
        .iter()
        .zip(z)
        .map(|(&f, z)| Mode::from_hz(f, z))
        .collect();
    let shape_x = [1.0, 0.4, 0.8, -0.6, 0.5, 0.3, -0.4, 0.2];
    let shape_y = [0.3, 1.0, -0.5, 0.7, 0.6, -0.5, 0.3, 0.4];
    let mass = 50.0;
    let ch = |o: Axis, sh: &[f64; 8]| ChannelModel {
        channel: Channel::new(o, Axis::X),
        num: (0..8)
            .map(|k| ModeNum {
                b0: sh[k] * shape_x[k] / mass,
                b1: 0.0,
            })
            .collect(),
        d: 0.0,
    };
    ModalModel {
        modes,
        channels: vec![ch(Axis::X, &shape_x), ch(Axis::Y, &shape_y)],
    }
}

fn noisy(model: &ModalModel, freqs: &[f64], seed: u64) -> Frf {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut frf = model.frf(freqs);
    for c in &mut frf.channels {
        // noise of 1 % of |H| on every line (an H1 with coherence 0.9999) plus a floor of
        // 0.1 % of the channel's RMS; the coherence it implies
        let rms = (c.h.iter().map(|v| v.norm_sqr()).sum::<f64>() / c.h.len() as f64).sqrt();
        let sigma: Vec<f64> = c.h.iter().map(|v| 0.01 * v.norm() + 1e-3 * rms).collect();
        c.coherence = Some(
            c.h.iter()
                .zip(&sigma)
                .map(|(v, s)| v.norm_sqr() / (v.norm_sqr() + s * s))
                .collect(),
        );
        for (v, s) in c.h.iter_mut().zip(&sigma) {
            let (a, b): (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            // uniform in [-1, 1] has variance 1/3: scale to s per complex line
            *v += Complex64::new(a, b) * (s * 3f64.sqrt() / 2f64.sqrt());
        }
    }
    frf
}

fn bench(c: &mut Criterion) {
    let model = truth();
    let freqs: Vec<f64> = (0..2000).map(|k| 20.0 + k as f64).collect();
    let frf = noisy(&model, &freqs, 7);
    let clean = model.frf(&freqs);
    let auto = FitOptions::default();
    let fixed = FitOptions {
        n_modes: Some(8),
        ..FitOptions::default()
    };
    let iv = FitOptions {
        weighting: identify::rational_fit::Weighting::InverseVariance,
        ..FitOptions::default()
    };
    for (name, o) in [
        ("automatic order", &auto),
        ("order 8", &fixed),
        ("inverse variance", &iv),
    ] {
        let r = fit_frf(&frf, o).expect("fit");
        let fits: Vec<String> = r
            .model
            .channels
            .iter()
            .enumerate()
            .map(|(ci, ch)| {
                let est: Vec<Complex64> = freqs.iter().map(|&f| r.model.eval_hz(ci, f)).collect();
                let ti = clean
                    .channels
                    .iter()
                    .position(|t| t.channel == ch.channel)
                    .expect("channel");
                format!(
                    "{} {:.3} %",
                    ch.channel,
                    fit_percent(&clean.channels[ti].h, &est)
                )
            })
            .collect();
        println!(
            "{name}: {} modes {:?} Hz, fit vs analytic truth: {}",
            r.model.modes.len(),
            r.model
                .modes
                .iter()
                .map(|m| m.freq_hz().round())
                .collect::<Vec<_>>(),
            fits.join(", ")
        );
        if std::env::var_os("MTWIN_BENCH_REPORT").is_some() {
            println!("{}", r.report);
        }
    }
    let mut g = c.benchmark_group("identify_2ch_2000_lines_8_modes");
    g.sample_size(10);
    g.bench_function("automatic_order", |b| {
        b.iter(|| fit_frf(&frf, &auto).expect("fit"))
    });
    g.bench_function("order_8", |b| {
        b.iter(|| fit_frf(&frf, &fixed).expect("fit"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
