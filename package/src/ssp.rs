//! A System Structure and Parameterization (SSP 1.0) package that wires the twin FMU to
//! the process FMU: `SystemStructure.ssd` (components, connectors, connections and the
//! parameter values: the pose of the cut and the cut's parameters) beside
//! `resources/twin.fmu` and `resources/cut.fmu`.

use crate::export::{export_fmu_with, FmuSize};
use crate::process::export_process_fmu;
use mtwin_core::twin::Twin;
use mtwin_fmu::process::{param_names, Cut};
use mtwin_fmu::slave::{variables, Var};
use quick_xml::events::{BytesDecl, Event};
use quick_xml::Writer;
use std::io::Write;
use std::path::Path;

fn bad(msg: String) -> mtwin_core::Error {
    mtwin_core::Error::BadInput(msg)
}

/// One connector of a component: name, kind, unit.
type Connector = (String, &'static str, Option<&'static str>);

fn twin_connectors(twin: &Twin) -> Vec<Connector> {
    variables(twin)
        .into_iter()
        .map(|v| match v {
            Var::Force(_) => (v.name(), "input", Some("N")),
            Var::Pos(_) => (v.name(), "input", Some("m")),
            Var::Disp(_) => (v.name(), "output", Some("m")),
        })
        .collect()
}

fn cut_connectors() -> Vec<Connector> {
    let mut c: Vec<Connector> = vec![
        ("dx".into(), "input", Some("m")),
        ("dy".into(), "input", Some("m")),
        ("Fx".into(), "output", Some("N")),
        ("Fy".into(), "output", Some("N")),
    ];
    c.extend(param_names().map(|(n, u)| (n.to_string(), "parameter", u)));
    c
}

/// The SSD text: the two components, the four connections (twin dx, dy → cut; cut Fx, Fy
/// → twin) and the parameter values (`pose` for the twin's axis inputs, the cut's
/// parameters).
pub fn system_structure(twin: &Twin, pose: [f64; 3], cut: &Cut, stop_time: f64) -> String {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    let xml = |r: std::io::Result<()>| r.expect("writing to memory");
    xml(w
        .write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .map_err(std::io::Error::other));
    let twin_params: Vec<(String, f64)> = ["x", "y", "z"]
        .iter()
        .zip(pose)
        .filter(|(n, _)| twin_connectors(twin).iter().any(|c| c.0 == **n))
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    let cut_params: Vec<(String, f64)> = mtwin_fmu::process::param_values(cut);
    let component = |w: &mut Writer<Vec<u8>>,
                     name: &str,
                     source: &str,
                     conns: &[Connector],
                     params: &[(String, f64)]| {
        w.create_element("ssd:Component")
            .with_attributes([
                ("name", name),
                ("type", "application/x-fmu-sharedlibrary"),
                ("source", source),
            ])
            .write_inner_content(|w| {
                w.create_element("ssd:Connectors")
                    .write_inner_content(|w| {
                        for (n, kind, unit) in conns {
                            w.create_element("ssd:Connector")
                                .with_attributes([("name", n.as_str()), ("kind", *kind)])
                                .write_inner_content(|w| {
                                    let e = w.create_element("ssc:Real");
                                    match unit {
                                        Some(u) => e.with_attribute(("unit", *u)),
                                        None => e,
                                    }
                                    .write_empty()?;
                                    Ok(())
                                })?;
                        }
                        Ok(())
                    })?;
                w.create_element("ssd:ParameterBindings")
                    .write_inner_content(|w| {
                        w.create_element("ssd:ParameterBinding")
                            .write_inner_content(|w| {
                                w.create_element("ssd:ParameterValues")
                                    .write_inner_content(|w| {
                                        w.create_element("ssv:ParameterSet")
                                            .with_attributes([("version", "1.0"), ("name", name)])
                                            .write_inner_content(|w| {
                                                w.create_element("ssv:Parameters")
                                                    .write_inner_content(|w| {
                                                        for (n, v) in params {
                                                            w.create_element("ssv:Parameter")
                                                                .with_attribute((
                                                                    "name",
                                                                    n.as_str(),
                                                                ))
                                                                .write_inner_content(|w| {
                                                                    w.create_element("ssv:Real")
                                                                        .with_attribute((
                                                                            "value",
                                                                            format!("{v:e}")
                                                                                .as_str(),
                                                                        ))
                                                                        .write_empty()?;
                                                                    Ok(())
                                                                })?;
                                                        }
                                                        Ok(())
                                                    })?;
                                                Ok(())
                                            })?;
                                        Ok(())
                                    })?;
                                Ok(())
                            })?;
                        Ok(())
                    })?;
                Ok(())
            })
            .map(|_| ())
    };
    let stop = format!("{stop_time:e}");
    xml(w
        .create_element("ssd:SystemStructureDescription")
        .with_attributes([
            (
                "xmlns:ssd",
                "http://ssp-standard.org/SSP1/SystemStructureDescription",
            ),
            (
                "xmlns:ssc",
                "http://ssp-standard.org/SSP1/SystemStructureCommon",
            ),
            (
                "xmlns:ssv",
                "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
            ),
            ("version", "1.0"),
            ("name", "milling"),
            (
                "generationTool",
                concat!("mtwin ", env!("CARGO_PKG_VERSION")),
            ),
        ])
        .write_inner_content(|w| {
            w.create_element("ssd:System")
                .with_attribute(("name", "milling"))
                .write_inner_content(|w| {
                    w.create_element("ssd:Elements").write_inner_content(|w| {
                        component(
                            w,
                            "twin",
                            "resources/twin.fmu",
                            &twin_connectors(twin),
                            &twin_params,
                        )?;
                        component(
                            w,
                            "cut",
                            "resources/cut.fmu",
                            &cut_connectors(),
                            &cut_params,
                        )
                    })?;
                    w.create_element("ssd:Connections")
                        .write_inner_content(|w| {
                            for (se, sc, ee, ec) in [
                                ("twin", "dx", "cut", "dx"),
                                ("twin", "dy", "cut", "dy"),
                                ("cut", "Fx", "twin", "Fx"),
                                ("cut", "Fy", "twin", "Fy"),
                            ] {
                                w.create_element("ssd:Connection")
                                    .with_attributes([
                                        ("startElement", se),
                                        ("startConnector", sc),
                                        ("endElement", ee),
                                        ("endConnector", ec),
                                    ])
                                    .write_empty()?;
                            }
                            Ok(())
                        })?;
                    Ok(())
                })?;
            w.create_element("ssd:DefaultExperiment")
                .with_attributes([("startTime", "0"), ("stopTime", stop.as_str())])
                .write_empty()?;
            Ok(())
        })
        .map(|_| ()));
    String::from_utf8(w.into_inner()).expect("the SSD is UTF-8")
}

