//! What kind of file a path holds (time series, FRF CSV, universal file), and measured
//! FRFs read from it as one pose; FRFs written by the output's extension.
//!
//! The command line asks this module instead of guessing by itself, so a program that
//! uses the library accepts the same files as `mtwin identify`.

use super::{read, uff};
use crate::axis::parse_pose;
use crate::error::{Error, Result};
use crate::frf::Frf;
use mtwin_core::plan::MeasuredAs;
use std::path::{Path, PathBuf};

/// The kinds of input file the product reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// A time-series CSV (force and response columns over `t`).
    TimeSeries,
    /// An FRF CSV (`f_hz` first), docs/formats.md.
    FrfCsv,
    /// A universal file (dataset 58 or 58b).
    Uff,
}

impl InputKind {
    /// The kind of `path`: by extension for universal files, by the header of the
    /// first line that is not a comment for CSVs (`f_hz` first: an FRF CSV).
    pub fn of(path: &Path) -> InputKind {
        if is_uff(path) {
            InputKind::Uff
        } else if is_frf_csv(path) {
            InputKind::FrfCsv
        } else {
            InputKind::TimeSeries
        }
    }

    /// True for measured FRFs (FRF CSV or UFF) rather than a time series.
    pub fn is_frf(self) -> bool {
        self != InputKind::TimeSeries
    }
}

/// True for the extensions universal files go by (`.uff`, `.unv`, `.uf`, `.58`).
pub fn is_uff(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .is_some_and(|e| matches!(e.as_str(), "uff" | "unv" | "uf" | "58"))
}

/// True when the CSV's header (first line that is not a comment) starts with `f_hz`.
fn is_frf_csv(path: &Path) -> bool {
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

/// Splits inputs into time series and measured FRFs; mixing both is refused.
pub fn split_inputs(files: &[PathBuf]) -> Result<(Vec<PathBuf>, Vec<PathBuf>)> {
    let (frfs, series): (Vec<PathBuf>, Vec<PathBuf>) = files
        .iter()
        .cloned()
        .partition(|f| InputKind::of(f).is_frf());
    if let (Some(frf), Some(ts)) = (frfs.first(), series.first()) {
        return Err(Error::BadInput(format!(
            "{} is a measured FRF but {} is a time series: give either time series \
             (FRFs are estimated) or measured FRFs (UFF / FRF CSV), not both",
            frf.display(),
            ts.display()
        )));
    }
    Ok((series, frfs))
}

/// How to read measured FRF files: which universal-file functions, and the pose of files
/// that do not carry one.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Pose of files that carry none (an FRF CSV may carry `# pose=X,Y,Z`).
    pub pose: Option<[f64; 3]>,
    /// UFF: only FRFs with this reference (excitation) node.
    pub uff_ref: Option<i64>,
    /// UFF: only FRFs with this response node.
    pub uff_resp: Option<i64>,
    /// UFF: what the ordinate is when the file leaves it unknown.
    pub uff_ordinate: Option<MeasuredAs>,
}

/// One measured FRF file read as one pose.
#[derive(Debug, Clone)]
pub struct FrfFile {
    /// The FRFs, receptance (m/N).
    pub frf: Frf,
    /// The file's pose, else the one of [`ReadOptions::pose`], else none.
    pub pose: Option<[f64; 3]>,
    /// What the file's FRFs measured when it says so (all alike) or the caller assumed.
    pub measured_as: Option<MeasuredAs>,
    /// What the estimate behind the file's FRFs says of itself, from the FRF CSV's
    /// comment lines ([`write_frf`] writes them; none for a UFF file).
    pub notes: EstimateNotes,
}

/// What an FRF estimate says of itself beyond its lines, carried through an FRF CSV as
/// comment lines before the header (docs/formats.md, "FRF CSV"): without them a twin
/// identified from the file could not take a window out, stop its band at the force's,
/// or tell a coherent channel from a noise-only one.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EstimateNotes {
    /// Decay (1/s) of the exponential window the estimate was made with
    /// (`# exp_window_sigma=V`): its FRFs are then `H(s + σ)`, and identify takes the
    /// window out of the model.
    pub exp_window_sigma: Option<f64>,
    /// Band (Hz) where the estimate's force was within 20 dB of its peak
    /// (`# force_band_hz=LO,HI`): the lines outside it were poorly excited, and
    /// identify's automatic band stops there.
    pub force_band_hz: Option<(f64, f64)>,
    /// Averages behind each channel's estimate, the fewest over the channels
    /// (`# averages=N`: hits of its force direction, Welch segments, chirp periods): the
    /// level pure noise reaches in the coherence, by which identify keeps a noise-only
    /// channel out of the fit.
    pub averages: Option<usize>,
    /// Lines behind each coherence value when the coherence came from the FRF's
    /// line-to-line scatter (one sweep record) instead of averages
    /// (`# coherence_dof=N`).
    pub coherence_dof: Option<usize>,
    /// The pose the records were measured at (`# pose=X,Y,Z`): FRF CSVs of a campaign,
    /// one per pose, identify as that campaign.
    pub pose: Option<[f64; 3]>,
}

