//! `mtwin frf`.

use super::{check_output_not_input, read_series, Output};
use anyhow::{Context, Result};
use identify::spectra::{
    estimate_frf, estimate_frf_streamed, excitation_of_scan, Estimator, Excitation, FrfEstimate,
    FrfOptions,
};
use std::path::{Path, PathBuf};

/// A single time-series file at least this large is streamed (when its excitation is
/// continuous) instead of read into memory: above it the in-memory record would hold
/// tens of MB.
pub const STREAM_MIN_BYTES: u64 = 8 << 20;

/// Arguments of `mtwin frf`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Time-series CSV files (docs/formats.md, "Time-series CSV"); records with the
    /// same excitation direction are averaged.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Output FRF, receptance in m/N with coherence: FRF CSV (docs/formats.md, "FRF
    /// CSV"), or Universal File Format dataset 58 when the name ends in `.uff` or `.unv`
    /// (docs/formats.md, "Universal files").
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
    /// Stream a single continuous-excitation file (two passes over the file, memory
    /// independent of the record length) whatever its size; by default only files of
    /// 8 MiB or more are streamed. Impact and chirp records are always read into memory.
    #[arg(long, conflicts_with = "in_memory")]
    pub stream: bool,
    /// Read the record into memory even when it would be streamed (the estimate is the
    /// same; for comparison).
    #[arg(long)]
    pub in_memory: bool,
    /// Also write an HTML report here: each channel's FRF with its coherence over a log
    /// frequency axis (docs/reports.md).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// How the report draws the FRFs: mag-phase, re-im (real and imaginary parts) or
    /// both (a switch in the page).
    #[arg(long, value_enum, default_value = "mag-phase")]
    pub frf_plot: crate::report::identify::FrfView,
}

/// The report of `mtwin frf`: what was estimated from what, then every channel.
fn frf_report(a: &Args, est: &FrfEstimate, unit: AverageUnit) -> String {
    use crate::report::identify::{channel_figures, view_switch, ChannelPlot, FrfView};
    use crate::report::{esc, page};
    let frf = &est.frf;
    let f = &frf.freqs_hz;
    // drawn: from the first line where some channel's coherence stays at 0.5 or more
    // over 5 lines to the last such line (an accelerometer's receptance at the lowest
    // lines is noise over ω² and would set the scale of a linear real/imaginary plot; a
    // single line of few averages can reach 0.5 by chance)
    const RUN: usize = 5;
    let trusted = |k: usize| {
        frf.channels.iter().any(|c| {
            c.coherence.as_ref().is_none_or(|g| {
                let lo = k.saturating_sub(RUN / 2);
                let hi = (lo + RUN).min(g.len());
                g[lo..hi].iter().all(|v| *v >= 0.5)
            })
        })
    };
    let first = (0..f.len()).find(|&k| f[k] > 0.0 && trusted(k));
    let last = (0..f.len()).rev().find(|&k| f[k] > 0.0 && trusted(k));
    let keep: Vec<usize> = match (first, last) {
        (Some(a), Some(z)) if z > a => (a..=z).collect(),
        _ => (0..f.len()).filter(|&k| f[k] > 0.0).collect(),
    };
    let band = [
        keep.first().map_or(1.0, |&k| f[k]),
        keep.last().map_or(2.0, |&k| f[k]),
    ];
    let mut b = format!(
        "<p>{} from {}: {}; {}. Receptance in µm/N, drawn \
         from {:.1} to {:.1} Hz (where some channel's coherence first and last stays \
         at 0.5 or more over 5 lines; the file holds every line); where the coherence is low the estimate \
         is not to be trusted.</p>",
        esc(&a.out.display().to_string()),
        esc(&a
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")),
        esc(&est.method),
        averages_tail(est, unit),
        band[0],
        band[1],
    );
    if a.frf_plot == FrfView::Both {
        b.push_str(view_switch());
    }
    b.push_str("<div class=\"poses\">");
    for ch in &frf.channels {
        channel_figures(
            &mut b,
            &ChannelPlot {
                head: &format!("{} receptance", ch.channel),
                fit_pct: None,
                freqs: &frf.freqs_hz,
                keep: &keep,
                ch,
                model: None,
                band,
                view: a.frf_plot,
            },
        );
    }
    b.push_str("</div>");
    page("mtwin frf", &b)
}

/// How the records were read.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Reading {
    /// Read into memory; the records' common pose, when they state one.
    InMemory {
        pose: Option<[f64; 3]>,
    },
    Streamed {
        rows: usize,
    },
}

impl Reading {
    fn name(self) -> &'static str {
        match self {
            Reading::InMemory { .. } => "in_memory",
            Reading::Streamed { .. } => "streamed",
        }
    }
}

/// The one file to stream, if the arguments allow streaming and ask for it (flag or
/// size); the excitation is checked after the file's first pass.
fn stream_candidate<'a>(a: &'a Args, opts: &FrfOptions) -> Option<&'a Path> {
    let [file] = a.files.as_slice() else {
        return None;
    };
    if a.in_memory || matches!(opts.excitation, Excitation::Impact | Excitation::Chirp) {
        return None;
    }
    let big = std::fs::metadata(file).is_ok_and(|m| m.len() >= STREAM_MIN_BYTES);
    (a.stream || big).then_some(file.as_path())
}