/// Writes the SSP package of `twin` cutting with `cut` at `pose` to `out` (atomically).
/// Returns the sizes of the twin FMU and the process FMU inside.
pub fn export_ssp(
    twin: &Twin,
    pose: [f64; 3],
    cut: &Cut,
    stop_time: f64,
    out: &Path,
    embedded: Option<&[u8]>,
) -> Result<(FmuSize, FmuSize), mtwin_core::Error> {
    if !(stop_time.is_finite() && stop_time > 0.0) {
        return Err(bad(format!("stop time {stop_time} s must be positive")));
    }
    let dir = tempfile_dir(out)?;
    let (tf, cf) = (dir.join("twin.fmu"), dir.join("cut.fmu"));
    let sizes = (
        export_fmu_with(twin, &tf, embedded)?,
        export_process_fmu(cut, &cf, embedded)?,
    );
    let read = |p: &Path| std::fs::read(p).map_err(|e| mtwin_core::Error::io(p, e));
    let (tb, cb) = (read(&tf)?, read(&cf)?);
    let _ = std::fs::remove_dir_all(&dir);
    let ssd = system_structure(twin, pose, cut, stop_time);
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut zip = zip::ZipWriter::new(&mut buf);
        let deflate = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        let stored = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored);
        let io = |e: std::io::Error| mtwin_core::Error::io(out, e);
        let zerr = |e: zip::result::ZipError| bad(format!("{}: zip: {e}", out.display()));
        zip.start_file("SystemStructure.ssd", deflate)
            .map_err(zerr)?;
        zip.write_all(ssd.as_bytes()).map_err(io)?;
        for (name, bytes) in [("resources/twin.fmu", &tb), ("resources/cut.fmu", &cb)] {
            zip.start_file(name, stored).map_err(zerr)?;
            zip.write_all(bytes).map_err(io)?;
        }
        zip.finish().map_err(zerr)?;
    }
    mtwin_core::atomic::write_atomic(out, buf.get_ref())?;
    Ok(sizes)
}

/// A fresh folder next to `out` for the two FMUs before they go into the package.
fn tempfile_dir(out: &Path) -> Result<std::path::PathBuf, mtwin_core::Error> {
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let d = parent.join(format!(".mtwin-ssp-{}", std::process::id()));
    std::fs::create_dir_all(&d).map_err(|e| mtwin_core::Error::io(&d, e))?;
    Ok(d)
}
