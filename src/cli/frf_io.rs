//! FRF files on the command line: measured FRFs as input (FRF CSV of docs/formats.md or
//! Universal File Format dataset 58/58b) and FRF output as CSV or UFF by extension.

use super::{parse_pose, BadInput};
use anyhow::Result;
use identify::campaign::MeasuredFrf;
use identify::frf::Frf;
use identify::uff::{self, UffSelect};
use std::path::{Path, PathBuf};

/// Options for reading measured FRFs (UFF selection, pose).
#[derive(Debug, Clone, clap::Args)]
pub struct FrfInputArgs {
    /// Pose X,Y,Z in metres of FRF inputs (UFF or FRF CSV) that do not carry one; an FRF CSV
    /// may carry it as a comment `# pose=X,Y,Z`. Default 0,0,0.
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    pub pose: Option<[f64; 3]>,
    /// UFF input: use only FRFs with this reference (excitation) node.
    #[arg(long)]
    pub uff_ref: Option<i64>,
    /// UFF input: use only FRFs with this response node.
    #[arg(long)]
    pub uff_resp: Option<i64>,
    /// UFF input: what the ordinate is when the file leaves it unknown
    /// (accel, vel, disp).
    #[arg(long, value_parser = ["accel", "vel", "disp"])]
    pub uff_ordinate: Option<String>,
}

/// True for the extensions universal files go by (`.uff`, `.unv`, `.uf`, `.58`).
pub fn is_uff(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .is_some_and(|e| matches!(e.as_str(), "uff" | "unv" | "uf" | "58"))
}

/// True when the CSV's header (first line that is not a comment) starts with `f_hz`,
/// i.e. it is an FRF CSV rather than a time series.
pub fn is_frf_csv(path: &Path) -> bool {
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    use std::io::{BufRead, BufReader};
    for line in BufReader::new(f).lines().take(10_000) {
        let Ok(line) = line else { return false };
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        return t
            .split(',')
            .next()
            .is_some_and(|h| h.trim().trim_matches('"') == "f_hz");
    }
    false
}

/// True when `path` holds measured FRFs (UFF or FRF CSV) rather than a time series.
pub fn is_frf_input(path: &Path) -> bool {
    is_uff(path) || is_frf_csv(path)
}

/// The pose of an FRF CSV from a comment line `# pose=X,Y,Z`, or `pose=X,Y,Z` as the
/// last word of a comment line (`# analytic receptance at pose=0.2,0.15,0.05`), if any.
fn pose_comment(text: &str, path: &Path) -> Result<Option<[f64; 3]>> {
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if !t.starts_with('#') {
            if t.is_empty() {
                continue;
            }
            break;
        }
        let body = t.trim_start_matches('#').trim();
        let found = body.strip_prefix("pose=").or_else(|| {
            body.rsplit_once(" pose=")
                .map(|(_, v)| v)
                .filter(|v| !v.contains(' '))
        });
        if let Some(v) = found {
            return parse_pose(v).map(Some).map_err(|e| {
                BadInput(format!("{}:{}: pose comment: {e}", path.display(), i + 1)).into()
            });
        }
    }
    Ok(None)
}

/// Reads one measured FRF file (UFF or FRF CSV) as one pose.
pub fn read_measured(path: &Path, a: &FrfInputArgs) -> Result<MeasuredFrf> {
    let mut measured_as = None;
    let (frf, pose) = if is_uff(path) {
        let funcs = uff::read_uff(path)?;
        // the quantity the file's FRFs measured (all alike), or the one the user assumed
        let kinds: Vec<i32> = funcs
            .iter()
            .map(|f| match f.ordinate_axis.data_type {
                t @ (uff::DATA_DISPLACEMENT | uff::DATA_VELOCITY | uff::DATA_ACCELERATION) => t,
                _ => match a.uff_ordinate.as_deref() {
                    Some("accel") => uff::DATA_ACCELERATION,
                    Some("vel") => uff::DATA_VELOCITY,
                    Some(_) => uff::DATA_DISPLACEMENT,
                    None => 0,
                },
            })
            .collect();
        if kinds.windows(2).all(|w| w[0] == w[1]) {
            measured_as = match kinds.first() {
                Some(&uff::DATA_ACCELERATION) => Some(identify::plan::MeasuredAs::Accelerance),
                Some(&uff::DATA_VELOCITY) => Some(identify::plan::MeasuredAs::Mobility),
                Some(&uff::DATA_DISPLACEMENT) => Some(identify::plan::MeasuredAs::Receptance),
                _ => None,
            };
        }
        let sel = UffSelect {
            response_node: a.uff_resp,
            reference_node: a.uff_ref,
            assume_ordinate: a.uff_ordinate.as_deref().map(|o| match o {
                "accel" => uff::DATA_ACCELERATION,
                "vel" => uff::DATA_VELOCITY,
                _ => uff::DATA_DISPLACEMENT,
            }),
        };
        let frf = uff::frf_from_uff(&funcs, &sel).map_err(|e| {
            BadInput(format!(
                "{}: {e} (choose FRFs with --uff-ref N / --uff-resp N; --uff-ordinate \
                 accel|vel|disp when the file does not say)",
                path.display()
            ))
        })?;
        (frf, a.pose)
    } else {
        let text = std::fs::read_to_string(path)
            .map_err(|e| BadInput(format!("{}: cannot read: {e}", path.display())))?;
        let frf = identify::read::parse_frf_csv(&text, path)?;
        (frf, pose_comment(&text, path)?.or(a.pose))
    };
    Ok(MeasuredFrf {
        facts: identify::plan::EstimateFacts {
            measured_as,
            ..Default::default()
        },
        pose: pose.unwrap_or([0.0; 3]),
        frf,
        exp_window_sigma: None,
        sources: vec![path.display().to_string()],
        warnings: Vec::new(),
    })
}

/// Writes an FRF by the output's extension: UFF dataset 58 (ASCII) for `.uff`/`.unv`,
/// 58b (binary) when `binary`, the FRF CSV of docs/formats.md otherwise. Atomic.
pub fn write_frf(path: &Path, frf: &Frf, binary: bool) -> Result<&'static str> {
    if is_uff(path) {
        let funcs = uff::uff_from_frf(frf, 1);
        if binary {
            uff::write_uff58b(path, &funcs)?;
            Ok("UFF dataset 58b (binary)")
        } else {
            uff::write_uff58(path, &funcs)?;
            Ok("UFF dataset 58 (ASCII)")
        }
    } else {
        if binary {
            return Err(BadInput(format!(
                "{}: --uff-binary needs a .uff or .unv output",
                path.display()
            ))
            .into());
        }
        identify::read::write_frf_csv(path, frf)?;
        Ok("FRF CSV")
    }
}

/// Splits inputs into time series and measured FRFs; mixing both is refused.
pub fn split_inputs(files: &[PathBuf]) -> Result<(Vec<PathBuf>, Vec<PathBuf>)> {
    let (frfs, series): (Vec<PathBuf>, Vec<PathBuf>) =
        files.iter().cloned().partition(|f| is_frf_input(f));
    if !frfs.is_empty() && !series.is_empty() {
        return Err(BadInput(format!(
            "{} is a measured FRF but {} is a time series: give either time series \
             (FRFs are estimated) or measured FRFs (UFF / FRF CSV), not both",
            frfs[0].display(),
            series[0].display()
        ))
        .into());
    }
    Ok((series, frfs))
}
