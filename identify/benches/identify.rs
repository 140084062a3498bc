//! One identification: 2 channels, 2000 lines, 8 modes (two closely spaced), 1 % noise;
//! automatic order and with the order given. Prints the fit against the analytic truth
//! once, then times `fit_frf` (target well under 50 ms on one core: run with
//! `RAYON_NUM_THREADS=1`). The inverse-variance weighting finds the two weak high modes
//! that the default coherence weighting leaves below the noise of the largest peak; on
//! the real impact data it is much worse (anti-resonance lines dominate), hence not the
//! default.

use criterion::{criterion_group, criterion_main, Criterion};
use identify::frf::{fit_percent, Frf};
use identify::model::ModalModel;
use identify::rational_fit::{fit_frf, FitOptions};
use num_complex::Complex64;

fn truth() -> ModalModel {
    vmachine::cases::eight_modes()
}

fn noisy(model: &ModalModel, freqs: &[f64], seed: u64) -> Frf {
    vmachine::cases::noisy_frf(model, freqs, seed)
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
