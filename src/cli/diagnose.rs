//! `mtwin diagnose`.

use super::{read_series, Output};
use crate::report::{esc, page, plot, Scale, Series};
use anyhow::{Context, Result};
use identify::diagnose::{diagnose, evidence, slice, split, DiagnoseOptions};
use identify::extended::simulate_as_measured;
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
    let html = report(&twin, &ext, &series, &diag, &opts)?;
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

fn report(
    twin: &Twin,
    ext: &Twin,
    series: &[identify::timeseries::TimeSeries],
    diag: &identify::diagnose::Diagnosis,
    opts: &DiagnoseOptions,
) -> Result<String> {
    let mut body = String::new();
    body.push_str(&format!(
        "<h2>Cause: <code>{}</code></h2><p>{}</p><p>Held-out fit: original twin <b>{:.2} %</b>, \
         extended twin <b>{:.2} %</b>. FRF misfit of the original twin: {:.1} standard errors (RMS).</p>",
        diag.cause,
        esc(&diag.summary),
        diag.fit_before_pct,
        diag.fit_after_pct,
        diag.chi_before
    ));
    body.push_str("<h3>Causes tried</h3><table><tr><th>cause</th><th>FRF misfit χ</th><th>held-out fit %</th><th>numbers</th></tr>");
    for c in &diag.candidates {
        body.push_str(&format!(
            "<tr><td>{}</td><td>{:.2}</td><td>{:.2}</td><td style='text-align:left'>{}</td></tr>",
            c.cause,
            c.chi,
            c.fit_holdout_pct,
            esc(&serde_json::to_string(&c.details).unwrap_or_default())
        ));
    }
    body.push_str("</table>");
    // measured vs simulated on the held-out part of the first record
    let ts = &series[0];
    let sp = split(ts, opts.holdout_fraction);
    let y0 = simulate_as_measured(twin, ts)?;
    let y1 = simulate_as_measured(ext, ts)?;
    let a = sp.holdout_start;
    let b = (a + 4000).min(ts.len());
    let t: Vec<f64> = (a..b).map(|i| ts.t0 + i as f64 * ts.dt).collect();
    for ax in ts.response_axes() {
        let Some(m) = ts.response(ax) else { continue };
        let accel = ts.response_kind == Some(identify::timeseries::ResponseKind::Acceleration);
        let (s0, s1) = (y0[ax.index()][a..b].to_vec(), y1[ax.index()][a..b].to_vec());
        body.push_str(&plot(
            &format!("held-out response {ax} ({})", ts.source),
            "t [s]",
            if accel {
                "acceleration [m/s²]"
            } else {
                "displacement [m]"
            },
            &[
                Series {
                    label: "measured",
                    x: &t,
                    y: &m[a..b],
                    color: 0,
                    points: false,
                },
                Series {
                    label: "twin",
                    x: &t,
                    y: &s0,
                    color: 1,
                    points: false,
                },
                Series {
                    label: "extended twin",
                    x: &t,
                    y: &s1,
                    color: 2,
                    points: false,
                },
            ],
            Scale::Lin,
        ));
    }
    // FRF evidence vs twin
    let parts: Vec<_> = series
        .iter()
        .map(|r| {
            let s = split(r, opts.holdout_fraction);
            slice(r, 0, s.holdout_start)
        })
        .collect();
    if let Ok(ev) = evidence(&parts) {
        let pose = series[0].mean_position();
        let m0 = twin.model_at(pose)?;
        let m1 = ext.model_at(pose)?;
        let band = (
            twin.poses
                .iter()
                .map(|p| p.band_hz[0])
                .fold(f64::INFINITY, f64::min),
            twin.poses.iter().map(|p| p.band_hz[1]).fold(0.0, f64::max),
        );
        for (ch, h, g) in &ev.channels {
            let idx: Vec<usize> = (0..ev.freqs_hz.len())
                .filter(|&i| ev.freqs_hz[i] >= band.0 && ev.freqs_hz[i] <= band.1)
                .collect();
            let fr: Vec<f64> = idx.iter().map(|&i| ev.freqs_hz[i]).collect();
            let meas: Vec<f64> = idx.iter().map(|&i| h[i].norm()).collect();
            let model = |m: &identify::model::ModalModel| -> Vec<f64> {
                match m.channel_index(*ch) {
                    Some(ci) => fr.iter().map(|&f| m.eval_hz(ci, f).norm()).collect(),
                    None => vec![0.0; fr.len()],
                }
            };
            let (a0, a1) = (model(&m0), model(&m1));
            body.push_str(&plot(
                &format!("FRF {ch}: measured (building part) vs twin"),
                "f [Hz]",
                "|H| [m/N]",
                &[
                    Series {
                        label: "measured H1",
                        x: &fr,
                        y: &meas,
                        color: 0,
                        points: false,
                    },
                    Series {
                        label: "twin",
                        x: &fr,
                        y: &a0,
                        color: 1,
                        points: false,
                    },
                    Series {
                        label: "extended twin",
                        x: &fr,
                        y: &a1,
                        color: 2,
                        points: false,
                    },
                ],
                Scale::Log,
            ));
            let coh: Vec<f64> = idx.iter().map(|&i| g[i]).collect();
            body.push_str(&plot(
                &format!("coherence {ch}"),
                "f [Hz]",
                "γ²",
                &[Series {
                    label: "coherence",
                    x: &fr,
                    y: &coh,
                    color: 3,
                    points: false,
                }],
                Scale::Lin,
            ));
        }
    }
    Ok(page("mtwin diagnosis", &body))
}
