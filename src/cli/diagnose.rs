//! `mtwin diagnose`.

use super::{read_series, Output};
use anyhow::{Context, Result};
use identify::diagnose::{diagnose, DiagnoseOptions};
use identify::twin::Twin;
use std::path::PathBuf;

/// Arguments of `mtwin diagnose`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The twin file.
    #[arg(long)]
    pub twin: PathBuf,
    /// Measured data (impact tests or operating data with forces).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output directory (diagnosis.json, twin_extended.json, report.html).
    #[arg(long)]
    pub out: PathBuf,
    /// Fraction of each continuous record held out for scoring.
    #[arg(long, default_value_t = 0.3)]
    pub holdout: f64,
}

/// Runs `mtwin diagnose`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    let twin = Twin::load(&a.twin)?;
    let series = read_series(&a.files, out)?;
    let opts = DiagnoseOptions {
        holdout_fraction: a.holdout.clamp(0.05, 0.8),
        ..DiagnoseOptions::default()
    };
    let (diag, ext) = diagnose(&twin, &series, &opts).context("diagnosis")?;
    std::fs::create_dir_all(&a.out).map_err(|e| identify::Error::io(&a.out, e))?;
    ext.save(&a.out.join(&diag.extended_twin))?;
    let json = serde_json::to_string_pretty(&diag)?;
    identify::atomic::write_atomic(&a.out.join("diagnosis.json"), json.as_bytes())?;
    let html = crate::report::diagnose::report(&twin, &ext, &series, &diag, &opts)?;
    identify::atomic::write_atomic(&a.out.join("report.html"), html.as_bytes())?;
    out.say(format!("cause: {}", diag.cause));
    out.say(format!("  {}", diag.summary));
    out.say(format!(
        "  held-out fit: {:.2} % -> {:.2} % ({})",
        diag.fit_before_pct,
        diag.fit_after_pct,
        diag.details
            .get("holdout")
            .and_then(|v| v.as_str())
            .unwrap_or("")
    ));
    out.say(format!(
        "diagnosis, extended twin and report -> {}",
        a.out.display()
    ));
    out.json(&serde_json::to_value(&diag)?);
    Ok(())
}
