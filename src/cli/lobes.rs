//! `mtwin lobes`.

use super::{check_output_not_input, BadInput, Output};
use crate::report::{self, Scale, Series};
use anyhow::Result;
use identify::axis::count;
use identify::interpolate::TwinEvaluator;
use identify::lobes::{
    lobes_sd, lobes_zoa, log_speeds, with_rigid_tool_tip, write_lobes_csv, Cut, LobePoint,
    SdOptions, Tool,
};
use identify::twin::Twin;
use std::path::{Path, PathBuf};

/// Arguments of `mtwin lobes`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub pose: super::TwinAt,
    /// Output CSV: rpm, ap_lim_zoa_m, ap_lim_sd_m, chatter_hz_zoa, chatter_hz_sd (limits
    /// in m, `inf` = no chatter found; docs/formats.md, "Lobes CSV"). With
    /// `--sd-speeds 0` the two SD columns are left out; with `--sd-speeds N` other than
    /// `--speeds` the semi-discretisation is written to a second file next to it,
    /// `<OUT without .csv>.sd.csv` (rpm, ap_lim_sd_m, chatter_hz_sd).
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub cut: super::cosim::CutArgs,
    /// Lowest spindle speed in rpm.
    #[arg(long, default_value_t = 2000.0)]
    pub rpm_min: f64,
    /// Highest spindle speed in rpm.
    #[arg(long, default_value_t = 20000.0)]
    pub rpm_max: f64,
    /// Number of spindle speeds (log-spaced).
    #[arg(long, default_value_t = 200)]
    pub speeds: usize,
    /// Number of speeds (log-spaced) of the semi-discretisation (exact for the linear
    /// delay equation; slower). Default: the same speeds as the zero-order method, in
    /// the same file; 0 = zero-order method only; any other number: a second file (see
    /// --out).
    #[arg(long)]
    pub sd_speeds: Option<usize>,
    /// Semi-discretisation steps per engaged tooth period.
    #[arg(long, default_value_t = 40)]
    pub sd_steps: usize,
    /// Also write an SVG plot of the lobes here: both methods, the stable region (below
    /// both limits) shaded, the cut's data in the title, the depth axis from the data;
    /// where a new lobe begins as an unstable island (its tip), the limit drops there.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// The semi-discretisation's own file next to `out`: `L.csv` → `L.sd.csv`.
fn sd_csv_path(out: &Path) -> PathBuf {
    let stem = out.file_stem().unwrap_or_default().to_string_lossy();
    out.with_file_name(format!("{stem}.sd.csv"))
}