fn uff_data_type(m: MeasuredAs) -> i32 {
    match m {
        MeasuredAs::Accelerance => uff::DATA_ACCELERATION,
        MeasuredAs::Mobility => uff::DATA_VELOCITY,
        MeasuredAs::Receptance => uff::DATA_DISPLACEMENT,
    }
}

/// Reads one measured FRF file (UFF or FRF CSV).
pub fn read_frf_file(path: &Path, o: &ReadOptions) -> Result<FrfFile> {
    if is_uff(path) {
        let funcs = uff::read_uff(path)?;
        let assumed = o.uff_ordinate.map(uff_data_type);
        // the quantity the file's FRFs measured (all alike), or the one the caller assumed
        let kinds: Vec<i32> = funcs
            .iter()
            .map(|f| match f.ordinate_axis.data_type {
                t @ (uff::DATA_DISPLACEMENT | uff::DATA_VELOCITY | uff::DATA_ACCELERATION) => t,
                _ => assumed.unwrap_or(0),
            })
            .collect();
        let measured_as = if kinds.windows(2).all(|w| w[0] == w[1]) {
            match kinds.first() {
                Some(&uff::DATA_ACCELERATION) => Some(MeasuredAs::Accelerance),
                Some(&uff::DATA_VELOCITY) => Some(MeasuredAs::Mobility),
                Some(&uff::DATA_DISPLACEMENT) => Some(MeasuredAs::Receptance),
                _ => None,
            }
        } else {
            None
        };
        let sel = uff::UffSelect {
            response_node: o.uff_resp,
            reference_node: o.uff_ref,
            assume_ordinate: assumed,
        };
        let frf = uff::frf_from_uff(&funcs, &sel).map_err(|e| {
            Error::BadInput(format!(
                "{}: {e} (choose FRFs with --uff-ref N / --uff-resp N; --uff-ordinate \
                 accel|vel|disp when the file does not say)",
                path.display()
            ))
        })?;
        let notes = (funcs.iter())
            .find(|f| f.func_type == uff::FUNC_FRF && f.id[3].starts_with(UFF_NOTES))
            .map(|f| notes_from_id_lines(&f.id[3], &f.id[4]))
            .unwrap_or_default();
        Ok(FrfFile {
            frf,
            pose: notes.pose.or(o.pose),
            measured_as,
            notes,
        })
    } else {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let frf = read::parse_frf_csv(&text, path)?;
        Ok(FrfFile {
            frf,
            pose: pose_comment(&text, path)?.or(o.pose),
            measured_as: None,
            notes: EstimateNotes {
                pose: pose_comment(&text, path)?,
                exp_window_sigma: sigma_comment(&text, path)?,
                force_band_hz: band_comment(&text, path)?,
                averages: count_comment(&text, path, AVERAGES_COMMENT)?,
                coherence_dof: count_comment(&text, path, DOF_COMMENT)?,
            },
        })
    }
}

/// The comment lines before an FRF CSV's header: each one's number and its text after
/// the `#`.
fn header_comments(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, t)| !t.is_empty())
        .take_while(|(_, t)| t.starts_with('#'))
        .map(|(n, t)| (n, t.trim_start_matches('#').trim()))
}

/// The pose of an FRF CSV from a comment line `# pose=X,Y,Z`, or `pose=X,Y,Z` as the
/// last word of a comment line (`# analytic receptance at pose=0.2,0.15,0.05`), if any.
fn pose_comment(text: &str, path: &Path) -> Result<Option<[f64; 3]>> {
    for (line, body) in header_comments(text) {
        let found = body.strip_prefix("pose=").or_else(|| {
            body.rsplit_once(" pose=")
                .map(|(_, v)| v)
                .filter(|v| !v.contains(' '))
        });
        if let Some(v) = found {
            return parse_pose(v)
                .map(Some)
                .map_err(|e| Error::bad_file(path, line, None, format!("pose comment: {e}")));
        }
    }
    Ok(None)
}

