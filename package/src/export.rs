//! Packaging a twin as an FMU (FMI 2.0 or 3.0, [`FmiVersion`]).
//!
//! The slave library is this crate's `cdylib` (`libmtwin_fmu.so`), found in this order:
//! the `MTWIN_FMU_LIB` environment variable; next to the running executable (and its
//! `deps/`), which is where `cargo build`/`cargo run` put it for the `mtwin` binary; the
//! workspace `target/{release,debug}` folders. The `mtwin` binary embeds the library
//! (its build script builds it; see [`export_fmu_with`]), so an installed binary
//! (`cargo install --path .`) needs nothing next to it.

use model_description::{
    BaseUnit, Category, DefaultExperiment, LogCategories, ModelDescription, Real, Unit,
    UnitDefinitions,
};
use mtwin_core::axis::Axis;
use mtwin_core::twin::Twin;
use mtwin_fmu::resources::{utc_iso, FmuTwin};
use mtwin_fmu::slave::{metres, start_pose, variables, Var};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The model identifier (the shared library's name inside the FMU).
pub const MODEL_IDENTIFIER: &str = "mtwin_tcp";

/// The FMI version of an exported FMU. Both carry the same slave library (it exports the
/// `fmi2*` and the `fmi3*` functions), the same resources and the same variables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FmiVersion {
    /// FMI 2.0 Co-Simulation: `binaries/linux64/`.
    #[default]
    V2,
    /// FMI 3.0 Co-Simulation: `binaries/x86_64-linux/`, `Float64` variables, the
    /// independent variable `time` added (see [`model_description::fmi3`]).
    V3,
}

impl FmiVersion {
    /// The slave library `<identifier>.so` inside the FMU, in the folder of the platform
    /// of this build.
    pub fn binary_path(self, identifier: &str) -> String {
        let platform = match self {
            FmiVersion::V2 => "linux64",
            FmiVersion::V3 => "x86_64-linux",
        };
        format!("binaries/{platform}/{identifier}.so")
    }

    /// "2.0" or "3.0".
    pub fn number(self) -> &'static str {
        match self {
            FmiVersion::V2 => "2.0",
            FmiVersion::V3 => "3.0",
        }
    }
}

fn bad(msg: String) -> mtwin_core::Error {
    mtwin_core::Error::BadInput(msg)
}

/// Description of every FMU variable: frame, sign and what is read when.
fn describe(v: Var, lo: &[f64; 3], hi: &[f64; 3]) -> String {
    match v {
        Var::Force(a) => format!(
            "Force on the tool at the tool centre point along the machine's {a} axis (the \
             force the workpiece or the hammer exerts on the tool; positive along +{a}), in N"
        ),
        Var::Pos(a) => {
            let i = a.index();
            format!(
                "Axis position {a} from the machine control, in m (machine coordinates). The \
                 twin was measured for {a} in [{}, {}] m (min/max); outside, the model of the \
                 nearest point of that box is used (clamped, not extrapolated) and a warning \
                 is logged once per excursion",
                metres(lo[i]),
                metres(hi[i])
            )
        }
        Var::Disp(a) => format!(
            "Displacement of the tool centre point along the machine's {a} axis, relative to \
             the workpiece (taken as rigid), in m; positive along +{a}, so a static force \
             +F{a} gives +d{a}. Read after setting the inputs at t, it includes the direct \
             feedthrough of the forces at t"
        ),
    }
}

/// The inputs an output depends on at the same communication point: the forces of the
/// channels with a direct (residual-compliance) term at some pose, and the axis positions
/// along which the measured box has an extent (the model varies there).
fn dependencies(twin: &Twin, out: Axis, lo: &[f64; 3], hi: &[f64; 3]) -> Vec<String> {
    let mut deps = Vec::new();
    for v in variables(twin) {
        match v {
            Var::Force(a) => {
                let direct = twin.poses.iter().any(|p| {
                    p.model
                        .channels
                        .iter()
                        .any(|c| c.channel.output == out && c.channel.input == a && c.d != 0.0)
                });
                if direct {
                    deps.push(v.name());
                }
            }
            Var::Pos(a) if hi[a.index()] > lo[a.index()] => deps.push(v.name()),
            _ => {}
        }
    }
    deps
}

