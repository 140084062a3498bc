//! The FMU carries the lean twin: no FRFs, plans or history, so a twin refitted ten times
//! gives an FMU no larger than after its first refit; the full twin file is still read
//! (FMUs exported before); the model description states units, ranges, descriptions and
//! the direct feedthrough; the slave warns once per excursion outside the measured box.

use model_description::ModelDescription;
use mtwin_core::axis::Axis;
use mtwin_core::twin::{HistoryEntry, Twin};
use mtwin_fmu::resources::{FmuTwin, FMU_TWIN_SCHEMA};
use mtwin_fmu::slave::Slave;
use mtwin_package::export::{export_fmu_with, model_description, FmuSize};
use std::io::Read;
use std::path::Path;
use vmachine::structure::ModalMachine;

/// A stand-in for the slave library: the size tests need no loadable one.
const FAKE_SO: &[u8] = b"\x7fELF not a library";

fn entry(kind: &str, unix_time: u64, previous: &Twin) -> HistoryEntry {
    HistoryEntry {
        unix_time,
        kind: kind.into(),
        files: vec![format!("{kind}.csv")],
        summary: format!("{kind} on generated data"),
        figures: Default::default(),
        previous_poses: if kind == "identify" {
            Vec::new()
        } else {
            previous.poses.clone()
        },
    }
}

/// An 18-pose twin whose poses carry 2000-line FRFs (as an identified twin does).
fn campaign_twin() -> Twin {
    let mut twin = ModalMachine::default_machine().exact_twin([3, 3, 2], &[Axis::X, Axis::Y]);
    let f: Vec<f64> = (1..=2000).map(|k| k as f64).collect();
    for p in &mut twin.poses {
        p.frf = p.model.frf(&f);
    }
    let e = entry("identify", 1_764_000_000, &twin);
    twin.history.push(e);
    twin
}

/// `twin` after a refit on day `day` (history keeps the previous poses, as `refit` does).
fn refit(twin: &mut Twin, day: u64) {
    let e = entry("refit", 1_764_000_000 + 86_400 * day, twin);
    twin.history.push(e);
}

fn export(twin: &Twin, out: &Path) -> FmuSize {
    export_fmu_with(twin, out, Some(FAKE_SO)).expect("export")
}

fn read_entry(fmu: &Path, name: &str) -> Vec<u8> {
    let mut z = zip::ZipArchive::new(std::fs::File::open(fmu).expect("open")).expect("zip");
    let mut b = Vec::new();
    z.by_name(name)
        .expect(name)
        .read_to_end(&mut b)
        .expect("read");
    b
}

#[test]
fn refitted_ten_times_the_fmu_is_no_larger_and_carries_no_history() {
    let d = tempfile::tempdir().expect("tmp");
    let mut twin = campaign_twin();
    let full = serde_json::to_vec_pretty(&twin).expect("json").len() as u64;
    let s0 = export(&twin, &d.path().join("identify.fmu"));
    refit(&mut twin, 1);
    let p1 = d.path().join("refit1.fmu");
    let s1 = export(&twin, &p1);
    for day in 2..=10 {
        refit(&mut twin, day);
    }
    let p10 = d.path().join("refit10.fmu");
    let s10 = export(&twin, &p10);
    let full10 = serde_json::to_vec_pretty(&twin).expect("json").len() as u64;
    eprintln!("twin file {full} B -> {full10} B after 10 refits; FMU {s0:?} / {s1:?} / {s10:?}");
    assert!(
        full10 > 5 * full,
        "the history should make the twin file grow"
    );
    // the lean twin is the same size however long the history (dates are fixed width)
    assert_eq!(s10.resources, s1.resources);
    assert_eq!(s10.model_description, s1.model_description);
    assert!(s10.unpacked <= s1.unpacked);
    // the zip: only deflate's handling of other date digits may differ
    assert!(s10.fmu <= s1.fmu + 8, "{} vs {}", s10.fmu, s1.fmu);
    // vs the identified twin: one more kind of history entry in the summary, nothing more
    assert!(s10.unpacked <= s0.unpacked + 200, "{s10:?} vs {s0:?}");
    // well under 1 MB apart from the library, and no FRF, plan or history in it
    assert!(s10.unpacked - s10.library < 1_000_000, "{s10:?}");
    assert!(s10.resources * 20 < full, "{} vs {full}", s10.resources);
    let json = String::from_utf8(read_entry(&p10, "resources/twin.json")).expect("utf-8");
    for absent in [
        "previous_poses",
        "\"frf\"",
        "freqs_hz",
        "\"plan\"",
        "leave_one_out\":[{",
    ] {
        assert!(!json.contains(absent), "resources/twin.json holds {absent}");
    }
    let lean = FmuTwin::from_json(&json, Path::new("twin.json")).expect("lean twin loads");
    assert_eq!(lean.schema, FMU_TWIN_SCHEMA);
    assert_eq!(lean.guid, twin.guid());
    assert_eq!(lean.poses.len(), 18);
    assert_eq!(lean.provenance.poses, 18);
    let kinds: Vec<&str> = lean
        .provenance
        .history
        .iter()
        .map(|k| k.kind.as_str())
        .collect();
    assert_eq!(kinds, ["identify", "refit"]);
    assert_eq!(lean.provenance.history[1].first, "2025-11-25T16:00:00Z");
    assert_eq!(lean.provenance.history[1].last, "2025-12-04T16:00:00Z");
}

