//! `mtwin export`.

use super::Output;
use anyhow::Result;
use identify::twin::Twin;
use mtwin_package::export::{FmiVersion, FmuSize};
use std::path::{Path, PathBuf};

/// Arguments of `mtwin export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The twin file.
    #[arg(long)]
    pub twin: PathBuf,
    /// The FMU to write.
    #[arg(long)]
    pub out: PathBuf,
    /// FMI version of the FMU: 2 (FMI 2.0, `binaries/linux64/`) or 3 (FMI 3.0,
    /// `binaries/x86_64-linux/`, Float64 variables plus the independent variable `time`).
    /// Same slave library, resources and variables.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub fmi: u8,
}

/// The FMU slave library built into this binary (see build.rs), if it was.
#[cfg(mtwin_embedded_fmu)]
pub const EMBEDDED_SLAVE: Option<&[u8]> =
    Some(include_bytes!(concat!(env!("OUT_DIR"), "/libmtwin_fmu.so")));
/// The FMU slave library built into this binary (see build.rs), if it was.
#[cfg(not(mtwin_embedded_fmu))]
pub const EMBEDDED_SLAVE: Option<&[u8]> = None;

/// Writes the FMI 2.0 FMU of `twin` to `out`; returns its sizes.
pub fn export(twin: &Twin, out: &Path) -> Result<FmuSize> {
    export_as(twin, out, FmiVersion::V2)
}

/// Writes the FMU of `twin` in FMI `version` to `out`; returns its sizes.
pub fn export_as(twin: &Twin, out: &Path, version: FmiVersion) -> Result<FmuSize> {
    Ok(mtwin_package::export::export_fmu_as(
        twin,
        out,
        EMBEDDED_SLAVE,
        version,
    )?)
}

/// `1.23 MB` / `45.6 kB` / `789 B`.
pub fn human_bytes(n: u64) -> String {
    match n {
        0..1_000 => format!("{n} B"),
        1_000..1_000_000 => format!("{:.1} kB", n as f64 / 1e3),
        _ => format!("{:.2} MB", n as f64 / 1e6),
    }
}

/// One line on the sizes of an exported twin FMU.
pub fn size_line(s: &FmuSize) -> String {
    format!(
        "  size {}; the resources hold the pose models only (no FRFs, plans or history)",
        sizes(s)
    )
}

/// The sizes of an exported FMU: `1.2 MB (unpacked …: slave library …, resources …,
/// modelDescription.xml …)`.
pub fn sizes(s: &FmuSize) -> String {
    format!(
        "{} (unpacked {}: slave library {}, resources {}, modelDescription.xml {})",
        human_bytes(s.fmu),
        human_bytes(s.unpacked),
        human_bytes(s.library),
        human_bytes(s.resources),
        human_bytes(s.model_description)
    )
}

/// Where the slave library of an export comes from: `embedded` or its path.
pub fn slave_source() -> String {
    if EMBEDDED_SLAVE.is_some() && std::env::var_os("MTWIN_FMU_LIB").is_none() {
        return "embedded".into();
    }
    mtwin_package::export::find_library()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|e| e.to_string())
}

/// The twin's extensions the FMU carries (cubic stiffness, external vibrations) and those
/// it leaves out (a measuring-chain delay).
pub fn extensions_in_fmu(twin: &Twin) -> (Vec<String>, Vec<String>) {
    let e = &twin.extensions;
    let mut carried = Vec::new();
    if !e.cubic.is_empty() {
        carried.push(format!(
            "cubic modal stiffness on {}",
            identify::axis::count(e.cubic.len(), "mode")
        ));
    }
    if !e.disturbance.is_empty() {
        carried.push(format!(
            "external vibration at {} Hz",
            e.disturbance
                .iter()
                .map(|d| format!("{:.1}", d.freq_hz))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let left = e
        .delay_s
        .map(|d| vec![format!("response delay {:.3} ms", d * 1e3)])
        .unwrap_or_default();
    (carried, left)
}

/// Runs `mtwin export`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    super::check_output_not_input(&a.out, std::slice::from_ref(&a.twin))?;
    let twin = Twin::load(&a.twin)?;
    let version = if a.fmi == 3 {
        FmiVersion::V3
    } else {
        FmiVersion::V2
    };
    let size = export_as(&twin, &a.out, version)?;
    let slave = slave_source();
    let token = match version {
        FmiVersion::V2 => "GUID",
        FmiVersion::V3 => "instantiationToken",
    };
    out.say(format!(
        "FMU (FMI {} co-simulation, {token} {}, slave library {slave}) -> {}",
        version.number(),
        twin.guid(),
        a.out.display()
    ));
    out.say(size_line(&size));
    let (carried, left_out) = extensions_in_fmu(&twin);
    if !carried.is_empty() {
        out.say(format!(
            "  the FMU includes the twin's {}",
            carried.join(", ")
        ));
    }
    if !left_out.is_empty() {
        out.say(format!(
            "  not in the FMU: {} (a delay between force and response channels belongs to the \
             measuring chain, not to the tool centre point)",
            left_out.join(", ")
        ));
    }
    out.json(&serde_json::json!({
        "out": a.out,
        "fmi_version": version.number(),
        "guid": twin.guid(),
        "slave_library": slave,
        "extensions_in_fmu": carried,
        "extensions_not_in_fmu": left_out,
        "size_bytes": {
            "fmu": size.fmu,
            "unpacked": size.unpacked,
            "resources": size.resources,
            "slave_library": size.library,
            "model_description": size.model_description,
        },
    }));
    Ok(())
}
