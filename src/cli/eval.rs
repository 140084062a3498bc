//! `mtwin eval`.

use super::{BadInput, Output};
use anyhow::Result;
use identify::frf::Frf;
use identify::interpolate::TwinEvaluator;
use std::path::PathBuf;

/// Arguments of `mtwin eval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub pose: super::TwinAt,
    /// Output FRF (receptance, m/N): FRF CSV, or Universal File Format dataset 58 when
    /// the name ends in `.uff` or `.unv`.
    #[arg(long)]
    pub out: PathBuf,
    /// With a `.uff`/`.unv` output: write binary dataset 58b instead of ASCII 58.
    #[arg(long)]
    pub uff_binary: bool,
    /// Lowest frequency in Hz (default: the twin's fitted band).
    #[arg(long)]
    pub fmin: Option<f64>,
    /// Highest frequency in Hz (default: the twin's fitted band).
    #[arg(long)]
    pub fmax: Option<f64>,
    /// Number of lines, linearly spaced.
    #[arg(long, default_value_t = 1000)]
    pub lines: usize,
    /// File with one frequency in Hz per line (overrides fmin/fmax/lines).
    #[arg(long)]
    pub freqs: Option<PathBuf>,
}

fn read_freqs(path: &PathBuf) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path).map_err(|e| identify::Error::io(path, e))?;
    let mut v = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f: f64 = t
            .parse()
            .ok()
            .filter(|f: &f64| f.is_finite() && *f >= 0.0)
            .ok_or_else(|| {
                BadInput(format!(
                    "{}:{}: '{t}' is not a frequency in Hz (one non-negative number per line)",
                    path.display(),
                    i + 1
                ))
            })?;
        if v.last().is_some_and(|&l| f <= l) {
            return Err(BadInput(format!(
                "{}:{}: frequencies must be strictly increasing",
                path.display(),
                i + 1
            ))
            .into());
        }
        v.push(f);
    }
    if v.is_empty() {
        return Err(BadInput(format!("{}: no frequencies", path.display())).into());
    }
    Ok(v)
}

/// Runs `mtwin eval`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    let twin = a.pose.load(&a.out)?;
    let mut ev = TwinEvaluator::new(&twin)?;
    let freqs = match &a.freqs {
        Some(p) => read_freqs(p)?,
        None => {
            let lo = a.fmin.unwrap_or_else(|| {
                twin.poses
                    .iter()
                    .map(|p| p.band_hz[0])
                    .fold(f64::INFINITY, f64::min)
            });
            let hi = a
                .fmax
                .unwrap_or_else(|| twin.poses.iter().map(|p| p.band_hz[1]).fold(0.0, f64::max));
            if !(hi > lo) || a.lines < 2 {
                return Err(BadInput(format!(
                    "empty frequency range {lo}..{hi} Hz with {}; give --fmin < --fmax and --lines >= 2",
                    identify::axis::count(a.lines, "line")
                ))
                .into());
            }
            (0..a.lines)
                .map(|i| lo + (hi - lo) * i as f64 / (a.lines - 1) as f64)
                .collect()
        }
    };
    let inside = ev.is_inside(a.pose.at);
    if !inside {
        let (lo, hi) = ev.bounds();
        out.say(format!(
            "warning: pose {} is outside the measured box {}..{}: the model of the nearest \
             point of the box is used (no extrapolation)",
            identify::axis::PoseText(a.pose.at),
            identify::axis::PoseText(lo),
            identify::axis::PoseText(hi)
        ));
    }
    let model = ev.model_at(a.pose.at).clone();
    let frf: Frf = model.frf(&freqs);
    let format = identify::io::measured::write_frf(
        &a.out,
        &frf,
        a.uff_binary,
        &identify::io::measured::EstimateNotes::default(),
    )?;
    out.say(format!(
        "FRF of {} at {} ({} {:.1}-{:.1} Hz, {}) -> {} ({format})",
        identify::axis::count(frf.channels.len(), "channel"),
        identify::axis::PoseText(a.pose.at),
        identify::axis::count(freqs.len(), "line"),
        freqs[0],
        freqs[freqs.len() - 1],
        if inside {
            "interpolated"
        } else {
            "clamped to the measured box"
        },
        a.out.display()
    ));
    out.json(&serde_json::json!({
        "out": a.out, "pose": a.pose.at, "inside_measured_box": inside,
        "method": twin.interpolation.method,
        "natural_freqs_hz": model.modes.iter().map(|m| m.freq_hz()).collect::<Vec<_>>(),
        "damping": model.modes.iter().map(|m| m.zeta).collect::<Vec<_>>(),
    }));
    Ok(())
}
