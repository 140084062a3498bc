//! `mtwin identify`.

use super::frf_io::{read_measured, FrfInputArgs};
use super::{check_output_not_input, frf::frf_options, read_series, BadInput, Output};
use anyhow::{Context, Result};
use identify::campaign::{identify_campaign, identify_frfs, CampaignOptions};
use identify::io::measured::split_inputs;
use identify::rational_fit::FitOptions;
use std::path::PathBuf;

/// Arguments of `mtwin identify`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Time-series CSV files of the campaign (grouped by pose and excitation axis), or
    /// measured FRFs instead: Universal File Format dataset 58/58b (`.uff`, `.unv`) or
    /// FRF CSV files, one pose per file (formats: docs/formats.md).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output twin file (JSON; docs/formats.md, "Twin file").
    #[arg(long)]
    pub out: PathBuf,
    /// Number of modes (pole pairs) instead of the automatic choice from the
    /// stabilization diagram.
    #[arg(long)]
    pub order: Option<usize>,
    /// Lower end of the fitted band in Hz.
    #[arg(long)]
    pub fmin: Option<f64>,
    /// Upper end of the fitted band in Hz.
    #[arg(long)]
    pub fmax: Option<f64>,
    /// FRF estimator: h1, h2, hv.
    #[arg(long, default_value = "h1", value_parser = ["h1", "h2", "hv"])]
    pub estimator: String,
    /// Excitation: auto, impact, continuous, chirp.
    #[arg(long, default_value = "auto", value_parser = ["auto", "impact", "continuous", "chirp"])]
    pub excitation: String,
    /// Records within this distance in metres share a pose.
    #[arg(long, default_value_t = 1e-3)]
    pub pose_tol: f64,
    /// Line weighting of the fit: auto (coherence weighting, then the inverse-variance,
    /// balanced and mobility weightings and, for a poor fit, a deeper stabilization
    /// diagram; the one with the smallest octave-averaged error kept), coherence, ml
    /// (inverse variance), balanced (relative error: every part of the band counts alike)
    /// or mobility (the coherence weighting of receptance × frequency).
    #[arg(long, default_value = "auto", value_parser = ["auto", "coherence", "ml", "balanced", "mobility"])]
    pub weighting: String,
    /// Impact tests whose hits ring into the next: `separate` (default) takes each hit's
    /// response apart from the earlier hits' free decays over a first fit's poles and
    /// identifies again; `as-measured` keeps the records as they are.
    #[arg(long, default_value = "separate", value_parser = ["separate", "as-measured"])]
    pub ringing_hits: String,
    /// Also write an HTML report (FRFs, coherence, stabilization diagram, modes across
    /// the workspace) here (docs/reports.md).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// How the report draws the FRFs: mag-phase (magnitude on a log axis and phase),
    /// re-im (real and imaginary parts) or both (a switch in the page; about twice the
    /// size).
    #[arg(long, value_enum, default_value = "mag-phase")]
    pub frf_plot: crate::report::identify::FrfView,
    /// Name of the machine, written into the twin.
    #[arg(long, default_value = "machine")]
    pub name: String,
    /// Measured FRF inputs.
    #[command(flatten)]
    pub frf_in: FrfInputArgs,
}

