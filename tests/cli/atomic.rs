//! `mtwin refit` killed (SIGKILL) at several moments: the input twin is untouched, the
//! `--out` file is either its old bytes or a complete new twin, and nothing is left
//! behind but what `identify::atomic` documents (at most the killed process's own
//! `.NAME.tmp-PID`). And an output that would overwrite an input is refused.

use crate::common::*;

use identify::axis::Axis;
use identify::read::write_timeseries;
use identify::twin::Twin;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use vmachine::daq::{milling_record, Daq};
use vmachine::excitation::Milling;
use vmachine::structure::ModalMachine;

/// A twin of the virtual machine and `seconds` of milling on the worn machine.
fn setup(dir: &Path, seconds: f64) -> (PathBuf, PathBuf) {
    let machine = ModalMachine::default_machine();
    let twin = machine.exact_twin([2, 2, 1], &[Axis::X, Axis::Y]);
    let twin_path = dir.join("twin.json");
    twin.save(&twin_path).expect("save twin");
    let worn = machine.clone().with_stiffness_change(2, 0.85);
    let centre = machine.center();
    let cut = Milling {
        rpm: 3300.0,
        teeth: 3,
        ..Milling::default()
    };
    let rec = milling_record(&worn, &cut, &|_t| centre, seconds, 0.5, &Daq::default(), 7);
    let data = dir.join("milling.csv");
    write_timeseries(&data, &rec).expect("write data");
    (twin_path, data)
}

fn refit_cmd(twin: &Path, data: &Path, out: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mtwin"));
    c.args([
        "refit",
        "--quiet",
        "--force",
        "--twin",
        s(twin),
        s(data),
        "--out",
        s(out),
    ])
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    c
}

/// Files of `dir` other than `expected`.
fn extra_files(dir: &Path, expected: &[&Path]) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("read dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| !expected.iter().any(|x| x == p))
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn killed_refit_never_damages_input_or_output() {
    let d = tmp();
    let (twin, data) = setup(d.path(), 20.0);
    let twin_bytes = std::fs::read(&twin).unwrap();
    let data_bytes = std::fs::read(&data).unwrap();
    let out = d.path().join("twin2.json");

    // a full run: how long it takes, and that it writes a new twin
    let t = Instant::now();
    let o = refit_cmd(&twin, &data, &out).output().expect("run");
    let full = t.elapsed();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let new = Twin::load(&out).expect("a complete new twin");
    assert!(new.history.len() > Twin::load(&twin).unwrap().history.len());
    println!("full refit: {:.2} s", full.as_secs_f64());
    assert!(extra_files(d.path(), &[&twin, &data, &out]).is_empty());

    let mut outcomes = (0, 0);
    for frac in [
        0.02, 0.1, 0.25, 0.4, 0.55, 0.7, 0.8, 0.9, 0.95, 0.98, 1.0, 1.05,
    ] {
        // an old output exists: a copy of the input twin
        std::fs::write(&out, &twin_bytes).unwrap();
        let mut child = refit_cmd(&twin, &data, &out).spawn().expect("spawn");
        let pid = child.id();
        std::thread::sleep(full.mul_f64(frac));
        let _ = child.kill(); // SIGKILL on Unix; an error means it had already exited
        let status = child.wait().expect("wait");
        assert_eq!(
            std::fs::read(&twin).unwrap(),
            twin_bytes,
            "input twin changed"
        );
        assert_eq!(
            std::fs::read(&data).unwrap(),
            data_bytes,
            "input data changed"
        );
        let now = std::fs::read(&out).expect("the --out file must still exist");
        if now == twin_bytes {
            outcomes.0 += 1;
        } else {
            Twin::load(&out).unwrap_or_else(|e| {
                panic!("killed at {frac} x run time: --out is neither old nor a valid twin: {e}")
            });
            outcomes.1 += 1;
        }
        // only the killed process's own temporary file may remain (identify::atomic)
        let extra = extra_files(d.path(), &[&twin, &data, &out]);
        let allowed = format!(".twin2.json.tmp-{pid}");
        assert!(
            extra.iter().all(|f| *f == allowed),
            "killed at {frac} x run time ({status}): stray files {extra:?}"
        );
        for f in extra {
            std::fs::remove_file(d.path().join(f)).unwrap();
        }
    }
    println!(
        "after the kills: {} x old output kept, {} x complete new twin",
        outcomes.0, outcomes.1
    );
    assert!(outcomes.0 > 0, "no kill landed before the write");
}

#[test]
fn output_equal_to_an_input_is_refused() {
    let d = tmp();
    let (twin, data) = setup(d.path(), 2.0);
    let twin_bytes = std::fs::read(&twin).unwrap();
    let data_bytes = std::fs::read(&data).unwrap();
    // the same file under another spelling
    let sub = d.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    let twin_alias = sub.join("..").join("twin.json");
    for out in [&twin, &twin_alias, &data] {
        let o = refit_cmd(&twin, &data, out).output().expect("run");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "--out {}: {err}", out.display());
        assert!(err.contains("overwrite an input"), "{err}");
        assert_eq!(std::fs::read(&twin).unwrap(), twin_bytes);
        assert_eq!(std::fs::read(&data).unwrap(), data_bytes);
    }
    assert!(extra_files(d.path(), &[&twin, &data, &sub]).is_empty());
}
