//! Packaging a twin as an FMU (work in progress: the slave library is not built yet).

use identify::twin::Twin;
use std::path::Path;

/// Writes the FMU of `twin` to `out`.
///
/// # Errors
/// Always, until the slave library exists.
pub fn export_fmu(_twin: &Twin, _out: &Path) -> Result<(), identify::Error> {
    Err(identify::Error::BadInput(
        "FMU export is not available yet".into(),
    ))
}