/// The estimate, streamed when possible (see [`stream_candidate`]), else in memory.
fn estimate(a: &Args, opts: &FrfOptions, out: &Output) -> Result<(FrfEstimate, Reading)> {
    if let Some(file) = stream_candidate(a, opts) {
        let scan = identify::read::scan_timeseries(file)?;
        if excitation_of_scan(&scan, opts).context("FRF estimation")? == Excitation::Continuous {
            let warnings: Vec<String> = scan
                .warnings
                .iter()
                .map(|w| format!("{}: {w}", file.display()))
                .collect();
            out.warnings(&warnings);
            let est = estimate_frf_streamed(&scan, opts).context("FRF estimation")?;
            return Ok((est, Reading::Streamed { rows: scan.rows }));
        }
        out.say(format!(
            "{}: not continuous excitation, read into memory",
            file.display()
        ));
    }
    let series = read_series(&a.files, out)?;
    let mut est = estimate_frf(&series, opts).context("FRF estimation")?;
    let pose = common_pose(&series, &mut est.warnings);
    Ok((est, Reading::InMemory { pose }))
}

/// The pose the records were measured at, when they carry axis positions and share one
/// (within identify's 1 mm): written into the FRF CSV, so that the FRF CSVs of a
/// campaign, one per pose, identify as that campaign. Records at several poses get a
/// warning: one FRF of all of them belongs to none.
fn common_pose(
    series: &[identify::timeseries::TimeSeries],
    warnings: &mut Vec<String>,
) -> Option<[f64; 3]> {
    if !series
        .iter()
        .any(|r| r.position.iter().any(Option::is_some))
    {
        return None;
    }
    let tol = identify::campaign::CampaignOptions::default().pose_tol_m;
    match identify::campaign::group_by_pose(series, tol).as_slice() {
        [g] => Some(g.pose),
        groups => {
            warnings.push(format!(
                "the records were measured at {} poses: this FRF averages them and belongs \
                 to none of them (estimate each pose alone, or give every record to \
                 identify, which groups them by pose)",
                groups.len()
            ));
            None
        }
    }
}

/// What the estimate's method text leaves out: the method names the estimator, the line
/// spacing and (impact) the hits averaged, said once; then the hits dropped, or how many
/// segments, periods or records were averaged.
fn averages_tail(est: &FrfEstimate, unit: AverageUnit) -> String {
    if unit == AverageUnit::Hit {
        match est.hits_dropped.len() {
            0 => "no hit dropped".to_string(),
            n => format!("{} dropped", identify::axis::count(n, "hit")),
        }
    } else {
        format!("{} used", unit.count(est.hits_used))
    }
}

/// What the averages of an estimate are: impact hits, Welch segments, chirp periods or
/// whole chirp records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AverageUnit {
    Hit,
    Segment,
    Period,
    Record,
}

impl AverageUnit {
    /// From the estimate's method text (`"H1, impact: ..."`, `"H1, Welch: ..."`,
    /// `"H1, chirp: ... (periods averaged) ..."`).
    fn of(method: &str) -> Self {
        if method.contains(", impact:") {
            AverageUnit::Hit
        } else if method.contains(", chirp:") {
            if method.contains("periods averaged") {
                AverageUnit::Period
            } else {
                AverageUnit::Record
            }
        } else {
            AverageUnit::Segment
        }
    }

    fn plural(self) -> &'static str {
        match self {
            AverageUnit::Hit => "hits",
            AverageUnit::Segment => "segments",
            AverageUnit::Period => "periods",
            AverageUnit::Record => "records",
        }
    }

    /// `n` of them in words: `5 hits`, `11 segments`, `1 record`.
    fn count(self, n: usize) -> String {
        let p = self.plural();
        format!("{n} {}", if n == 1 { &p[..p.len() - 1] } else { p })
    }
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
    if let Some(r) = &a.report {
        check_output_not_input(r, &a.files)?;
    }
    let opts = frf_options(&a.estimator, &a.excitation, a.nfft);
    let (mut est, reading) = estimate(&a, &opts, out)?;
    if let Reading::Streamed { rows } = reading {
        out.say(format!(
            "streamed {rows} rows from {} (two passes, memory independent of the record length)",
            a.files[0].display()
        ));
    }
    if let Some(s) = est
        .exp_window_sigma
        .filter(|_| identify::io::measured::is_uff(&a.out))
    {
        est.warnings.push(format!(
            "{}: the FRFs are H(s + {s:.3}/s), an exponential window's estimate; the \
             universal file states it only in its ID line 4, which mtwin reads and other \
             tools show as text: their modal fit of this file sees each mode {s:.3}/ω more \
             damped",
            a.out.display()
        ));
    }
    out.warnings(&est.warnings);
    let format = identify::io::measured::write_frf(
        &a.out,
        &est.frf,
        a.uff_binary,
        &identify::io::measured::EstimateNotes {
            exp_window_sigma: est.exp_window_sigma,
            force_band_hz: est.excitation_band_hz,
            averages: (est.averages_per_channel > 0).then_some(est.averages_per_channel),
            coherence_dof: est.coherence_dof,
            pose: match reading {
                Reading::InMemory { pose } => pose,
                Reading::Streamed { .. } => None,
            },
        },
    )?;
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
    let unit = AverageUnit::of(&est.method);
    let tail = averages_tail(&est, unit);
    out.say(format!(
        "{}; {tail} -> {} ({format})",
        est.method,
        a.out.display()
    ));
    if let Some(r) = &a.report {
        let html = frf_report(&a, &est, unit);
        identify::atomic::write_atomic(r, html.as_bytes())?;
        out.say(format!("report -> {}", r.display()));
    }
    out.json(&serde_json::json!({
        "out": a.out, "report": a.report, "method": est.method, "df_hz": est.df_hz, "hits_used": est.hits_used,
        "averages": est.hits_used, "averages_of": unit.plural(),
        "hits_dropped": est.hits_dropped, "warnings": est.warnings, "channels": chans,
        "exp_window_sigma": est.exp_window_sigma, "reading": reading.name(),
    }));
    Ok(())
}
