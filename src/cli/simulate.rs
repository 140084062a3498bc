//! `mtwin simulate`.

use super::{read_series, Output};
use anyhow::Result;
use identify::interpolate::TwinEvaluator;
use identify::simulate::Hold;
use identify::twin::Twin;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `mtwin simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The twin file.
    #[arg(long)]
    pub twin: PathBuf,
    /// Time-series CSV with forces (and axis positions; absent = 0).
    pub data: PathBuf,
    /// Output CSV: t, dx, dy, dz (the axes the twin has).
    #[arg(long)]
    pub out: PathBuf,
    /// Force between samples: zoh = held (what the FMU does; identical outputs),
    /// foh = linear, band = the band-limited signal the samples of an anti-aliased
    /// measurement stand for (windowed-sinc upsampled 16x; the most accurate for measured
    /// records: a hold on the samples mis-states the force near the Nyquist frequency).
    #[arg(long, default_value = "zoh", value_parser = ["zoh", "foh", "band"])]
    pub hold: String,
}

/// Runs `mtwin simulate`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    super::check_output_not_input(&a.out, &[a.twin.clone(), a.data.clone()])?;
    let twin = Twin::load(&a.twin)?;
    let ts = read_series(std::slice::from_ref(&a.data), out)?.remove(0);
    let hold = match a.hold.as_str() {
        "foh" => Hold::Foh,
        "band" => Hold::BandLimited,
        _ => Hold::Zoh,
    };
    if !twin.extensions.is_empty() {
        // the extended twin of `mtwin diagnose`: delay, external vibration, cubic stiffness
        out.say("simulating with the twin's extensions (from mtwin diagnose)");
    }
    let y = twin.simulate(&ts, hold)?;
    let mut axes: Vec<identify::axis::Axis> = twin.channels.iter().map(|c| c.output).collect();
    axes.sort();
    axes.dedup();
    let mut text = String::with_capacity(y.len() * 64);
    text.push_str(&format!(
        "# mtwin simulate: twin={} data={} hold={}\nt",
        a.twin.display(),
        a.data.display(),
        a.hold
    ));
    for ax in &axes {
        let _ = write!(text, ",d{ax}");
    }
    text.push('\n');
    for (i, row) in y.iter().enumerate() {
        let _ = write!(text, "{}", ts.t0 + i as f64 * ts.dt);
        for ax in &axes {
            let _ = write!(text, ",{:e}", row[ax.index()]);
        }
        text.push('\n');
    }
    identify::atomic::write_atomic(&a.out, text.as_bytes())?;
    let ev = TwinEvaluator::new(&twin)?;
    let outside = (0..ts.len())
        .filter(|&i| !ev.is_inside(ts.position_at(i)))
        .count();
    if outside > 0 {
        out.say(format!(
            "warning: {} outside the measured poses; the model of the nearest \
             point of the measured box was used there",
            if outside == 1 {
                "1 sample lies".to_string()
            } else {
                format!("{outside} samples lie")
            }
        ));
    }
    out.say(format!(
        "{} samples at {:.1} Hz simulated ({} hold) -> {}",
        y.len(),
        ts.fs(),
        a.hold,
        a.out.display()
    ));
    out.json(&serde_json::json!({"out": a.out, "samples": y.len(), "hold": a.hold, "samples_outside_measured_box": outside}));
    Ok(())
}
