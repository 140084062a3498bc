//! The paper's 3-DoF example (sections 3.1 and 3.2), with numbers against the ANALYTIC
//! FRF of the chain.
//!
//! Run: `cargo run --release --example paper_3dof`
//!
//! 1. **A-priori model** (paper 3.1): masses m = 10 kg, springs k = 2·10⁴ N/m, dampers
//!    c = 5 N s/m; a periodic chirp on mass 3, displacement of mass 3, Ts = 0.01 s;
//!    simulated exactly at 8× the rate and recorded through an anti-alias filter with
//!    0 %, 0.1 % and 0.5 % sensor noise (the paper's simulation has none). FRF, automatic order from the stabilization diagram, uniform
//!    weight W = 1 (as the paper), fit against the analytic FRF (paper eq. 5).
//!    Paper: 99.88 %.
//! 2. The discrete H(z⁻¹) at Ts = 0.01 s (paper eq. 1/4) and what rounding its
//!    coefficients to 4 digits does to its poles.
//! 3. **Refit** (paper 3.2): k1 reduced by 10 %, milling-like force (tooth-passing
//!    harmonics plus a broadband share), the paper's intermediate-FRF method and mtwin's
//!    modal update; each updated model against the analytic FRF of the changed chain.
//!    Paper: 95.23 %.

use identify::campaign::{identify_campaign, CampaignOptions};
use identify::frf::fit_percent;
use identify::model::ModalModel;
use identify::rational_fit::{FitOptions, Weighting};
use identify::refit::{refit, RefitMethod, RefitOptions};
use identify::spectra::{Excitation, FrfOptions};
use identify::stabilization::poly_roots;
use identify::timeseries::ResponseKind;
use num_complex::Complex64;
use std::f64::consts::PI;
use std::time::Instant;
use vmachine::chain::MdofChain;
use vmachine::daq::{chain_record, Daq};
use vmachine::excitation::{chirp, noise};

/// Fit (paper eq. 5) of `model` channel 0 against the chain's analytic FRF on `freqs`.
fn fit_vs_truth(model: &ModalModel, chain: &MdofChain, freqs: &[f64]) -> f64 {
    let truth: Vec<Complex64> = freqs.iter().map(|&f| chain.receptance(f)).collect();
    let est: Vec<Complex64> = freqs.iter().map(|&f| model.eval_hz(0, f)).collect();
    fit_percent(&truth, &est)
}