/// Runs `mtwin lobes`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    check_output_not_input(&a.out, std::slice::from_ref(&a.pose.twin))?;
    if !(a.rpm_min > 0.0 && a.rpm_max > a.rpm_min && a.speeds >= 1) {
        return Err(BadInput(format!(
            "spindle speeds: need 0 < --rpm-min < --rpm-max and --speeds >= 1 (got {} .. {}, {})",
            a.rpm_min, a.rpm_max, a.speeds
        ))
        .into());
    }
    let twin = Twin::load(&a.pose.twin)?;
    let mut ev = TwinEvaluator::new(&twin)?;
    if !ev.is_inside(a.pose.at) {
        out.say(format!(
            "note: pose {} is outside the measured poses; the model of the nearest point of the measured box is used",
            identify::axis::PoseText(a.pose.at)
        ));
    }
    let (model, rigid) = with_rigid_tool_tip(ev.model_at(a.pose.at).clone());
    for ch in rigid {
        out.say(format!(
            "note: the twin has no {} channel; the tool is taken as rigid in {}",
            ch.name(),
            ch.input
        ));
    }
    let tool = Tool {
        teeth: a.cut.teeth,
        diameter_m: a.cut.diameter,
        helix_deg: a.cut.helix,
    };
    let cut = Cut {
        radial_immersion: a.cut.immersion,
        down_milling: !a.cut.up,
        kt: a.cut.kt,
        kr: a.cut.kr,
    };
    let rpm = log_speeds(a.rpm_min, a.rpm_max, a.speeds);
    let t0 = std::time::Instant::now();
    let zoa = lobes_zoa(&model, &tool, &cut, &rpm)?;
    let t_zoa = t0.elapsed();
    let sd_speeds = a.sd_speeds.unwrap_or(a.speeds);
    let (sd, t_sd) = if sd_speeds > 0 {
        let rpm_sd = log_speeds(a.rpm_min, a.rpm_max, sd_speeds);
        let t1 = std::time::Instant::now();
        let opts = SdOptions {
            steps: a.sd_steps.max(2),
            ..SdOptions::default()
        };
        (lobes_sd(&model, &tool, &cut, &rpm_sd, &opts)?, t1.elapsed())
    } else {
        (Vec::new(), std::time::Duration::ZERO)
    };
    // The CSV holds both on one grid when they share it (the default); otherwise the SD
    // lobes go to their own file (no empty columns either way).
    let sd_path = (!sd.is_empty() && sd.len() != zoa.len()).then(|| sd_csv_path(&a.out));
    if let Some(p) = &sd_path {
        check_output_not_input(p, std::slice::from_ref(&a.pose.twin))?;
        write_lobes_csv(&a.out, &zoa, &[])?;
        write_lobes_csv(p, &[], &sd)?;
    } else {
        write_lobes_csv(&a.out, &zoa, &sd)?;
    }
    let min_zoa = zoa.iter().map(|p| p.ap_lim_m).fold(f64::INFINITY, f64::min);
    let min_sd = sd.iter().map(|p| p.ap_lim_m).fold(f64::INFINITY, f64::min);
    out.say(format!(
        "lobes at {}, {}, ae/D {}, Kt {:.3e} N/m², Kr {}: \
         minimum stable depth ZOA {:.3} mm ({}, {:.0} ms){}",
        identify::axis::PoseText(a.pose.at),
        count(a.cut.teeth, "tooth"),
        a.cut.immersion,
        a.cut.kt,
        a.cut.kr,
        min_zoa * 1e3,
        count(zoa.len(), "speed"),
        t_zoa.as_secs_f64() * 1e3,
        if sd.is_empty() {
            String::new()
        } else {
            format!(
                ", semi-discretisation {:.3} mm ({}, {:.2} s)",
                min_sd * 1e3,
                count(sd.len(), "speed"),
                t_sd.as_secs_f64()
            )
        }
    ));
    if let Some(p) = &a.plot {
        let svg = lobes_svg(&a, &zoa, &sd);
        identify::atomic::write_atomic(p, svg.as_bytes())?;
        out.say(format!("plot -> {}", p.display()));
    }
    match &sd_path {
        Some(p) => {
            out.say(format!("zero-order lobes -> {}", a.out.display()));
            out.say(format!(
                "semi-discretisation lobes ({}, not the {} of the zero-order method) -> {}",
                count(sd.len(), "speed"),
                zoa.len(),
                p.display()
            ));
        }
        None if sd.is_empty() => out.say(format!("zero-order lobes -> {}", a.out.display())),
        None => out.say(format!(
            "lobes (zero-order and semi-discretisation) -> {}",
            a.out.display()
        )),
    }
    out.json(&serde_json::json!({
        "out": a.out,
        "sd_out": sd_path,
        "min_ap_zoa_m": min_zoa,
        "min_ap_sd_m": if sd.is_empty() { None } else { Some(min_sd) },
        "zoa": zoa.iter().map(|p| serde_json::json!({"rpm": p.rpm, "ap_lim_m": p.ap_lim_m, "chatter_hz": p.chatter_hz})).collect::<Vec<_>>(),
        "sd": sd.iter().map(|p| serde_json::json!({"rpm": p.rpm, "ap_lim_m": p.ap_lim_m, "chatter_hz": p.chatter_hz})).collect::<Vec<_>>(),
    }));
    Ok(())
}

