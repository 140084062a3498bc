//! `mtwin process-fmu` and `mtwin ssp`: the milling process as its own co-simulation FMU,
//! and an SSP package wiring it to the twin FMU.

use super::export::{sizes, EMBEDDED_SLAVE};
use super::Output;
use anyhow::Result;
use mtwin_fmu::process::Cut;
use mtwin_package::process::export_process_fmu;
use std::path::PathBuf;

/// The tool and the cut (shared by `lobes`, `process-fmu` and `ssp`).
#[derive(Debug, Clone, clap::Args)]
pub struct CutArgs {
    /// Number of teeth.
    #[arg(long, default_value_t = 2)]
    pub teeth: usize,
    /// Tool diameter in m (used with a helix).
    #[arg(long, default_value_t = 0.016)]
    pub diameter: f64,
    /// Helix angle in degrees.
    #[arg(long, default_value_t = 0.0)]
    pub helix: f64,
    /// Radial immersion ae/D in (0, 1] (1 = slotting).
    #[arg(long, default_value_t = 1.0)]
    pub immersion: f64,
    /// Up (conventional) milling instead of down (climb) milling.
    #[arg(long)]
    pub up: bool,
    /// Tangential cutting coefficient Kt in N/m².
    #[arg(long, default_value_t = 6e8)]
    pub kt: f64,
    /// Radial to tangential force ratio Kr.
    #[arg(long, default_value_t = 0.3)]
    pub kr: f64,
}

/// The operating point of a simulated cut (`process-fmu`, `ssp`).
#[derive(Debug, Clone, clap::Args)]
pub struct ProcessArgs {
    #[command(flatten)]
    pub cut: CutArgs,
    /// Spindle speed in rpm (the FMU parameter `rpm`'s start value).
    #[arg(long, default_value_t = 6000.0)]
    pub rpm: f64,
    /// Axial depth of cut in m (the FMU parameter `ap`'s start value).
    #[arg(long, default_value_t = 1e-3)]
    pub ap: f64,
    /// Axial slices with a helix.
    #[arg(long, default_value_t = 20)]
    pub slices: u32,
    /// A tap along +x and +y in N at the start, to start the vibration (0: none).
    #[arg(long, default_value_t = 0.0)]
    pub kick: f64,
    /// How long the tap lasts, in s.
    #[arg(long, default_value_t = 0.0)]
    pub kick_duration: f64,
}

impl ProcessArgs {
    fn cut(&self) -> Cut {
        let c = &self.cut;
        Cut {
            rpm: self.rpm,
            ap: self.ap,
            teeth: u32::try_from(c.teeth).unwrap_or(u32::MAX),
            kt: c.kt,
            kr: c.kr,
            immersion: c.immersion,
            down: !c.up,
            helix_deg: c.helix,
            diameter: c.diameter,
            slices: self.slices,
            kick: self.kick,
            kick_duration: self.kick_duration,
        }
    }
}

/// Arguments of `mtwin process-fmu`.
#[derive(Debug, clap::Args)]
pub struct FmuArgs {
    #[command(flatten)]
    pub process: ProcessArgs,
    /// The FMU to write.
    #[arg(long)]
    pub out: PathBuf,
}

/// Arguments of `mtwin ssp`.
#[derive(Debug, clap::Args)]
pub struct SspArgs {
    #[command(flatten)]
    pub pose: super::TwinAt,
    #[command(flatten)]
    pub process: ProcessArgs,
    /// Stop time of the default experiment, in s.
    #[arg(long, default_value_t = 0.5)]
    pub stop_time: f64,
    /// The SSP package to write (`.ssp`).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `mtwin process-fmu`.
pub fn run_fmu(a: FmuArgs, out: &Output) -> Result<()> {
    let cut = a.process.cut();
    let size = export_process_fmu(&cut, &a.out, EMBEDDED_SLAVE)?;
    out.say(format!(
        "process FMU (FMI 2.0 co-simulation: inputs dx, dy; outputs Fx, Fy; {}, {} rpm, \
         ap {} m) -> {}",
        identify::axis::count(cut.teeth as usize, "tooth"),
        cut.rpm,
        cut.ap,
        a.out.display()
    ));
    out.say(format!("  size {}", sizes(&size)));
    out.json(&serde_json::json!({ "out": a.out, "cut": cut, "size_bytes": size.fmu }));
    Ok(())
}

/// Runs `mtwin ssp`.
pub fn run_ssp(a: SspArgs, out: &Output) -> Result<()> {
    let twin = a.pose.load(&a.out)?;
    let cut = a.process.cut();
    let (ts, cs) = mtwin_package::ssp::export_ssp(
        &twin,
        a.pose.at,
        &cut,
        a.stop_time,
        &a.out,
        EMBEDDED_SLAVE,
    )?;
    out.say(format!(
        "SSP (SystemStructure.ssd: twin dx, dy -> cut; cut Fx, Fy -> twin; pose {} and the \
         cut's parameters bound) -> {}",
        identify::axis::PoseText(a.pose.at),
        a.out.display()
    ));
    out.say(format!("  twin FMU {}", sizes(&ts)));
    out.say(format!("  process FMU {}", sizes(&cs)));
    out.json(&serde_json::json!({
        "out": a.out,
        "pose": a.pose.at,
        "cut": cut,
        "twin_fmu_bytes": ts.fmu,
        "process_fmu_bytes": cs.fmu,
    }));
    Ok(())
}
