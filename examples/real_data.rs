//! mtwin on REAL measured data (../shared/data): the impact-hammer test and the
//! pyuff measured accelerances.
//!
//! Run: `cargo run --release --example real_data` (from the repository root; the data
//! folder is found at `../shared/data` or `$MTWIN_DATA`).
//!
//! 1. Impact hammer, 5 hits (`impact_5hits.csv`): mtwin's FRF estimate (hit detection,
//!    force/exponential windows, H1, coherence), automatic order, rational fit in
//!    200–4500 Hz; the model is scored against a *plain per-hit H1 of the raw data*
//!    (no windows) where its coherence is > 0.95, as receptance.
//! 2. pyuff's three measured accelerances (roving hammer on a free-free beam): each fitted
//!    on its own, 20–1000 Hz, automatic order; the fit against the measured receptance.

use identify::axis::{Axis, Channel};
use identify::frf::{fit_percent, Frf, FrfChannel};
use identify::rational_fit::{fit_frf, FitOptions};
use identify::read::{accelerance_to_receptance, read_complex_lines, read_timeseries};
use identify::spectra::{estimate_frf, FrfOptions};
use num_complex::Complex64;
use std::f64::consts::PI;
use std::path::PathBuf;
use std::time::Instant;

fn data_dir() -> PathBuf {
    std::env::var_os("MTWIN_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"))
}

/// Plain H1 = Σ conj(F) A / Σ |F|² with coherence, one FFT per hit (1 s records).
fn plain_h1(fx: &[f64], ax: &[f64], n: usize, fs: f64) -> (Vec<f64>, Vec<Complex64>, Vec<f64>) {
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let hits = fx.len() / n;
    let mut sfa = vec![Complex64::default(); n / 2 + 1];
    let mut sff = vec![0.0; n / 2 + 1];
    let mut saa = vec![0.0; n / 2 + 1];
    for h in 0..hits {
        let mut f: Vec<Complex64> = fx[h * n..(h + 1) * n].iter().map(|&v| v.into()).collect();
        let mut a: Vec<Complex64> = ax[h * n..(h + 1) * n].iter().map(|&v| v.into()).collect();
        fft.process(&mut f);
        fft.process(&mut a);
        for k in 0..=n / 2 {
            sfa[k] += f[k].conj() * a[k];
            sff[k] += f[k].norm_sqr();
            saa[k] += a[k].norm_sqr();
        }
    }
    let freqs = (0..=n / 2).map(|k| k as f64 * fs / n as f64).collect();
    let h = (0..=n / 2).map(|k| sfa[k] / sff[k]).collect();
    let coh = (0..=n / 2)
        .map(|k| sfa[k].norm_sqr() / (sff[k] * saa[k]))
        .collect();
    (freqs, h, coh)
}

fn impact() -> Result<(), Box<dyn std::error::Error>> {
    let path = data_dir().join("pyfrf_impact_hammer/impact_5hits.csv");
    let ts = read_timeseries(&path)?;
    let t0 = Instant::now();
    let est = estimate_frf(std::slice::from_ref(&ts), &FrfOptions::default())?;
    let t_frf = t0.elapsed();
    let coh = est.frf.channels[0].coherence.clone().unwrap_or_default();
    let in_band: Vec<f64> = est
        .frf
        .freqs_hz
        .iter()
        .zip(&coh)
        .filter(|(f, _)| (200.0..=4500.0).contains(*f))
        .map(|(_, c)| *c)
        .collect();
    let mut sorted = in_band.clone();
    sorted.sort_by(f64::total_cmp);
    let t1 = Instant::now();
    let opts = FitOptions {
        band_hz: Some((200.0, 4500.0)),
        ..FitOptions::default()
    };
    let mut fit = fit_frf(&est.frf, &opts)?;
    if let Some(s) = est.exp_window_sigma {
        fit.model.shift_poles(s);
    }
    let t_fit = t1.elapsed();

    // Score against the plain per-hit H1 of the raw samples.
    let fx = ts.force(Axis::X).ok_or("no fx")?;
    let ax = ts.response(Axis::X).ok_or("no ax")?;
    let fs = ts.fs();
    let n = fs.round() as usize; // 1 s per hit
    let (freqs, acc, coh_plain) = plain_h1(fx, ax, n, fs);
    let mut meas = Vec::new();
    let mut model = Vec::new();
    for k in 0..freqs.len() {
        let f = freqs[k];
        if (200.0..=4500.0).contains(&f) && coh_plain[k] > 0.95 {
            let w = 2.0 * PI * f;
            meas.push(acc[k] / (-w * w));
            model.push(fit.model.eval_hz(0, f));
        }
    }
    println!("## Real impact-hammer test (pyFRF, 5 hits, 25.6 kHz)");
    println!(
        "hits used {} dropped {:?}, exponential window sigma {:?}, FRF estimate {:.1} ms",
        est.hits_used,
        est.hits_dropped,
        est.exp_window_sigma,
        t_frf.as_secs_f64() * 1e3
    );
    println!(
        "coherence 200-4500 Hz: median {:.4}, 5th percentile {:.4}",
        sorted[sorted.len() / 2],
        sorted[sorted.len() / 20]
    );
    println!(
        "order {} modes ({}), fit {:.1} ms",
        fit.model.modes.len(),
        if fit.automatic_order {
            "automatic"
        } else {
            "given"
        },
        t_fit.as_secs_f64() * 1e3
    );
    let f_in: Vec<String> = fit
        .model
        .modes
        .iter()
        .map(|m| m.freq_hz())
        .filter(|f| (200.0..=4500.0).contains(f))
        .map(|f| format!("{f:.0}"))
        .collect();
    println!("modes in band [Hz]: {}", f_in.join(" "));
    println!(
        "receptance fit vs plain per-hit H1 (200-4500 Hz, coherence > 0.95, {} lines): {:.2} %  (target >= 97 %)",
        meas.len(),
        fit_percent(&meas, &model)
    );
    Ok(())
}

fn pyuff() -> Result<(), Box<dyn std::error::Error>> {
    println!("\n## pyuff measured accelerances (free-free beam, 0-1000 Hz)");
    for i in 1..=3 {
        let path = data_dir().join(format!("pyuff_measured_frf/meas_point_{i}.txt"));
        let pts = read_complex_lines(&path, 0.0, 1.0)?;
        let frf = accelerance_to_receptance(&pts, Channel::new(Axis::X, Axis::X));
        let band = Frf {
            freqs_hz: frf.freqs_hz.clone(),
            channels: vec![FrfChannel {
                coherence: None,
                ..frf.channels[0].clone()
            }],
        };
        let t = Instant::now();
        let res = fit_frf(
            &band,
            &FitOptions {
                band_hz: Some((20.0, 1000.0)),
                ..FitOptions::default()
            },
        )?;
        let dt = t.elapsed();
        if std::env::var_os("MTWIN_VERBOSE").is_some() {
            eprintln!("{}", res.report);
        }
        let modes: Vec<String> = res
            .model
            .modes
            .iter()
            .map(|m| m.freq_hz())
            .filter(|f| (20.0..=1000.0).contains(f))
            .map(|f| format!("{f:.0}"))
            .collect();
        println!(
            "point {i}: {} modes (automatic), fit {:.2} % in 20-1000 Hz, {:.0} ms; modes [Hz] {}",
            res.model.modes.len(),
            res.fit_pct[0].1,
            dt.as_secs_f64() * 1e3,
            modes.join(" ")
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    impact()?;
    pyuff()?;
    Ok(())
}
#[allow(dead_code)]
fn debug_report() {}
