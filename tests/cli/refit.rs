//! `mtwin refit` through the command line on generated milling data: the updated twin,
//! its history, the updated FMU and the HTML report; the input twin is never touched.

use crate::common::*;
use identify::axis::Axis;
use identify::read::write_timeseries;
use identify::twin::Twin;
use vmachine::daq::{milling_record, Daq};
use vmachine::excitation::Milling;
use vmachine::structure::ModalMachine;

#[test]
fn refit_writes_twin_history_fmu_and_report() {
    let machine = ModalMachine::default_machine();
    let twin = machine.exact_twin([2, 2, 1], &[Axis::X, Axis::Y]);
    let worn = machine.clone().with_stiffness_change(2, 0.85);
    let c = machine.center();
    let cut = Milling {
        rpm: 3300.0,
        teeth: 3,
        ..Milling::default()
    };
    let rec = milling_record(&worn, &cut, &|_t| c, 6.0, 0.5, &Daq::default(), 3);
    let d = tmp();
    let (tp, mp) = (d.path().join("twin.json"), d.path().join("mill.csv"));
    twin.save(&tp).unwrap();
    write_timeseries(&mp, &rec).unwrap();
    let original = std::fs::read(&tp).unwrap();
    let (out, fmu, report) = (
        d.path().join("twin2.json"),
        d.path().join("twin2.fmu"),
        d.path().join("refit.html"),
    );
    // the report may not overwrite an input
    let o = mtwin(&[
        "refit",
        "--twin",
        s(&tp),
        s(&mp),
        "--out",
        s(&out),
        "--report",
        s(&tp),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.exists());
    let o = mtwin(&[
        "refit",
        "--twin",
        s(&tp),
        s(&mp),
        "--out",
        s(&out),
        "--fmu",
        s(&fmu),
        "--report",
        s(&report),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["report"]["updated"], true);
    let modes = v["report"]["modes"].as_array().unwrap();
    let m2 = modes
        .iter()
        .find(|m| m["mode"] == 2)
        .expect("mode 2 updated");
    let truth = worn.mode_at(2, c).freq_hz();
    let got = m2["freq_after_hz"].as_f64().unwrap();
    assert!((got - truth).abs() < 0.01 * truth, "{got} Hz vs {truth} Hz");
    assert_eq!(std::fs::read(&tp).unwrap(), original, "input twin changed");
    let t2 = Twin::load(&out).unwrap();
    assert_eq!(t2.history.len(), twin.history.len() + 1);
    assert_eq!(t2.history.last().unwrap().kind, "refit");
    assert_eq!(t2.history.last().unwrap().previous_poses, twin.poses);
    let z = std::fs::read(&fmu).unwrap();
    assert!(z.starts_with(b"PK"), "FMU is not a zip");
    let html = std::fs::read_to_string(&report).unwrap();
    for needle in [
        "<svg",
        "Drift check",
        "Modes updated",
        "Operating FRF vs the twin",
        "Measured vs simulated response",
        "History",
    ] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
}

/// An installed binary alone (as `cargo install --path .` leaves it) exports a working
/// FMU: the slave library is embedded.
#[test]
fn a_lone_copy_of_the_binary_exports_with_the_embedded_slave() {
    let d = tmp();
    let exe = d.path().join("mtwin");
    std::fs::copy(env!("CARGO_BIN_EXE_mtwin"), &exe).unwrap();
    let twin = ModalMachine::default_machine().exact_twin([2, 1, 1], &[Axis::X]);
    let tp = d.path().join("t.json");
    twin.save(&tp).unwrap();
    let fmu = d.path().join("t.fmu");
    let o = std::process::Command::new(&exe)
        .args(["export", "--twin", s(&tp), "--out", s(&fmu), "--json"])
        .env_remove("MTWIN_FMU_LIB")
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["slave_library"], "embedded", "{v}");
    // sizes: the .fmu, and unpacked the lean twin (no FRFs or history) and the library
    let size = &v["size_bytes"];
    let n = |k: &str| {
        size[k]
            .as_u64()
            .unwrap_or_else(|| panic!("size_bytes.{k}: {v}"))
    };
    assert_eq!(n("fmu"), std::fs::metadata(&fmu).unwrap().len());
    assert_eq!(
        n("unpacked"),
        n("resources") + n("slave_library") + n("model_description")
    );
    assert!(n("resources") < 100_000, "{v}");
    // the zip holds an ELF shared object under binaries/linux64
    let mut z = zip::ZipArchive::new(std::fs::File::open(&fmu).unwrap()).unwrap();
    let mut so = Vec::new();
    std::io::Read::read_to_end(
        &mut z.by_name("binaries/linux64/mtwin_tcp.so").unwrap(),
        &mut so,
    )
    .unwrap();
    assert!(so.starts_with(b"\x7fELF"), "not an ELF shared object");
    assert!(so.windows(20).any(|w| w == b"fmi2GetTypesPlatform"));
}