/// Comment line of an FRF CSV that states the exponential window's decay.
const SIGMA_COMMENT: &str = "exp_window_sigma=";

/// The first word after `key` on a comment line before an FRF CSV's header (`# key...`),
/// with the line's number, if any.
fn comment_value<'t>(text: &'t str, key: &str) -> Option<(usize, &'t str)> {
    header_comments(text).find_map(|(line, body)| {
        body.strip_prefix(key)
            .map(|v| (line, v.split_whitespace().next().unwrap_or("")))
    })
}

/// A decay in 1/s, zero or positive (the window's `exp_window_sigma`).
fn sigma_value(w: &str) -> Option<f64> {
    w.parse::<f64>().ok().filter(|s| s.is_finite() && *s >= 0.0)
}

/// Two frequencies `LO,HI` in Hz with `0 <= LO < HI` (the force's band).
fn band_value(w: &str) -> Option<(f64, f64)> {
    match w
        .split(',')
        .map(|x| x.parse::<f64>().ok())
        .collect::<Vec<_>>()[..]
    {
        [Some(lo), Some(hi)] if lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo => {
            Some((lo, hi))
        }
        _ => None,
    }
}

/// A whole number, at least 1 (averages, scatter lines).
fn count_value(w: &str) -> Option<usize> {
    w.parse::<usize>().ok().filter(|n| *n >= 1)
}

/// The value of a comment line `# key=V ...` before an FRF CSV's header, read by
/// `parse`, if there is one; a value `parse` refuses is an error naming the line, and
/// `rule` says what it must be.
fn comment<T>(
    text: &str,
    path: &Path,
    key: &str,
    parse: fn(&str) -> Option<T>,
    rule: &str,
) -> Result<Option<T>> {
    let Some((line, word)) = comment_value(text, key) else {
        return Ok(None);
    };
    parse(word).map(Some).ok_or_else(|| {
        let name = key.trim_end_matches('=');
        Error::bad_file(path, line, Some(word), format!("{name} must be {rule}"))
    })
}

/// The exponential window's decay of an FRF CSV from a comment line
/// `# exp_window_sigma=V ...` before the header, if any (0: no window).
fn sigma_comment(text: &str, path: &Path) -> Result<Option<f64>> {
    let s = comment(
        text,
        path,
        SIGMA_COMMENT,
        sigma_value,
        "a decay in 1/s, zero or positive",
    )?;
    Ok(s.filter(|s| *s > 0.0))
}

/// Comment line of an FRF CSV that states the force's band.
const BAND_COMMENT: &str = "force_band_hz=";

/// The force's band of an FRF CSV from a comment line `# force_band_hz=LO,HI ...` before
/// the header, if any.
fn band_comment(text: &str, path: &Path) -> Result<Option<(f64, f64)>> {
    let rule = "two frequencies in Hz, LO,HI with 0 <= LO < HI";
    comment(text, path, BAND_COMMENT, band_value, rule)
}

/// Comment line of an FRF CSV that states the averages behind each channel.
const AVERAGES_COMMENT: &str = "averages=";

/// Comment line of an FRF CSV that states the lines behind a scatter coherence.
const DOF_COMMENT: &str = "coherence_dof=";

/// A count from a comment line `# key=N ...` before an FRF CSV's header, if any.
fn count_comment(text: &str, path: &Path, key: &str) -> Result<Option<usize>> {
    comment(text, path, key, count_value, "a whole number, at least 1")
}

/// The format [`write_frf`] chose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrfFormat {
    /// UFF dataset 58 (ASCII).
    Uff58,
    /// UFF dataset 58b (binary).
    Uff58b,
    /// The FRF CSV of docs/formats.md.
    Csv,
}

impl std::fmt::Display for FrfFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FrfFormat::Uff58 => "UFF dataset 58 (ASCII)",
            FrfFormat::Uff58b => "UFF dataset 58b (binary)",
            FrfFormat::Csv => "FRF CSV",
        })
    }
}

/// First word of the ID lines 4 and 5 in which a universal file written by [`write_frf`]
/// states the estimate's notes.
const UFF_NOTES: &str = "mtwin:";

