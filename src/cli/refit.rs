//! `mtwin refit`.

use super::{check_output_not_input, read_series, Output};
use anyhow::{Context, Result};
use identify::refit::{refit, RefitMethod, RefitOptions};
use identify::twin::Twin;
use std::path::PathBuf;

/// Arguments of `mtwin refit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The current twin file (never overwritten).
    #[arg(long)]
    pub twin: PathBuf,
    /// Operating data: forces, responses and axis positions while milling.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// The updated twin (with the whole history).
    #[arg(long)]
    pub out: PathBuf,
    /// Also export the updated FMU here.
    #[arg(long)]
    pub fmu: Option<PathBuf>,
    /// time (default: mtwin's modal update from the operating cross-spectra, then the
    /// updated modes refined by output error on the records), modal (the modal update
    /// alone) or paper (intermediate FRF + weighted refit).
    #[arg(long, default_value = "time", value_parser = ["time", "modal", "paper"])]
    pub method: String,
    /// Refit when the simulated response fits worse than 100 - this (percent).
    #[arg(long, default_value_t = 5.0)]
    pub drift_threshold: f64,
    /// Refit even when no drift is detected.
    #[arg(long)]
    pub force: bool,
    /// Paper's PSD threshold on the response in m²/Hz (default: automatic).
    #[arg(long)]
    pub psd_threshold: Option<f64>,
    /// Minimum coherence of a line to be used.
    #[arg(long, default_value_t = 0.8)]
    pub min_coherence: f64,
    /// Length in metres over which the change spreads to other poses (weight exp(-(d/L)²));
    /// default half the workspace diagonal; `inf` = everywhere alike.
    #[arg(long)]
    pub spread_length: Option<f64>,
    /// Also write an HTML report (drift check, operating FRF vs the twin before and
    /// after, responses, modes changed, history) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// Runs `mtwin refit`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    let mut inputs = a.files.clone();
    inputs.push(a.twin.clone());
    check_output_not_input(&a.out, &inputs)?;
    for f in a.fmu.iter().chain(&a.report) {
        check_output_not_input(f, &inputs)?;
    }
    let twin = Twin::load(&a.twin)?;
    let series = read_series(&a.files, out)?;
    let opts = RefitOptions {
        method: match a.method.as_str() {
            "paper" => RefitMethod::Paper,
            "time" => RefitMethod::Time,
            _ => RefitMethod::Modal,
        },
        drift_threshold_pct: a.drift_threshold,
        force: a.force,
        psd_threshold: a.psd_threshold,
        min_coherence: a.min_coherence,
        spread_length_m: a.spread_length,
        ..RefitOptions::default()
    };
    let (mut new, rep) = refit(&twin, &series, &opts).context("refit")?;
    new.provenance.command = std::env::args().collect::<Vec<_>>().join(" ");
    new.save(&a.out)?;
    out.say(format!(
        "drift check at pose {}: simulated response fit {:.2} %, operating FRF misfit {:.1} σ -> {}",
        identify::axis::PoseText(rep.pose),
        rep.drift_fit_pct,
        rep.drift_chi,
        if rep.updated {
            "updated"
        } else if rep.held_out.is_some() {
            "drift, but no validated update: modes kept"
        } else {
            "no change needed"
        }
    ));
    if let Some(d) = &rep.drift_in_time {
        out.say(format!("  drift found in time: {d}"));
    }
    for m in &rep.modes {
        out.say(format!(
            "  mode {}: {:.2} Hz -> {:.2} Hz, damping {:.2} % -> {:.2} %",
            m.mode + 1,
            m.freq_before_hz,
            m.freq_after_hz,
            100.0 * m.zeta_before,
            100.0 * m.zeta_after
        ));
    }
    if let Some(h) = &rep.held_out {
        out.say(format!("  held-out check: {}", h.note));
    }
    if rep.updated {
        out.say(format!(
            "  {} used; simulated response fit after: {:.2} %",
            identify::axis::count(rep.lines_hz.len(), "line"),
            rep.fit_after_pct
        ));
    }
    out.warnings(&rep.warnings);
    if let Some(oe) = &rep.output_error {
        out.say(format!(
            "  output-error stage: residual {:.2} % -> {:.2} % of the response RMS in {} \
             (first {:.2} s of each record not fitted); force noise floor {} of the force's median level",
            100.0 * oe.rel_rms_before,
            100.0 * oe.rel_rms_after,
            identify::axis::count(oe.iterations, "iteration"),
            oe.skipped_s,
            oe.force_noise_text()
        ));
    }
    if let Some(f) = &a.fmu {
        let size = super::export::export(&new, f)?;
        out.say(format!("updated FMU -> {}", f.display()));
        out.say(super::export::size_line(&size));
    }
    if let Some(r) = &a.report {
        let html = crate::report::refit::refit_report(&twin, &new, &rep, &series);
        identify::atomic::write_atomic(r, html.as_bytes())?;
        out.say(format!("report -> {}", r.display()));
    }
    out.say(format!(
        "twin ({} history entries) -> {}",
        new.history.len(),
        a.out.display()
    ));
    // each changed mode also counted from 1, as the reports and messages count it
    let mut rep_json = serde_json::to_value(&rep)?;
    if let Some(modes) = rep_json
        .get_mut("modes")
        .and_then(serde_json::Value::as_array_mut)
    {
        for m in modes {
            if let Some(k) = m.get("mode").and_then(serde_json::Value::as_u64) {
                m["mode_number"] = serde_json::json!(k + 1);
            }
        }
    }
    out.json(&serde_json::json!({"out": a.out, "report": rep_json, "fmu": a.fmu}));
    Ok(())
}