/// `modelDescription.xml` of `twin`'s FMU, generated now.
pub fn model_description(twin: &Twin) -> ModelDescription {
    model_description_at(twin, mtwin_core::twin::now_unix())
}

/// `modelDescription.xml` of `twin`'s FMU, generated at `unix_time` (s since 1970, UTC).
pub fn model_description_at(twin: &Twin, unix_time: u64) -> ModelDescription {
    let lean = FmuTwin::from_twin(twin);
    let (lo, hi) = lean.bounds();
    let mut md = ModelDescription::co_simulation(&twin.name, &lean.guid, MODEL_IDENTIFIER);
    let boxed = Axis::ALL
        .iter()
        .map(|a| {
            let i = a.index();
            format!("{a} {}..{} m", metres(lo[i]), metres(hi[i]))
        })
        .collect::<Vec<_>>()
        .join(", ");
    md.description = Some(format!(
        "mtwin digital twin of the TCP dynamics of '{}' ({}, written by {}): {}; channels {}; \
         measured box {boxed}. Forces on the tool, displacements of the tool relative to the \
         workpiece, machine axis frame, SI units",
        twin.name,
        lean.provenance.twin_schema,
        lean.provenance.twin_tool,
        lean.provenance.line(),
        twin.channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(",")
    ));
    md.generation_tool = Some(format!("mtwin {}", env!("CARGO_PKG_VERSION")));
    md.generation_date_and_time = Some(utc_iso(unix_time));
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
    let cat = |n: &str, d: &str| Category {
        name: n.into(),
        description: Some(d.into()),
    };
    md.log_categories = Some(LogCategories {
        categories: vec![
            cat(
                "logStatusWarning",
                "axis positions outside the measured box (once per excursion)",
            ),
            cat(
                "logStatusError",
                "misuse of the API, bad resources, overflow",
            ),
            cat("logAll", "everything (with debug logging on)"),
        ],
    });
    md.default_experiment = Some(DefaultExperiment {
        start_time: Some(0.0),
        stop_time: Some(1.0),
        step_size: Some(1e-4),
    });
    let start = start_pose(&lo, &hi);
    for v in variables(twin) {
        let d = describe(v, &lo, &hi);
        let real = match v {
            Var::Force(_) => Real {
                quantity: Some("Force".into()),
                unit: Some("N".into()),
                start: Some(0.0),
                ..Real::default()
            },
            Var::Pos(a) => Real {
                quantity: Some("Length".into()),
                unit: Some("m".into()),
                min: Some(lo[a.index()]),
                max: Some(hi[a.index()]),
                start: Some(start[a.index()]),
            },
            Var::Disp(_) => Real {
                quantity: Some("Length".into()),
                unit: Some("m".into()),
                ..Real::default()
            },
        };
        let causality = if matches!(v, Var::Disp(_)) {
            "output"
        } else {
            "input"
        };
        md = md.with_described_real(&v.name(), causality, &d, real);
    }
    for v in variables(twin) {
        if let Var::Disp(a) = v {
            let deps = dependencies(twin, a, &lo, &hi);
            let deps: Vec<&str> = deps.iter().map(String::as_str).collect();
            md.set_dependencies(&v.name(), &deps);
        }
    }
    md
}

/// Where the slave library is (see the module docs).
pub fn find_library() -> Result<PathBuf, mtwin_core::Error> {
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
    Err(mtwin_core::Error::Numerical(format!(
        "the FMU slave library {name} was not found (looked at {}); build it with \
         `cargo build --release -p mtwin-fmu` or set MTWIN_FMU_LIB",
        tried
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )))
}

/// Sizes of an exported FMU, in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FmuSize {
    /// The `.fmu` file (zip).
    pub fmu: u64,
    /// Everything unpacked.
    pub unpacked: u64,
    /// `resources/` unpacked (the lean twin).
    pub resources: u64,
    /// The slave library unpacked.
    pub library: u64,
    /// `modelDescription.xml`.
    pub model_description: u64,
}