/// The estimate's notes as ID lines 4 and 5 of a universal file's FRF functions (80
/// characters each at most: numbers rounded to 6 decimals, the band to 4).
fn notes_id_lines(n: &EstimateNotes) -> [String; 2] {
    let mut a = UFF_NOTES.to_string();
    if let Some(v) = n.averages {
        a += &format!(" {AVERAGES_COMMENT}{v}");
    }
    if let Some(v) = n.coherence_dof {
        a += &format!(" {DOF_COMMENT}{v}");
    }
    if let Some(v) = n.exp_window_sigma.filter(|s| *s > 0.0) {
        a += &format!(" {SIGMA_COMMENT}{v:.6}");
    }
    let mut b = UFF_NOTES.to_string();
    if let Some([x, y, z]) = n.pose {
        b += &format!(" pose={x:.6},{y:.6},{z:.6}");
    }
    if let Some((lo, hi)) = n.force_band_hz {
        b += &format!(" {BAND_COMMENT}{lo:.4},{hi:.4}");
    }
    [a, b]
}

/// The notes [`notes_id_lines`] wrote, each value read as from the CSV's comments; a
/// word that does not parse is left out (ID lines are free text).
fn notes_from_id_lines(a: &str, b: &str) -> EstimateNotes {
    let mut n = EstimateNotes::default();
    for word in a.split_whitespace().chain(b.split_whitespace()) {
        if let Some(v) = word.strip_prefix(AVERAGES_COMMENT) {
            n.averages = count_value(v);
        } else if let Some(v) = word.strip_prefix(DOF_COMMENT) {
            n.coherence_dof = count_value(v);
        } else if let Some(v) = word.strip_prefix(SIGMA_COMMENT) {
            n.exp_window_sigma = sigma_value(v).filter(|s| *s > 0.0);
        } else if let Some(v) = word.strip_prefix(BAND_COMMENT) {
            n.force_band_hz = band_value(v);
        } else if let Some(v) = word.strip_prefix("pose=") {
            n.pose = parse_pose(v).ok();
        }
    }
    n
}