fn daq(noise: f64) -> Daq {
    Daq {
        fs: 100.0,
        oversample: 8,
        force_noise: noise,
        response_noise: noise,
        response: ResponseKind::Displacement,
        seed: 11,
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let chain = MdofChain::paper_chain();
    println!("## 1. A-priori model (paper 3.1)");
    let mut kept = None;
    for noise in [0.0, 0.001, 0.005] {
        let d = daq(noise);
        // --- 1. a-priori model from a periodic chirp
        let period = 4096; // 40.96 s at 100 Hz: 0.024 Hz lines
        let periods = 10;
        let force = chirp(
            d.fs_sim(),
            period * d.oversample * periods,
            0.2,
            40.0,
            10.0,
            periods,
        );
        let rec = chain_record(&chain, force, &d, "paper_chirp");
        // the first periods hold the transient (ζ1 = 0.25 %, decay time ≈ 20 s)
        let rec = identify::diagnose::slice(&rec, 4 * period, periods * period);
        let t0 = Instant::now();
        let opts = CampaignOptions {
            frf: FrfOptions {
                excitation: Excitation::Chirp,
                nfft: Some(period),
                ..FrfOptions::default()
            },
            fit: FitOptions {
                weighting: Weighting::Uniform,
                band_hz: Some((0.2, 40.0)),
                ..FitOptions::default()
            },
            ..CampaignOptions::default()
        };
        let res = identify_campaign(std::slice::from_ref(&rec), &opts, &|_, _| {})?;
        let dt_id = t0.elapsed();
        let twin = res.twin;
        let model = &twin.poses[0].model;
        let freqs: Vec<f64> = twin.poses[0]
            .frf
            .freqs_hz
            .iter()
            .copied()
            .filter(|f| (0.2..=40.0).contains(f))
            .collect();
        let fit0 = fit_vs_truth(model, &chain, &freqs);
        println!(
        "sensor noise {:.1} % RMS: order {} modes (automatic: {}), natural frequencies {:?} Hz (analytic {:?})",
        noise * 100.0,
        model.modes.len(),
        twin.poses[0].order.automatic,
        model
            .modes
            .iter()
            .map(|m| (m.freq_hz() * 1e3).round() / 1e3)
            .collect::<Vec<_>>(),
        chain
            .natural_freqs_hz()
            .iter()
            .map(|f| (f * 1e3).round() / 1e3)
            .collect::<Vec<_>>()
    );
        println!(
        "fit vs analytic FRF (0.2-40 Hz, {} lines): {fit0:.3} %   (paper 99.88 %, target >= 99.95 %), identification {:.0} ms",
        freqs.len(),
        dt_id.as_secs_f64() * 1e3
    );
        if noise == 0.0 {
            kept = Some(twin.clone());
        }
    }
    let twin = kept.ok_or("no model")?;
    let model = &twin.poses[0].model;
    let mut d = daq(0.005);
    if std::env::var_os("MTWIN_NO_FORCE_NOISE").is_some() {
        d.force_noise = 0.0;
    }

    // --- 2. the discrete transfer function of paper eq. (1)
    let (b, a) = model.discrete_tf(0, 0.01);
    let scale = 1e-5;
    println!("\n## 2. H(z^-1) at Ts = 0.01 s (paper eq. 4 form, numerator x 1e-5)");
    println!(
        "b = {:?}",
        b.iter()
            .map(|v| format!("{:.4}", v / scale))
            .collect::<Vec<_>>()
    );
    println!(
        "a = {:?}",
        a.iter().map(|v| format!("{:.4}", v)).collect::<Vec<_>>()
    );
    let max_pole = |a: &[f64]| poly_roots(a).iter().map(|p| p.norm()).fold(0.0, f64::max);
    let round4 = |v: f64| {
        if v == 0.0 {
            0.0
        } else {
            let e = 10f64.powf(v.abs().log10().floor() - 3.0);
            (v / e).round() * e
        }
    };
    let a4: Vec<f64> = a.iter().map(|&v| round4(v)).collect();
    let paper_a = [1.0, -5.704, 13.78, -18.06, 13.54, -5.504, 0.9485];
    println!(
        "largest |pole|: exact {:.6}; our denominator rounded to 4 digits {:.6}; the paper's printed eq. 4 {:.6} (> 1 = unstable)",
        max_pole(&a),
        max_pole(&a4),
        max_pole(&paper_a)
    );

    // --- 3. refit after a 10 % loss of k1
    let worn = chain.clone().with_k1_factor(0.9);
    let fs = d.fs_sim();
    let n = (3600.0 * fs) as usize;
    // milling-like force: tooth passing at 2.9 Hz with harmonics, plus broadband share
    let tooth = 2.9;
    let mut f: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            (1..=6)
                .map(|h| {
                    (8.0 / h as f64) * (2.0 * PI * tooth * h as f64 * t + 0.3 * h as f64).sin()
                })
                .sum::<f64>()
                + 20.0
        })
        .collect();
    let bb = noise(n, 2.0, 21);
    f.iter_mut().zip(&bb).for_each(|(a, b)| *a += b);
    let op = chain_record(&worn, f, &d, "milling_like");
    let freqs_all: Vec<f64> = (1..=4000).map(|k| k as f64 * 0.01).collect();
    let before = fit_vs_truth(model, &worn, &freqs_all);
    println!("\n## 3. Refit after k1 -10 % (paper 3.2)");
    println!("twin before refit vs changed chain (0.01-40 Hz): {before:.2} %");
    for method in [RefitMethod::Paper, RefitMethod::Modal, RefitMethod::Time] {
        let t = Instant::now();
        let (tw2, rep) = refit(
            &twin,
            std::slice::from_ref(&op),
            &RefitOptions {
                method,
                force: true,
                fit: FitOptions {
                    weighting: Weighting::Uniform,
                    ..FitOptions::default()
                },
                ..RefitOptions::default()
            },
        )?;
        let fit = fit_vs_truth(&tw2.poses[0].model, &worn, &freqs_all);
        if std::env::var_os("MTWIN_VERBOSE").is_some() {
            eprintln!("truth {:?}", worn.natural_freqs_hz());
            let um = &tw2.poses[0].model;
            for (lo, hi) in [
                (0.01, 2.0),
                (2.0, 5.0),
                (5.0, 11.0),
                (11.0, 15.0),
                (15.0, 40.0),
            ] {
                let fr: Vec<f64> = freqs_all
                    .iter()
                    .copied()
                    .filter(|f| (lo..hi).contains(f))
                    .collect();
                let err: f64 = fr
                    .iter()
                    .map(|&f| (um.eval_hz(0, f) - worn.receptance(f)).norm_sqr())
                    .sum();
                let tot: f64 = freqs_all
                    .iter()
                    .map(|&f| worn.receptance(f).norm_sqr())
                    .sum();
                eprintln!(
                    "  {lo}-{hi} Hz: share of squared error {:.2e} of total |H|^2",
                    err / tot
                );
            }
            for (k, m) in um.modes.iter().enumerate() {
                let n = um.channels[0].num[k];
                eprintln!(
                    "  mode {k}: {:.5} Hz zeta {:.6} b0 {:.4e} b1*wn/b0 {:.2e}",
                    m.freq_hz(),
                    m.zeta,
                    n.b0,
                    n.b1 * m.wn / n.b0
                );
            }
            let near: Vec<f64> = rep
                .lines_hz
                .iter()
                .copied()
                .filter(|f| (11.0..14.5).contains(f))
                .collect();
            eprintln!(
                "{} lines in 11-14.5 Hz: {:?}",
                near.len(),
                &near[..near.len().min(20)]
            );
        }
        println!(
            "{:?} method: updated model vs analytic changed chain {fit:.2} % (paper 95.23 %, target >= 99 %); drift check fit {:.1} %, {} lines used, {:.0} ms",
            method,
            rep.drift_fit_pct,
            rep.lines_hz.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    Ok(())
}