/// The depth axis's top \[mm\], from the data: the stable region (below both limits) is
/// shown whole, with 10 % room above its highest point, unless that point is more than
/// ten times its lowest (a lobe's asymptote, no chatter found at some speed), when the
/// axis ends at 11 times the lowest (lobe diagrams are read near their minimum; what
/// rises higher leaves the plot at the frame, the shading fills to it). A limit above
/// the region (the other method's lobe tops) leaves the plot at the frame. When neither
/// method finds chatter anywhere: the highest finite limit, else 10 mm.
fn depth_top_mm(envelope: &[f64], zoa: &[LobePoint], sd: &[LobePoint]) -> f64 {
    let finite = |v: &f64| v.is_finite() && *v > 0.0;
    let (lo, hi) = envelope
        .iter()
        .filter(|v| finite(v))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let top = if envelope.iter().any(|v| !finite(v)) {
        // no chatter at some speed: stable up to any depth there
        10.0 * lo
    } else {
        hi.min(10.0 * lo)
    };
    let top = if top.is_finite() {
        top
    } else {
        zoa.iter()
            .chain(sd)
            .map(|p| p.ap_lim_m * 1e3)
            .filter(finite)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    if top.is_finite() {
        1.1 * top
    } else {
        10.0
    }
}

/// The lobes plot: the zero-order and semi-discretisation limits, the stable region
/// (below the lower of the two) shaded, the cut's data in the title; the depth axis from
/// the data ([`depth_top_mm`]). Each limit is one line over the speeds: where a new lobe
/// begins as an unstable island between two speeds (its tip), the limit drops there and
/// the line with it (that drop is the edge of the stable region); `inf` (no chatter
/// found) breaks the line.
fn lobes_svg(a: &Args, zoa: &[LobePoint], sd: &[LobePoint]) -> String {
    let mm = |p: &LobePoint| {
        if p.ap_lim_m.is_finite() {
            p.ap_lim_m * 1e3
        } else {
            f64::NAN
        }
    };
    let zx: Vec<f64> = zoa.iter().map(|p| p.rpm).collect();
    let zy: Vec<f64> = zoa.iter().map(mm).collect();
    let sx: Vec<f64> = sd.iter().map(|p| p.rpm).collect();
    let sy: Vec<f64> = sd.iter().map(mm).collect();
    // stable region: below the lower limit; on the zero-order grid where SD is on it too
    // (no chatter found = stable at every depth: up to the frame)
    let same_grid = sd.len() == zoa.len() && sx == zx;
    let lim = |p: &LobePoint| p.ap_lim_m * 1e3;
    let envelope: Vec<f64> = if sd.is_empty() || !same_grid {
        zoa.iter().map(lim).collect()
    } else {
        zoa.iter()
            .zip(sd)
            .map(|(z, d)| lim(z).min(lim(d)))
            .collect()
    };
    let top_mm = depth_top_mm(&envelope, zoa, sd);
    let shx = zx.clone();
    let shy: Vec<f64> = envelope.iter().map(|v| v.min(top_mm * 2.0)).collect();
    let mut series = vec![Series {
        label: "zero-order (Altintas–Budak)",
        x: &zx,
        y: &zy,
        color: 2,
        points: false,
    }];
    if !sd.is_empty() {
        series.push(Series {
            label: "semi-discretisation (Insperger–Stépán)",
            x: &sx,
            y: &sy,
            color: 1,
            points: false,
        });
    }
    let title = format!(
        "Stability lobes at {}: {}, D {} mm{}, ae/D {:.2} {}, Kt {:.0} N/mm², Kr {:.2}",
        identify::axis::PoseText(a.pose.at),
        count(a.cut.teeth, "tooth"),
        report::eng(a.cut.diameter * 1e3),
        if a.cut.helix != 0.0 {
            format!(", helix {:.0}°", a.cut.helix)
        } else {
            String::new()
        },
        a.cut.immersion,
        if a.cut.up {
            "up-milling"
        } else {
            "down-milling"
        },
        a.cut.kt * 1e-6,
        a.cut.kr,
    );
    report::figure(&report::Figure {
        title: &title,
        xlabel: "spindle speed [rpm]",
        xscale: Scale::Lin,
        xrange: Some((a.rpm_min, a.rpm_max)),
        width: 900,
        panels: &[report::Panel {
            yrange: Some((0.0, top_mm)),
            shade: Some((&shx, &shy, "stable (below both limits)")),
            ..report::Panel::new("limiting axial depth of cut [mm]", Scale::Lin, &series, 380)
        }],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[f64]) -> Vec<LobePoint> {
        v.iter()
            .enumerate()
            .map(|(i, &ap)| LobePoint {
                rpm: 1000.0 * (i + 1) as f64,
                ap_lim_m: ap,
                chatter_hz: 100.0,
            })
            .collect()
    }

    #[test]
    fn depth_axis_shows_the_whole_stable_region() {
        // the envelope's top with 10 % room, not a multiple of the smallest limit
        let env = [20.0, 200.0, 150.0];
        let (zoa, sd) = (pts(&[0.02, 0.2, 0.15]), pts(&[0.03, 0.3, 0.15]));
        assert!((depth_top_mm(&env, &zoa, &sd) - 220.0).abs() < 1e-9);
        // a lobe top near an asymptote (3 m) or no chatter found does not squash the
        // diagram: at most 11 times its minimum
        let env = [20.0, 3000.0, 150.0];
        assert!((depth_top_mm(&env, &zoa, &sd) - 220.0).abs() < 1e-9);
        let env = [20.0, f64::INFINITY, 150.0];
        assert!((depth_top_mm(&env, &zoa, &sd) - 220.0).abs() < 1e-9);
        // no chatter anywhere: the highest finite limit, else 10 mm
        let none = pts(&[f64::INFINITY, f64::INFINITY]);
        assert_eq!(depth_top_mm(&[f64::INFINITY; 2], &none, &none), 10.0);
    }
}
