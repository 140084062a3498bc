//! Packaging a twin as an FMU.
//!
//! The slave library is this crate's `cdylib` (`libmtwin_fmu.so`), found in this order:
//! the `MTWIN_FMU_LIB` environment variable; next to the running executable (and its
//! `deps/`), which is where `cargo build`/`cargo run` put it for the `mtwin` binary; the
//! workspace `target/{release,debug}` folders. The `mtwin` binary embeds the library
//! (its build script builds it; see [`export_fmu_with`]), so an installed binary
//! (`cargo install --path .`) needs nothing next to it.

use crate::slave::{variables, Var};
use identify::twin::Twin;
use model_description::{BaseUnit, DefaultExperiment, ModelDescription, Unit, UnitDefinitions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The model identifier (the shared library's name inside the FMU).
pub const MODEL_IDENTIFIER: &str = "mtwin_tcp";

fn bad(msg: String) -> identify::Error {
    identify::Error::BadInput(msg)
}

/// `modelDescription.xml` of `twin`'s FMU.
pub fn model_description(twin: &Twin) -> ModelDescription {
    let mut md = ModelDescription::co_simulation(&twin.name, &twin.guid(), MODEL_IDENTIFIER);
    md.description = Some(format!(
        "mtwin digital twin of the TCP dynamics of '{}': {} pose(s), channels {}",
        twin.name,
        twin.poses.len(),
        twin.channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(",")
    ));
    md.generation_tool = Some(format!("mtwin {}", env!("CARGO_PKG_VERSION")));
    md.co_simulation.can_get_and_set_fmu_state = Some(true);
    md.co_simulation.can_serialize_fmu_state = Some(true);
    md.unit_definitions = Some(UnitDefinitions {
        units: vec![
            Unit {
                name: "N".into(),
                base_unit: Some(BaseUnit {
                    kg: Some(1),
                    m: Some(1),
                    s: Some(-2),
                }),
            },
            Unit {
                name: "m".into(),
                base_unit: Some(BaseUnit {
                    kg: None,
                    m: Some(1),
                    s: None,
                }),
            },
        ],
    });
    md.default_experiment = Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(1.0),
        step_size: Some(1e-4),
    });
    for v in variables(twin) {
        md = match v {
            Var::Force(_) => md.with_real(&v.name(), "input", Some(0.0), Some("N")),
            Var::Pos(_) => md.with_real(&v.name(), "input", Some(0.0), Some("m")),
            Var::Disp(_) => md.with_real(&v.name(), "output", None, Some("m")),
        };
    }
    md
}

/// Where the slave library is (see the module docs).
pub fn find_library() -> Result<PathBuf, identify::Error> {
    let name = "libmtwin_fmu.so";
    let mut tried = Vec::new();
    if let Some(p) = std::env::var_os("MTWIN_FMU_LIB") {
        let p = PathBuf::from(p);
        if p.is_file() {
            return Ok(p);
        }
        tried.push(p);
    }
    let mut dirs = Vec::new();
    if let Ok(exe) = std::env::current_exe() {
        if let Some(d) = exe.parent() {
            dirs.push(d.to_path_buf());
            dirs.push(d.join("deps"));
            if let Some(up) = d.parent() {
                // target/<profile>/examples or target/<profile>/deps
                dirs.push(up.to_path_buf());
                dirs.push(up.join("deps"));
            }
        }
    }
    let ws = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("target");
    for prof in ["release", "debug"] {
        dirs.push(ws.join(prof));
        dirs.push(ws.join(prof).join("deps"));
    }
    for d in dirs {
        let p = d.join(name);
        if p.is_file() {
            return Ok(p);
        }
        tried.push(p);
    }
    Err(identify::Error::Numerical(format!(
        "the FMU slave library {name} was not found (looked at {}); build it with \
         `cargo build --release -p mtwin-fmu` or set MTWIN_FMU_LIB",
        tried
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

/// Writes the FMU of `twin` to `out` (atomically), with the slave library found by
/// [`find_library`].
pub fn export_fmu(twin: &Twin, out: &Path) -> Result<(), identify::Error> {
    export_fmu_with(twin, out, None)
}

/// Writes the FMU of `twin` to `out` (atomically). The slave library is `MTWIN_FMU_LIB`
/// when set, else `embedded` (the bytes of `libmtwin_fmu.so` built into the caller) when
/// given, else the one [`find_library`] finds.
pub fn export_fmu_with(
    twin: &Twin,
    out: &Path,
    embedded: Option<&[u8]>,
) -> Result<(), identify::Error> {
    let so: std::borrow::Cow<[u8]> = match embedded {
        Some(b) if std::env::var_os("MTWIN_FMU_LIB").is_none() => std::borrow::Cow::Borrowed(b),
        _ => {
            let lib = find_library()?;
            std::borrow::Cow::Owned(std::fs::read(&lib).map_err(|e| identify::Error::io(&lib, e))?)
        }
    };
    let xml = model_description(twin)
        .to_xml()
        .map_err(|e| bad(format!("modelDescription.xml: {e}")))?;
    let json = serde_json::to_vec_pretty(twin).map_err(|e| bad(format!("twin: {e}")))?;
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let io = |e: std::io::Error| identify::Error::io(out, e);
        let zerr = |e: zip::result::ZipError| bad(format!("{}: zip: {e}", out.display()));
        zip.start_file("modelDescription.xml", opts).map_err(zerr)?;
        zip.write_all(xml.as_bytes()).map_err(io)?;
        zip.start_file(format!("binaries/linux64/{MODEL_IDENTIFIER}.so"), opts)
            .map_err(zerr)?;
        zip.write_all(&so).map_err(io)?;
        zip.start_file("resources/twin.json", opts).map_err(zerr)?;
        zip.write_all(&json).map_err(io)?;
        zip.finish().map_err(zerr)?;
    }
    identify::atomic::write_atomic(out, buf.get_ref())
}
