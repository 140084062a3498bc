//! Records as the data acquisition delivers them, and the CSV files of SPEC sections 2
//! (time series) and 3 (FRF).

use crate::frf::{Frf, AXES};
use crate::structure::Pose;
use crate::Error;
use std::fmt::Write as _;
use std::path::Path;

/// What the response channels hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// Relative acceleration tool − workpiece `ax, ay, az` (m/s²).
    Acceleration,
    /// Relative displacement `dx, dy, dz` (m).
    Displacement,
}

/// One measured record at the output rate.
#[derive(Clone, Debug)]
pub struct Record {
    /// Metadata written as `#` comment lines (without the `# `).
    pub comments: Vec<String>,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Force `fx, fy, fz` (N).
    pub force: [Vec<f64>; 3],
    /// Response (see [`Record::kind`]).
    pub response: [Vec<f64>; 3],
    /// What the response holds.
    pub kind: Response,
    /// Axis positions per sample.
    pub poses: Vec<Pose>,
}

impl Record {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.force[0].len()
    }

    /// True when the record has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The CSV text of a time series (docs/formats.md, "Time-series CSV"): comments, header
    /// `t,fx,fy,fz,ax,ay,az,x,y,z` (or `dx,dy,dz`), one row per sample.
    pub fn to_csv(&self) -> String {
        let mut s = String::with_capacity(self.len() * 150 + 200);
        for c in &self.comments {
            let _ = writeln!(s, "# {c}");
        }
        let r = match self.kind {
            Response::Acceleration => "a",
            Response::Displacement => "d",
        };
        let _ = writeln!(s, "t,fx,fy,fz,{r}x,{r}y,{r}z,x,y,z");
        for i in 0..self.len() {
            let t = i as f64 / self.fs;
            let p = self.poses[i.min(self.poses.len().saturating_sub(1))];
            let _ = write!(s, "{t}");
            for ch in self.force.iter().chain(self.response.iter()) {
                let _ = write!(s, ",{}", num(ch[i]));
            }
            let _ = writeln!(s, ",{},{},{}", pos(p[0]), pos(p[1]), pos(p[2]));
        }
        s
    }

    /// Write [`Record::to_csv`] to `path`.
    pub fn write_csv(&self, path: &Path) -> Result<(), Error> {
        write_atomic(path, &self.to_csv())
    }
}

/// Nine significant digits (the values are measurements, not exact numbers).
fn num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    format!("{v:.8e}")
}

/// Axis positions: micrometre resolution.
fn pos(v: f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    format!("{}", if r == 0.0 { 0.0 } else { r })
}

/// Write `text` atomically (mtwin-core's temporary file and rename; a device or pipe is
/// written in place), creating the folder first.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), Error> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
    }
    mtwin_core::atomic::write_atomic_io(path, text.as_bytes()).map_err(|e| Error::io(path, e))
}

impl Frf {
    /// FRF CSV (docs/formats.md, "FRF CSV"): first line `# analytic receptance (m/N) at pose=X,Y,Z`
    /// (plus `extra` comment lines), header `f_hz,xx_re,xx_im,xy_re,...`, all 9 channels.
    pub fn to_csv(&self, extra: &[String]) -> String {
        let mut s = String::new();
        let [x, y, z] = self.pose;
        let _ = writeln!(
            s,
            "# analytic receptance [m/N] at pose={},{},{}",
            pos(x),
            pos(y),
            pos(z)
        );
        for c in extra {
            let _ = writeln!(s, "# {c}");
        }
        let mut head = vec!["f_hz".to_string()];
        for o in AXES {
            for i in AXES {
                head.push(format!("{o}{i}_re"));
                head.push(format!("{o}{i}_im"));
            }
        }
        let _ = writeln!(s, "{}", head.join(","));
        for (f, h) in self.freqs_hz.iter().zip(&self.h) {
            let _ = write!(s, "{f}");
            for o in 0..3 {
                for i in 0..3 {
                    let v = h[(o, i)];
                    let _ = write!(s, ",{},{}", num(v.re), num(v.im));
                }
            }
            s.push('\n');
        }
        s
    }

    /// Write [`Frf::to_csv`] to `path`.
    pub fn write_csv(&self, path: &Path, extra: &[String]) -> Result<(), Error> {
        write_atomic(path, &self.to_csv(extra))
    }
}
