//! Helpers shared by the command-line integration tests.

pub mod modal;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `../shared/data` (the real measured data), or `$MTWIN_SHARED/data` when that is set
/// (to run the tryout tests on another data set of the same form, e.g. one written by
/// `cargo run --release -p lumped --example dump`).
pub fn shared_data() -> PathBuf {
    if let Ok(p) = std::env::var("MTWIN_SHARED") {
        return PathBuf::from(p).join("data");
    }
    let local = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if local.is_dir() {
        return local;
    }
    PathBuf::from("/work/shared/data")
}

/// Runs the `mtwin` binary.
pub fn mtwin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mtwin"))
        .args(args)
        .output()
        .expect("run mtwin")
}

/// stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh temporary directory.
pub fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().expect("tempdir")
}

/// Path as &str.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The pose in a truth file's first comment line (`... pose=X,Y,Z`).
pub fn pose_of(path: &Path) -> [f64; 3] {
    let text = std::fs::read_to_string(path).expect("truth file");
    let first = text.lines().next().unwrap_or_default();
    let p: Vec<f64> = first
        .split("pose=")
        .nth(1)
        .expect("pose in the comment line")
        .split_whitespace()
        .next()
        .unwrap_or_default()
        .split(',')
        .map(|v| v.parse().expect("pose number"))
        .collect();
    [p[0], p[1], p[2]]
}

/// The numbers of a JSON array (empty when it is none).
pub fn f64_list(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .map(|a| a.iter().filter_map(serde_json::Value::as_f64).collect())
        .unwrap_or_default()
}