/// Runs `mtwin identify`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    check_output_not_input(&a.out, &a.files)?;
    if a.order == Some(0) {
        return Err(BadInput("--order must be at least 1 (number of modes)".into()).into());
    }
    let t0 = std::time::Instant::now();
    let (series_files, frf_files) = split_inputs(&a.files)?;
    let series = read_series(&series_files, out)?;
    let measured = frf_files
        .iter()
        .map(|f| read_measured(f, &a.frf_in))
        .collect::<Result<Vec<_>>>()?;
    let t_read = t0.elapsed();
    let band = match (a.fmin, a.fmax) {
        (None, None) => None,
        (lo, hi) => Some((lo.unwrap_or(0.0), hi.unwrap_or(f64::INFINITY))),
    };
    let opts = CampaignOptions {
        frf: frf_options(&a.estimator, &a.excitation, None),
        fit: FitOptions {
            n_modes: a.order,
            band_hz: band,
            weighting: match a.weighting.as_str() {
                "ml" => identify::rational_fit::Weighting::InverseVariance,
                "balanced" => identify::rational_fit::Weighting::Balanced,
                "mobility" => identify::rational_fit::Weighting::Mobility,
                _ => identify::rational_fit::Weighting::Coherence,
            },
            ..FitOptions::default()
        },
        pose_tol_m: a.pose_tol,

        name: a.name.clone(),
        try_ml_weighting: a.weighting == "auto",
        separate_ringing_hits: a.ringing_hits == "separate",
    };
    let bar = (!out.quiet && !out.json).then(|| {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "identify [{bar:30}] {pos}/{len} poses {elapsed}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let progress = |done: usize, total: usize| {
        if let Some(b) = &bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let mut res = if measured.is_empty() {
        identify_campaign(&series, &opts, &progress)
    } else {
        identify_frfs(measured, &opts, &progress)
    }
    .context("identification")?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    res.twin.provenance.command = std::env::args().collect::<Vec<_>>().join(" ");
    res.twin.save(&a.out)?;
    if a.fmax.is_some() {
        // the estimate's hint about identify's automatic band does not apply when the
        // band's top is given
        identify::campaign::drop_automatic_band_hint(&mut res.warnings);
    }
    out.warnings(&res.warnings);
    say_summary(out, &a, &res, !frf_files.is_empty(), t_read, t0.elapsed());
    let twin = &res.twin;
    out.say(format!("twin -> {}", a.out.display()));
    if let Some(r) = &a.report {
        let html = crate::report::identify::identify_report(twin, &res.diagrams, a.frf_plot);
        identify::atomic::write_atomic(r, html.as_bytes())?;
        out.say(format!("report -> {}", r.display()));
    }
    out.json(&serde_json::json!({
        "out": a.out,
        "poses": twin.poses.iter().map(|p| serde_json::json!({
            "pose": p.pose, "modes": p.order.modes, "automatic_order": p.order.automatic,
            "fit": p.fit, "natural_freqs_hz": p.model.modes.iter().map(|m| m.freq_hz()).collect::<Vec<_>>(),
            "damping": p.model.modes.iter().map(|m| m.zeta).collect::<Vec<_>>(),
            "band_hz": p.band_hz, "plan": p.plan,
        })).collect::<Vec<_>>(),
        "interpolation": twin.interpolation,
        "warnings": res.warnings,
    }));
    Ok(())
}

/// The terminal summary: records and poses, each pose's order, band and fits, how the
/// automatic choices were made (pose 1), and the leave-one-pose-out accuracy.
fn say_summary(
    out: &Output,
    a: &Args,
    res: &identify::campaign::CampaignResult,
    from_frfs: bool,
    t_read: std::time::Duration,
    total: std::time::Duration,
) {
    let twin = &res.twin;
    out.say(format!(
        "{}, {}, channels {} (read {:.2} s, total {:.2} s)",
        identify::axis::count(
            a.files.len(),
            if !from_frfs {
                "record"
            } else {
                "measured FRF file"
            }
        ),
        identify::axis::count(twin.poses.len(), "pose"),
        twin.channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(","),
        t_read.as_secs_f64(),
        total.as_secs_f64()
    ));
    for p in &twin.poses {
        let fits: Vec<String> = p
            .fit
            .iter()
            .map(|f| {
                let band = f
                    .band_hz
                    .map(|b| format!(" in {:.0}-{:.0} Hz", b[0], b[1]))
                    .unwrap_or_default();
                match (f.noise_limit_pct, f.noise_free_fit_pct) {
                    // a channel the noise keeps well below 100 %: the model against what
                    // the data measure, and the raw figure with what its noise allows
                    (Some(l), Some(nf)) if l < 97.0 => format!(
                        "{} ≈{:.1} % of its noise-free FRF ({:.2} % of the measured{band}, \
                         whose noise alone allows {:.1} %)",
                        f.channel, nf, f.fit_pct, l
                    ),
                    (Some(l), None) if l < 97.0 => format!(
                        "{} {:.2} %{band} (its noise allows {:.1} %)",
                        f.channel, f.fit_pct, l
                    ),
                    _ => format!("{} {:.2} %{band}", f.channel, f.fit_pct),
                }
            })
            .collect();
        let of = p
            .plan
            .as_ref()
            .and_then(|pl| pl.measured_as)
            .map_or(String::new(), |m| format!(" ({} as measured)", m.name()));
        out.say(format!(
            "  pose {}: {} ({}), band {:.0}-{:.0} Hz, fit {}{of}",
            identify::axis::PoseText(p.pose),
            identify::axis::count(p.order.modes, "mode"),
            if p.order.automatic {
                "automatic"
            } else {
                "--order"
            },
            p.band_hz[0],
            p.band_hz[1],
            fits.join(", ")
        ));
    }
    // how the automatic choices were made (the plan of the first pose; every pose's plan
    // is in the twin file)
    if let Some(plan) = twin.poses.first().and_then(|p| p.plan.as_ref()) {
        out.say(format!("  decided from the data (pose 1; all poses in the twin file's \"plan\"): excitation {}", plan.excitation));
        for e in &plan.band_evidence {
            out.say(format!("    band: {e}"));
        }
        for c in &plan.channels {
            out.say(format!("    channel {}: {}", c.channel, c.reason));
        }
        for a in plan.alternatives.iter().take(1) {
            out.say(format!("    fit: {a}"));
        }
    }
    let loo = &twin.interpolation.leave_one_out;
    if !loo.is_empty() {
        let all: Vec<f64> = loo
            .iter()
            .flat_map(|e| e.fit.iter().map(|f| f.fit_pct))
            .collect();
        let min = all.iter().copied().fold(f64::INFINITY, f64::min);
        let mean = all.iter().sum::<f64>() / all.len().max(1) as f64;
        // along an axis with only two pose levels, a pose left out is extrapolated from
        // the other level: its figure is no measure of the interpolation between them
        let two_levels: Vec<&str> = (0..3)
            .filter(|&a| {
                let mut v: Vec<f64> = twin.poses.iter().map(|p| p.pose[a]).collect();
                v.sort_by(f64::total_cmp);
                v.dedup_by(|x, y| (*x - *y).abs() < 1e-6);
                v.len() == 2
            })
            .map(|a| ["x", "y", "z"][a])
            .collect();
        let caveat = if two_levels.is_empty() {
            String::new()
        } else {
            format!(
                " (only two pose levels along {}: a pose left out there is extrapolated from \
                 the other level, not interpolated)",
                two_levels.join(", ")
            )
        };
        out.say(format!(
            "  interpolation {}: leave-one-pose-out fit mean {mean:.2} %, worst {min:.2} %{caveat}",
            twin.interpolation.method
        ));
    }
}
