//! `mtwin lobes`.

use super::{check_output_not_input, parse_pose, BadInput, Output};
use crate::report::{self, Scale, Series};
use anyhow::Result;
use identify::interpolate::TwinEvaluator;
use identify::lobes::{
    lobes_sd, lobes_zoa, log_speeds, with_rigid_tool_tip, write_lobes_csv, Cut, SdOptions, Tool,
};
use identify::twin::Twin;
use std::path::{Path, PathBuf};

/// Arguments of `mtwin lobes`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The twin file.
    #[arg(long)]
    pub twin: PathBuf,
    /// Pose X,Y,Z in metres where the tool-tip FRF is taken.
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    pub at: [f64; 3],
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
    /// Also write an SVG plot of the lobes here.
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
    check_output_not_input(&a.out, std::slice::from_ref(&a.twin))?;
    if !(a.rpm_min > 0.0 && a.rpm_max > a.rpm_min && a.speeds >= 1) {
        return Err(BadInput(format!(
            "spindle speeds: need 0 < --rpm-min < --rpm-max and --speeds >= 1 (got {} .. {}, {})",
            a.rpm_min, a.rpm_max, a.speeds
        ))
        .into());
    }
    let twin = Twin::load(&a.twin)?;
    let mut ev = TwinEvaluator::new(&twin)?;
    if !ev.is_inside(a.at) {
        out.say(format!(
            "note: pose {} is outside the measured poses; the model of the nearest point of the measured box is used",
            identify::axis::PoseText(a.at)
        ));
    }
    let (model, rigid) = with_rigid_tool_tip(ev.model_at(a.at).clone());
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
        check_output_not_input(p, std::slice::from_ref(&a.twin))?;
        write_lobes_csv(&a.out, &zoa, &[])?;
        write_lobes_csv(p, &[], &sd)?;
    } else {
        write_lobes_csv(&a.out, &zoa, &sd)?;
    }
    let min_zoa = zoa.iter().map(|p| p.ap_lim_m).fold(f64::INFINITY, f64::min);
    let min_sd = sd.iter().map(|p| p.ap_lim_m).fold(f64::INFINITY, f64::min);
    out.say(format!(
        "lobes at ({:.3}, {:.3}, {:.3}) m, {} teeth, ae/D {}, Kt {:.3e} N/m², Kr {}: \
         minimum stable depth ZOA {:.3} mm ({} speeds, {:.0} ms){}",
        a.at[0],
        a.at[1],
        a.at[2],
        a.cut.teeth,
        a.cut.immersion,
        a.cut.kt,
        a.cut.kr,
        min_zoa * 1e3,
        zoa.len(),
        t_zoa.as_secs_f64() * 1e3,
        if sd.is_empty() {
            String::new()
        } else {
            format!(
                ", semi-discretisation {:.3} mm ({} speeds, {:.2} s)",
                min_sd * 1e3,
                sd.len(),
                t_sd.as_secs_f64()
            )
        }
    ));
    if let Some(p) = &a.plot {
        let zx: Vec<f64> = zoa.iter().map(|p| p.rpm).collect();
        let zy: Vec<f64> = zoa.iter().map(|p| p.ap_lim_m * 1e3).collect();
        let sx: Vec<f64> = sd.iter().map(|p| p.rpm).collect();
        let sy: Vec<f64> = sd.iter().map(|p| p.ap_lim_m * 1e3).collect();
        let mut series = vec![Series {
            label: "zero-order (Altintas-Budak)",
            x: &zx,
            y: &zy,
            color: 2,
            points: false,
        }];
        if !sd.is_empty() {
            series.push(Series {
                label: "semi-discretisation",
                x: &sx,
                y: &sy,
                color: 1,
                points: true,
            });
        }
        let svg = report::plot(
            "Stability lobes",
            "spindle speed [rpm]",
            "limiting axial depth [mm]",
            &series,
            Scale::Lin,
        );
        identify::atomic::write_atomic(p, svg.as_bytes())?;
        out.say(format!("plot -> {}", p.display()));
    }
    match &sd_path {
        Some(p) => {
            out.say(format!("zero-order lobes -> {}", a.out.display()));
            out.say(format!(
                "semi-discretisation lobes ({} speeds, not the {} of the zero-order method) -> {}",
                sd.len(),
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
