//! `mtwin frf`.

use super::{check_output_not_input, read_series, Output};
use anyhow::{Context, Result};
use identify::spectra::{estimate_frf, Estimator, Excitation, FrfOptions};
use std::path::PathBuf;

/// Arguments of `mtwin frf`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Time-series CSV files (SPEC section 2); records with the same excitation
    /// direction are averaged.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output FRF, receptance in m/N with coherence: FRF CSV (SPEC section 3), or
    /// Universal File Format dataset 58 when the name ends in `.uff` or `.unv`.
    #[arg(long)]
    pub out: PathBuf,
    /// With a `.uff`/`.unv` output: write binary dataset 58b instead of ASCII 58.
    #[arg(long)]
    pub uff_binary: bool,
    /// Estimator: h1 (noise on the response), h2 (noise on the force), hv (both).
    #[arg(long, default_value = "h1", value_parser = ["h1", "h2", "hv"])]
    pub estimator: String,
    /// Excitation: auto, impact, continuous (Welch) or chirp (whole-record DFT).
    #[arg(long, default_value = "auto", value_parser = ["auto", "impact", "continuous", "chirp"])]
    pub excitation: String,
    /// Segment length for Welch averaging (default: chosen from the record).
    #[arg(long)]
    pub nfft: Option<usize>,
}

/// FRF options from the command line.
pub fn frf_options(estimator: &str, excitation: &str, nfft: Option<usize>) -> FrfOptions {
    FrfOptions {
        estimator: match estimator {
            "h2" => Estimator::H2,
            "hv" => Estimator::Hv,
            _ => Estimator::H1,
        },
        excitation: match excitation {
            "impact" => Excitation::Impact,
            "continuous" => Excitation::Continuous,
            "chirp" => Excitation::Chirp,
            _ => Excitation::Auto,
        },
        nfft,
        ..FrfOptions::default()
    }
}

/// Runs `mtwin frf`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    check_output_not_input(&a.out, &a.files)?;
    let series = read_series(&a.files, out)?;
    let opts = frf_options(&a.estimator, &a.excitation, a.nfft);
    let est = estimate_frf(&series, &opts).context("FRF estimation")?;
    for w in &est.warnings {
        out.say(format!("warning: {w}"));
    }
    let format = super::frf_io::write_frf(&a.out, &est.frf, a.uff_binary)?;
    let mut chans = Vec::new();
    for c in &est.frf.channels {
        let mean_coh = c
            .coherence
            .as_ref()
            .map(|g| g.iter().sum::<f64>() / g.len().max(1) as f64);
        out.say(format!(
            "  {}: {} lines {:.1}..{:.1} Hz, mean coherence {}",
            c.channel,
            c.h.len(),
            est.frf.freqs_hz.first().unwrap_or(&0.0),
            est.frf.freqs_hz.last().unwrap_or(&0.0),
            mean_coh.map_or("-".into(), |g| format!("{g:.4}"))
        ));
        chans.push(serde_json::json!({"channel": c.channel.name(), "mean_coherence": mean_coh}));
    }
    out.say(format!(
        "{} ({}, Δf = {:.3} Hz, {} hits used, {} dropped) -> {} ({format})",
        est.method,
        a.estimator.to_uppercase(),
        est.df_hz,
        est.hits_used,
        est.hits_dropped.len(),
        a.out.display()
    ));
    out.json(&serde_json::json!({
        "out": a.out, "method": est.method, "df_hz": est.df_hz, "hits_used": est.hits_used,
        "hits_dropped": est.hits_dropped, "warnings": est.warnings, "channels": chans,
        "exp_window_sigma": est.exp_window_sigma,
    }));
    Ok(())
}