#[test]
fn the_slave_reads_a_full_twin_file_like_the_lean_one() {
    let mut twin = campaign_twin();
    twin.extensions
        .cubic
        .push(mtwin_core::twin::CubicStiffness {
            mode: 0,
            kappa: 1e9,
        });
    let full = serde_json::to_string(&twin).expect("json");
    let lean_text = String::from_utf8(FmuTwin::from_twin(&twin).to_json().unwrap()).unwrap();
    let a = FmuTwin::from_json(&full, Path::new("full.json")).expect("full twin");
    let b = FmuTwin::from_json(&lean_text, Path::new("lean.json")).expect("lean twin");
    assert_eq!(a, b);
    assert_eq!(a.guid, twin.guid());
    // same outputs, step by step, at a moving pose
    let (mut sa, mut sb) = (Slave::from_lean(&a).unwrap(), Slave::from_lean(&b).unwrap());
    for s in [&mut sa, &mut sb] {
        s.setup(0.0).unwrap();
        s.enter_init().unwrap();
        s.exit_init().unwrap();
    }
    let (lo, hi) = a.bounds();
    let (mut ya, mut yb) = ([0.0; 2], [0.0; 2]);
    for k in 0..200 {
        let t = k as f64 * 1e-4;
        let x = lo[0] + (hi[0] - lo[0]) * (k as f64 / 200.0);
        let u = [(t * 900.0).sin(), (t * 1300.0).cos(), x, lo[1], lo[2]];
        for s in [&mut sa, &mut sb] {
            s.set_real(&[0, 1, 2, 3, 4], &u).unwrap();
            s.do_step(t, 1e-4).unwrap();
        }
        sa.get_real(&[5, 6], &mut ya).unwrap();
        sb.get_real(&[5, 6], &mut yb).unwrap();
        assert_eq!(ya, yb, "step {k}");
    }
    // a file of neither schema is refused with a message saying what to do
    let e = FmuTwin::from_json(r#"{"schema":"x"}"#, Path::new("r/twin.json")).unwrap_err();
    assert!(e.contains("mtwin export"), "{e}");
}

#[test]
fn model_description_states_units_ranges_descriptions_and_feedthrough() {
    let mut twin = campaign_twin();
    // no direct term on yy: dy does not depend on Fy at the same instant
    for p in &mut twin.poses {
        for c in &mut p.model.channels {
            if c.channel.output == Axis::Y {
                c.d = 0.0;
            } else {
                c.d = 1e-9;
            }
        }
    }
    let xml = model_description(&twin).to_xml().unwrap();
    let md = ModelDescription::from_xml(&xml).unwrap();
    let (lo, hi) = FmuTwin::from_twin(&twin).bounds();
    let units: Vec<&str> = md
        .unit_definitions
        .as_ref()
        .expect("UnitDefinitions")
        .units
        .iter()
        .map(|u| u.name.as_str())
        .collect();
    let vars = &md.model_variables.variables;
    for v in vars {
        let desc = v.description.as_deref().unwrap_or("");
        assert!(desc.len() > 40, "{}: description {desc:?}", v.name);
        let unit = v.real.unit.as_deref().expect("unit");
        assert!(units.contains(&unit), "{}: unit {unit} not defined", v.name);
        if let Some(a) = ["x", "y", "z"].iter().position(|n| *n == v.name) {
            assert_eq!(
                (v.real.min, v.real.max),
                (Some(lo[a]), Some(hi[a])),
                "{}",
                v.name
            );
            let s = v.real.start.expect("start");
            assert!(
                s >= lo[a] && s <= hi[a],
                "{}: start {s} outside min/max",
                v.name
            );
        }
    }
    let dd = |n: &str| vars.iter().find(|v| v.name == n).expect(n);
    assert!(dd("Fx")
        .description
        .as_deref()
        .unwrap()
        .contains("on the tool"));
    assert!(dd("dx")
        .description
        .as_deref()
        .unwrap()
        .contains("relative to"));
    let d = md.description.as_deref().unwrap();
    assert!(
        d.contains("18 poses") && d.contains("identify 2025-11-24"),
        "{d}"
    );
    let date = md.generation_date_and_time.as_deref().expect("date");
    assert!(date.len() == 20 && date.ends_with('Z'), "{date}");
    // Outputs: dx = 6 depends on Fx (1), Fy (2, the xy channel's direct term) and the
    // positions along which the box extends (x 3, y 4, z 5); dy = 7 has no direct force term
    let deps: Vec<(u32, String)> = md
        .model_structure
        .outputs
        .unknowns
        .iter()
        .map(|u| (u.index, u.dependencies.clone().unwrap_or_default()))
        .collect();
    let has_xy = twin.channels.iter().any(|c| c.name() == "xy");
    let dx = if has_xy { "1 2 3 4 5" } else { "1 3 4 5" };
    assert_eq!(deps, [(6, dx.to_string()), (7, "3 4 5".to_string())]);
    assert_eq!(
        md.model_structure.initial_unknowns,
        md.model_structure.outputs
    );
}

#[test]
fn leaving_the_measured_box_warns_once_per_excursion() {
    let twin = ModalMachine::default_machine().exact_twin([3, 3, 2], &[Axis::X, Axis::Y]);
    let mut s = Slave::new(&twin).unwrap();
    let (lo, hi) = s.bounds();
    s.setup(0.0).unwrap();
    s.enter_init().unwrap();
    s.exit_init().unwrap();
    let mid = [
        (lo[0] + hi[0]) / 2.0,
        (lo[1] + hi[1]) / 2.0,
        (lo[2] + hi[2]) / 2.0,
    ];
    let mut y = [0.0; 2];
    let mut warned = Vec::new();
    // inside, out along x for 50 steps, inside, out along z, inside
    for k in 0..300 {
        let mut p = mid;
        if (50..100).contains(&k) {
            p[0] = hi[0] + 0.01 * (1.0 + k as f64);
        }
        if (200..250).contains(&k) {
            p[2] = lo[2] - 0.05;
        }
        let t = k as f64 * 1e-4;
        s.set_real(&[0, 1, 2, 3, 4], &[1.0, 0.0, p[0], p[1], p[2]])
            .unwrap();
        s.get_real(&[5, 6], &mut y).unwrap();
        s.do_step(t, 1e-4).unwrap();
        for w in s.take_warnings() {
            warned.push((k, w));
        }
    }
    let steps: Vec<usize> = warned.iter().map(|(k, _)| *k).collect();
    assert_eq!(steps, [50, 200], "{warned:?}");
    assert!(warned[0].1.contains("x = "), "{}", warned[0].1);
    assert!(warned[1].1.contains("z = "), "{}", warned[1].1);
    assert!(warned[0].1.contains("clamped"), "{}", warned[0].1);
}

/// The FMI 3.0 FMU: the same variables as the FMI 2.0 one (names, value references,
/// causality, variability, descriptions, min/max/start, units and quantities through
/// declared types, dependencies translated from indices to value references) plus the
/// independent variable `time`,
/// written with quick-xml and read back identically; the library under
/// `binaries/x86_64-linux/`, the same resources.
#[test]
fn fmi3_model_description_carries_the_fmi2_variable_table() {
    use model_description::fmi3;
    use mtwin_package::export::{export_fmu_as, model_description_xml, FmiVersion};
    let twin = campaign_twin();
    let md2 =
        ModelDescription::from_xml(&model_description_xml(&twin, FmiVersion::V2).unwrap()).unwrap();
    let xml = model_description_xml(&twin, FmiVersion::V3).unwrap();
    assert!(xml.contains(r#"fmiVersion="3.0""#) && xml.contains("instantiationToken="));
    let md3 = fmi3::ModelDescription::from_xml(&xml).expect("parse FMI 3");
    assert_eq!(
        fmi3::ModelDescription::from_xml(&md3.to_xml().unwrap()).unwrap(),
        md3
    );
    assert_eq!(md3.instantiation_token, md2.guid);
    assert_eq!(md3.description, md2.description);
    assert_eq!(md3.co_simulation.model_identifier, "mtwin_tcp");
    assert_eq!(
        md3.co_simulation
            .can_handle_variable_communication_step_size,
        Some(true)
    );
    assert_eq!(md3.co_simulation.can_get_and_set_fmu_state, Some(true));
    let n = md2.model_variables.variables.len() as u32;
    let time = &md3.model_variables.variables[0];
    assert_eq!(
        (
            time.name.as_str(),
            time.value_reference,
            time.causality.as_deref()
        ),
        ("time", n, Some("independent"))
    );
    assert_eq!(
        md3.model_variables.variables.len(),
        md2.model_variables.variables.len() + 1
    );
    for (v2, v3) in md2
        .model_variables
        .variables
        .iter()
        .zip(&md3.model_variables.variables[1..])
    {
        assert_eq!(v3.name, v2.name);
        assert_eq!(v3.value_reference, v2.value_reference);
        assert_eq!(
            (&v3.causality, &v3.variability),
            (&v2.causality, &v2.variability)
        );
        assert_eq!(v3.description, v2.description);
        let t = md3.declared_type(v3).expect("declaredType");
        assert_eq!((&t.quantity, &t.unit), (&v2.real.quantity, &v2.real.unit));
        assert_eq!((&v3.quantity, &v3.unit), (&None, &None));
        assert_eq!(
            (v3.min, v3.max, v3.start),
            (v2.real.min, v2.real.max, v2.real.start)
        );
    }
    let units3: Vec<String> = md3
        .unit_definitions
        .as_ref()
        .unwrap()
        .units
        .iter()
        .map(|u| u.name.clone())
        .collect();
    assert_eq!(units3, ["N", "m", "s"]);
    // dependencies: 1-based indices in FMI 2.0, value references (index - 1) in FMI 3.0
    let vr_of_index = |i: &str| (i.parse::<u32>().unwrap() - 1).to_string();
    for (u2, u3) in md2
        .model_structure
        .outputs
        .unknowns
        .iter()
        .zip(&md3.model_structure.outputs)
    {
        assert_eq!(u3.value_reference, u2.index - 1);
        let want: Vec<String> = u2
            .dependencies
            .as_deref()
            .unwrap_or("")
            .split_whitespace()
            .map(vr_of_index)
            .collect();
        assert_eq!(u3.dependencies.as_deref(), Some(want.join(" ").as_str()));
    }
    assert_eq!(
        md3.model_structure.outputs.len(),
        md2.model_structure.outputs.unknowns.len()
    );
    assert_eq!(
        md3.model_structure.initial_unknowns,
        md3.model_structure.outputs
    );
    // the package
    let d = tempfile::tempdir().expect("tmp");
    let p = d.path().join("t3.fmu");
    export_fmu_as(&twin, &p, Some(FAKE_SO), FmiVersion::V3).expect("export");
    assert_eq!(
        read_entry(&p, "binaries/x86_64-linux/mtwin_tcp.so"),
        FAKE_SO
    );
    let res = String::from_utf8(read_entry(&p, "resources/twin.json")).unwrap();
    let lean = FmuTwin::from_json(&res, Path::new("twin.json")).expect("lean");
    assert_eq!(lean.guid, md2.guid);
    let z = zip::ZipArchive::new(std::fs::File::open(&p).unwrap()).unwrap();
    assert!(z.file_names().all(|f| !f.starts_with("binaries/linux64")));
}