/// Writes an FRF by the output's extension: UFF dataset 58 (ASCII) for `.uff`/`.unv`,
/// 58b (binary) when `binary`, the FRF CSV of docs/formats.md otherwise. Atomic. The
/// estimate's `notes` are stated and [`read_frf_file`] reads them back: in the CSV as
/// comment lines before its header (`# pose=X,Y,Z`, `# exp_window_sigma=V`,
/// `# force_band_hz=LO,HI`, `# averages=N`, `# coherence_dof=N`), in a universal file
/// as ID lines 4 and 5 of each FRF function (`mtwin: averages=N ...`), which other
/// tools show as text.
pub fn write_frf(path: &Path, frf: &Frf, binary: bool, notes: &EstimateNotes) -> Result<FrfFormat> {
    if is_uff(path) {
        let mut funcs = uff::uff_from_frf(frf, 1);
        if *notes != EstimateNotes::default() {
            let [a, b] = notes_id_lines(notes);
            for f in funcs.iter_mut().filter(|f| f.func_type == uff::FUNC_FRF) {
                f.id[3] = a.clone();
                f.id[4] = b.clone();
            }
        }
        if binary {
            uff::write_uff58b(path, &funcs)?;
            Ok(FrfFormat::Uff58b)
        } else {
            uff::write_uff58(path, &funcs)?;
            Ok(FrfFormat::Uff58)
        }
    } else if binary {
        Err(Error::BadInput(format!(
            "{}: --uff-binary needs a .uff or .unv output",
            path.display()
        )))
    } else {
        let mut text = String::new();
        if let Some([x, y, z]) = notes.pose {
            text += &format!("# pose={x},{y},{z}\n");
        }
        if let Some(sigma) = notes.exp_window_sigma.filter(|s| *s > 0.0) {
            text += &format!(
                "# {SIGMA_COMMENT}{sigma} (1/s: an exponential window's estimate, the FRFs \
                 are H(s + sigma); identify takes the window out)\n"
            );
        }
        if let Some((lo, hi)) = notes.force_band_hz {
            text += &format!(
                "# {BAND_COMMENT}{lo},{hi} (the force's band: within 20 dB of its peak, 40 dB \
                 for one sweep record; identify's automatic band stops there)\n"
            );
        }
        if let Some(n) = notes.averages {
            text += &format!(
                "# {AVERAGES_COMMENT}{n} (behind each channel's estimate: the level pure \
                 noise reaches in the coherence, by which identify leaves a noise-only \
                 channel out)\n"
            );
        }
        if let Some(n) = notes.coherence_dof {
            text += &format!(
                "# {DOF_COMMENT}{n} (lines behind each coherence value, taken from the \
                 FRF's line-to-line scatter)\n"
            );
        }
        text += &read::format_frf_csv(frf)?;
        crate::atomic::write_atomic(path, text.as_bytes())?;
        Ok(FrfFormat::Csv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mtwin-measured-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn kinds_by_extension_and_header() {
        let frf = tmp("a.csv", "# pose=0.1,0.2,0.3\n\"f_hz\",xx_re,xx_im\n1,0,0\n");
        let ts = tmp("b.csv", "t,fx,ax\n0,0,0\n");
        assert_eq!(InputKind::of(&frf), InputKind::FrfCsv);
        assert_eq!(InputKind::of(&ts), InputKind::TimeSeries);
        assert_eq!(InputKind::of(Path::new("x.UNV")), InputKind::Uff);
        assert!(split_inputs(&[frf.clone(), ts.clone()]).is_err());
        let (s, f) = split_inputs(std::slice::from_ref(&ts)).unwrap();
        assert_eq!((s.len(), f.len()), (1, 0));
        let text = std::fs::read_to_string(&frf).unwrap();
        assert_eq!(pose_comment(&text, &frf).unwrap(), Some([0.1, 0.2, 0.3]));
        let bad = "# analytic receptance at pose=0.2,x,0.05\nf_hz\n";
        let e = pose_comment(bad, Path::new("c.csv")).unwrap_err();
        assert!(
            e.is_bad_input() && e.to_string().starts_with("c.csv:1:"),
            "{e}"
        );
    }

    /// An estimate's notes written to an FRF CSV (pose, window, force band, averages,
    /// scatter lines) are read back; a bad value is an error naming its line.
    #[test]
    fn estimate_notes_round_trip_through_an_frf_csv() {
        let dir = std::env::temp_dir().join(format!("mtwin-measured-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let frf = Frf {
            freqs_hz: vec![1.0, 2.0],
            channels: vec![crate::frf::FrfChannel {
                channel: crate::axis::Channel {
                    output: crate::axis::Axis::X,
                    input: crate::axis::Axis::X,
                },
                h: vec![num_complex::Complex64::new(1e-8, 0.0); 2],
                coherence: Some(vec![0.99, 0.98]),
            }],
        };
        let p = dir.join("w.csv");
        let notes = EstimateNotes {
            exp_window_sigma: Some(12.5),
            force_band_hz: Some((3.2, 3726.0)),
            averages: Some(5),
            coherence_dof: Some(7),
            pose: Some([0.6, 0.15, 0.25]),
        };
        write_frf(&p, &frf, false, &notes).unwrap();
        let back = read_frf_file(&p, &ReadOptions::default()).unwrap();
        assert_eq!(back.notes, notes);
        // the same through a universal file's ID lines, rounded as written there
        for (name, binary) in [("w.uff", false), ("w_b.uff", true)] {
            let u = dir.join(name);
            write_frf(&u, &frf, binary, &notes).unwrap();
            let back = read_frf_file(&u, &ReadOptions::default()).unwrap();
            assert_eq!(back.notes, notes, "{name}");
            assert_eq!(back.pose, notes.pose, "{name}");
        }
        let q = dir.join("plain.csv");
        write_frf(&q, &frf, false, &EstimateNotes::default()).unwrap();
        let plain = read_frf_file(&q, &ReadOptions::default()).unwrap();
        assert_eq!(plain.notes, EstimateNotes::default());
        let bad = tmp(
            "bad.csv",
            "# exp_window_sigma=-1\nf_hz,xx_re,xx_im\n1,0,0\n",
        );
        let e = read_frf_file(&bad, &ReadOptions::default()).unwrap_err();
        assert!(
            e.to_string().contains("bad.csv:1") && e.to_string().contains("exp_window_sigma"),
            "{e}"
        );
        let bad = tmp(
            "bad2.csv",
            "# force_band_hz=400,30\nf_hz,xx_re,xx_im\n1,0,0\n",
        );
        assert!(read_frf_file(&bad, &ReadOptions::default()).is_err());
        let bad = tmp("bad3.csv", "# averages=0\nf_hz,xx_re,xx_im\n1,0,0\n");
        let e = read_frf_file(&bad, &ReadOptions::default()).unwrap_err();
        assert!(
            e.to_string().contains("bad3.csv:1") && e.to_string().contains("averages"),
            "{e}"
        );
    }
}