/// Writes the FMU of `twin` to `out` (atomically), with the slave library found by
/// [`find_library`].
pub fn export_fmu(twin: &Twin, out: &Path) -> Result<FmuSize, mtwin_core::Error> {
    export_fmu_with(twin, out, None)
}

/// Writes the FMI 2.0 FMU of `twin` to `out` (atomically). The slave library is
/// `MTWIN_FMU_LIB` when set, else `embedded` (the bytes of `libmtwin_fmu.so` built into
/// the caller) when given, else the one [`find_library`] finds.
pub fn export_fmu_with(
    twin: &Twin,
    out: &Path,
    embedded: Option<&[u8]>,
) -> Result<FmuSize, mtwin_core::Error> {
    export_fmu_as(twin, out, embedded, FmiVersion::V2)
}

/// The `modelDescription.xml` text of `twin`'s FMU in FMI `version`, generated now.
pub fn model_description_xml(twin: &Twin, version: FmiVersion) -> Result<String, String> {
    let md = model_description(twin);
    match version {
        FmiVersion::V2 => md.to_xml(),
        FmiVersion::V3 => model_description::fmi3::ModelDescription::from_fmi2(&md).to_xml(),
    }
    .map_err(|e| format!("modelDescription.xml: {e}"))
}

/// Writes the FMU of `twin` in FMI `version` to `out` (atomically); the slave library as
/// for [`export_fmu_with`].
pub fn export_fmu_as(
    twin: &Twin,
    out: &Path,
    embedded: Option<&[u8]>,
    version: FmiVersion,
) -> Result<FmuSize, mtwin_core::Error> {
    let xml = model_description_xml(twin, version).map_err(bad)?;
    // the slave needs the pose models only: no FRFs, plans or history (module docs of
    // `resources`)
    let json = FmuTwin::from_twin(twin).to_json().map_err(bad)?;
    package(
        out,
        &xml,
        &version.binary_path(MODEL_IDENTIFIER),
        embedded,
        &[("resources/twin.json", &json)],
    )
}

/// The slave library's bytes: `MTWIN_FMU_LIB` when set, else `embedded` when given, else
/// the one [`find_library`] finds.
fn library(embedded: Option<&[u8]>) -> Result<std::borrow::Cow<'_, [u8]>, mtwin_core::Error> {
    Ok(match embedded {
        Some(b) if std::env::var_os("MTWIN_FMU_LIB").is_none() => std::borrow::Cow::Borrowed(b),
        _ => {
            let lib = find_library()?;
            std::borrow::Cow::Owned(
                std::fs::read(&lib).map_err(|e| mtwin_core::Error::io(&lib, e))?,
            )
        }
    })
}

/// Writes an FMU (zip) to `out` atomically: `modelDescription.xml`, the slave library at
/// `binary` (e.g. `binaries/linux64/<identifier>.so`) and the `resources` files.
pub fn package(
    out: &Path,
    xml: &str,
    binary: &str,
    embedded: Option<&[u8]>,
    resources: &[(&str, &[u8])],
) -> Result<FmuSize, mtwin_core::Error> {
    let so = library(embedded)?;
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let io = |e: std::io::Error| mtwin_core::Error::io(out, e);
        let zerr = |e: zip::result::ZipError| bad(format!("{}: zip: {e}", out.display()));
        zip.start_file("modelDescription.xml", opts).map_err(zerr)?;
        zip.write_all(xml.as_bytes()).map_err(io)?;
        zip.start_file(binary, opts).map_err(zerr)?;
        zip.write_all(&so).map_err(io)?;
        for (name, bytes) in resources {
            zip.start_file(*name, opts).map_err(zerr)?;
            zip.write_all(bytes).map_err(io)?;
        }
        zip.finish().map_err(zerr)?;
    }
    mtwin_core::atomic::write_atomic(out, buf.get_ref())?;
    let res: u64 = resources.iter().map(|(_, b)| b.len() as u64).sum();
    let (xml_n, so_n) = (xml.len() as u64, so.len() as u64);
    Ok(FmuSize {
        fmu: buf.get_ref().len() as u64,
        unpacked: xml_n + so_n + res,
        resources: res,
        library: so_n,
        model_description: xml_n,
    })
}
