//! `mtwin export`.

use super::Output;
use anyhow::Result;
use identify::twin::Twin;
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
}

/// Writes the FMU of `twin` to `out`.
pub fn export(twin: &Twin, out: &Path) -> Result<()> {
    mtwin_fmu::export::export_fmu(twin, out)?;
    Ok(())
}

/// Runs `mtwin export`.
pub fn run(a: Args, out: &Output) -> Result<()> {
    super::check_output_not_input(&a.out, std::slice::from_ref(&a.twin))?;
    let twin = Twin::load(&a.twin)?;
    export(&twin, &a.out)?;
    out.say(format!(
        "FMU (FMI 2.0 co-simulation, GUID {}) -> {}",
        twin.guid(),
        a.out.display()
    ));
    out.json(&serde_json::json!({"out": a.out, "guid": twin.guid()}));
    Ok(())
}
