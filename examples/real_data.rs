//! mtwin on REAL measured data (../shared/data) with the defaults a user gets from
//! `mtwin identify FILE --out twin.json` (no band, order or weighting given): the
//! impact-hammer test and the pyuff measured accelerances.
//!
//! Run: `cargo run --release --example real_data` (from the repository root; the data
//! folder is found at `../shared/data` or `$MTWIN_DATA`).
//!
//! 1. Impact hammer, 5 hits (`impact_5hits.csv`): the whole automatic path
//!    (`identify_campaign` with default options: hit detection, windows, H1, the plan's
//!    band and channels, order, weighting candidates); the model is scored against a
//!    *plain per-hit H1 of the raw data* (no windows) at 200–4500 Hz where its coherence
//!    is > 0.95, as accelerance (what was measured) and as receptance.
//! 2. pyuff's three measured accelerances (roving hammer on a free-free beam), each as its
//!    own pose through `identify_frfs` with default options, scored against the measured
//!    accelerance over the whole file (1–1000 Hz) and as receptance at 20–1000 Hz.

use identify::axis::{Axis, Channel};
use identify::campaign::{identify_campaign, identify_frfs, CampaignOptions, MeasuredFrf};
use identify::frf::fit_percent;
use identify::plan::{EstimateFacts, MeasuredAs};
use identify::read::{accelerance_to_receptance, read_complex_lines, read_timeseries};
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
    let res = identify_campaign(
        std::slice::from_ref(&ts),
        &CampaignOptions::default(),
        &|_, _| {},
    )?;
    let dt = t0.elapsed();
    let pose = &res.twin.poses[0];
    let model = &pose.model;

    // Score against the plain per-hit H1 of the raw samples.
    let fx = ts.force(Axis::X).ok_or("no fx")?;
    let ax = ts.response(Axis::X).ok_or("no ax")?;
    let fs = ts.fs();
    let n = fs.round() as usize; // 1 s per hit
    let (freqs, acc, coh_plain) = plain_h1(fx, ax, n, fs);
    let (mut meas_a, mut model_a, mut meas_r, mut model_r) = (vec![], vec![], vec![], vec![]);
    for k in 0..freqs.len() {
        let f = freqs[k];
        if (200.0..=4500.0).contains(&f) && coh_plain[k] > 0.95 {
            let w2 = -(2.0 * PI * f).powi(2);
            let r = model.eval_hz(0, f);
            meas_a.push(acc[k]);
            model_a.push(r * w2);
            meas_r.push(acc[k] / w2);
            model_r.push(r);
        }
    }
    println!("## Real impact-hammer test (pyFRF, 5 hits, 25.6 kHz), default options");
    if let Some(plan) = &pose.plan {
        println!("excitation: {}", plan.excitation);
        println!(
            "band {:.0}-{:.0} Hz; {}",
            pose.band_hz[0],
            pose.band_hz[1],
            plan.alternatives.first().cloned().unwrap_or_default()
        );
    }
    let f_in: Vec<String> = model
        .modes
        .iter()
        .map(|m| m.freq_hz())
        .filter(|f| (200.0..=4500.0).contains(f))
        .map(|f| format!("{f:.0}"))
        .collect();
    println!(
        "{} modes (automatic), identify {:.2} s; modes in 200-4500 Hz [Hz]: {}",
        model.modes.len(),
        dt.as_secs_f64(),
        f_in.join(" ")
    );
    println!(
        "vs plain per-hit H1 (200-4500 Hz, coherence > 0.95, {} lines): accelerance {:.2} %, receptance {:.2} %  (target >= 97 %)",
        meas_a.len(),
        fit_percent(&meas_a, &model_a),
        fit_percent(&meas_r, &model_r)
    );
    Ok(())
}

fn pyuff() -> Result<(), Box<dyn std::error::Error>> {
    println!("\n## pyuff measured accelerances (free-free beam, 0-1000 Hz), default options");
    for i in 1..=3 {
        let path = data_dir().join(format!("pyuff_measured_frf/meas_point_{i}.txt"));
        let pts = read_complex_lines(&path, 0.0, 1.0)?;
        let frf = accelerance_to_receptance(&pts, Channel::new(Axis::X, Axis::X));
        let t = Instant::now();
        let res = identify_frfs(
            vec![MeasuredFrf {
                pose: [0.0; 3],
                frf: frf.clone(),
                exp_window_sigma: None,
                sources: vec![path.display().to_string()],
                warnings: Vec::new(),
                facts: EstimateFacts {
                    measured_as: Some(MeasuredAs::Accelerance),
                    ..Default::default()
                },
            }],
            &CampaignOptions::default(),
            &|_, _| {},
        )?;
        let dt = t.elapsed();
        let model = &res.twin.poses[0].model;
        let score = |lo: f64, power: i32| {
            let (mut m, mut e) = (vec![], vec![]);
            for (k, &f) in frf.freqs_hz.iter().enumerate() {
                if f >= lo {
                    let jw = Complex64::new(0.0, 2.0 * PI * f).powi(power);
                    m.push(frf.channels[0].h[k] * jw);
                    e.push(model.eval_hz(0, f) * jw);
                }
            }
            fit_percent(&m, &e)
        };
        println!(
            "point {i}: {} modes (automatic), {:.0} ms; accelerance 1-1000 Hz {:.2} %, receptance 20-1000 Hz {:.2} %",
            model.modes.len(),
            dt.as_secs_f64() * 1e3,
            score(0.0, 2),
            score(20.0, 0)
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
