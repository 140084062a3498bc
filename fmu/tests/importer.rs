//! The exported FMUs in a third-party importer: rust-fmi (`fmi` crate) unpacks each `.fmu`,
//! reads its model description with its own schema, loads the slave library from the
//! platform folder of its FMI version (`linux64` / `x86_64-linux`) and drives it through
//! the `fmi2*` / `fmi3*` C functions. A master loop with moving axes and varying forces
//! (inputs set at t, outputs read at t, `doStep(t, h)`) agrees with the library's own
//! simulation (`mtwin_core::interpolate::simulate_twin`, the loop behind `mtwin simulate
//! --hold zoh`) to 1e-9 of the response's peak, and FMI 2.0 agrees with FMI 3.0.

use fmi::fmi2::instance::{CoSimulation as _, Common as _};
use fmi::fmi3::{CoSimulation as _, Common as _, Fmi3Model as _, GetSet as _};
use fmi::traits::FmiImport as _;
use mtwin_core::axis::Axis;
use mtwin_core::interpolate::{simulate_twin, TwinEvaluator};
use mtwin_core::simulate::Hold;
use mtwin_core::twin::Twin;
use mtwin_package::export::{export_fmu_as, FmiVersion};
use std::path::{Path, PathBuf};
use vmachine::structure::ModalMachine;

const STEPS: usize = 600;
const DT: f64 = 1e-4;

fn lib_path() -> PathBuf {
    let exe = std::env::current_exe().expect("exe");
    let deps = exe.parent().expect("deps").to_path_buf();
    for d in [deps.clone(), deps.parent().expect("profile").to_path_buf()] {
        let p = d.join("libmtwin_fmu.so");
        if p.is_file() {
            return p;
        }
    }
    panic!("libmtwin_fmu.so not found near {}", deps.display());
}

/// Forces (x, y) and axis positions (moving through the measured box) at sample `i`.
fn inputs(i: usize, lo: &[f64; 3], hi: &[f64; 3]) -> ([f64; 2], [f64; 3]) {
    let t = i as f64 * DT;
    let f = [
        80.0 * (2.0 * std::f64::consts::PI * 310.0 * t).sin() + 20.0 * ((i * 7919) % 13) as f64,
        -50.0 * (2.0 * std::f64::consts::PI * 870.0 * t).cos(),
    ];
    let s = i as f64 / STEPS as f64;
    let p = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * (0.1 + 0.8 * s));
    (f, p)
}

/// `identify`'s own simulation of the same record: dx, dy at every sample.
fn reference(twin: &Twin, lo: &[f64; 3], hi: &[f64; 3]) -> Vec<[f64; 2]> {
    let mut ev = TwinEvaluator::new(twin).expect("evaluator");
    let forces: Vec<[f64; 3]> = (0..STEPS)
        .map(|i| {
            let (f, _) = inputs(i, lo, hi);
            [f[0], f[1], 0.0]
        })
        .collect();
    let y = simulate_twin(&mut ev, &forces, |i| inputs(i, lo, hi).1, DT, Hold::Zoh);
    y.iter().map(|r| [r[0], r[1]]).collect()
}

fn run_fmi2(fmu: &Path, lo: &[f64; 3], hi: &[f64; 3]) -> Vec<[f64; 2]> {
    let import: fmi::fmi2::import::Fmi2Import = fmi::import::from_path(fmu).expect("import");
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    let vr = |name: &str| {
        md.model_variables
            .variables
            .iter()
            .find(|v| v.name == name)
            .map(|v| v.value_reference)
            .unwrap_or_else(|| panic!("no variable {name}"))
    };
    let ins = ["Fx", "Fy", "x", "y", "z"].map(vr);
    let outs = ["dx", "dy"].map(vr);
    let mut inst = import.instantiate_cs("fmi2", false, false).expect("inst");
    inst.setup_experiment(None, 0.0, None).expect("setup");
    inst.enter_initialization_mode().expect("enter");
    inst.exit_initialization_mode().expect("exit");
    let mut y = Vec::with_capacity(STEPS);
    for i in 0..STEPS {
        let (f, p) = inputs(i, lo, hi);
        inst.set_real(&ins, &[f[0], f[1], p[0], p[1], p[2]])
            .expect("set");
        let mut o = [0.0; 2];
        inst.get_real(&outs, &mut o).expect("get");
        y.push(o);
        inst.do_step(i as f64 * DT, DT, true).expect("step");
    }
    inst.terminate().expect("terminate");
    y
}

fn run_fmi3(fmu: &Path, lo: &[f64; 3], hi: &[f64; 3]) -> Vec<[f64; 2]> {
    let import: fmi::fmi3::import::Fmi3Import = fmi::import::from_path(fmu).expect("import");
    let md = import.model_description();
    assert_eq!(md.fmi_version, "3.0");
    let xml = std::fs::read_to_string(import.archive_path().join("modelDescription.xml"))
        .expect("modelDescription.xml");
    let ours = model_description::fmi3::ModelDescription::from_xml(&xml).expect("parse");
    let vr = |name: &str| {
        ours.value_reference(name)
            .unwrap_or_else(|| panic!("no variable {name}"))
    };
    let ins = ["Fx", "Fy", "x", "y", "z"].map(vr);
    let outs = ["dx", "dy", "time"].map(vr);
    let mut inst = import
        .instantiate_cs("fmi3", false, false, false, false, &[])
        .expect("inst");
    inst.enter_initialization_mode(None, 0.0, None)
        .expect("enter");
    inst.exit_initialization_mode().expect("exit");
    let mut y = Vec::with_capacity(STEPS);
    for i in 0..STEPS {
        let (f, p) = inputs(i, lo, hi);
        inst.set_float64(&ins, &[f[0], f[1], p[0], p[1], p[2]])
            .expect("set");
        let mut o = [0.0; 3];
        inst.get_float64(&outs, &mut o).expect("get");
        assert!((o[2] - i as f64 * DT).abs() < 1e-12, "time {} at {i}", o[2]);
        y.push([o[0], o[1]]);
        let (mut event, mut term, mut early, mut last) = (true, true, true, f64::NAN);
        inst.do_step(
            i as f64 * DT,
            DT,
            true,
            &mut event,
            &mut term,
            &mut early,
            &mut last,
        )
        .expect("step");
        assert!(!event && !term && !early);
        assert!(
            (last - (i + 1) as f64 * DT).abs() < 1e-12,
            "lastSuccessfulTime {last}"
        );
    }
    inst.terminate().expect("terminate");
    y
}

fn max_dev(a: &[[f64; 2]], b: &[[f64; 2]]) -> [f64; 2] {
    assert_eq!(a.len(), b.len());
    [0, 1].map(|k| {
        let scale = b.iter().map(|r| r[k].abs()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        a.iter()
            .zip(b)
            .map(|(x, y)| (x[k] - y[k]).abs())
            .fold(0.0, f64::max)
            / scale
    })
}

#[test]
fn fmi2_and_fmi3_fmus_in_rust_fmi_agree_with_the_library_simulation() {
    let twin = ModalMachine::default_machine().exact_twin([2, 2, 1], &[Axis::X, Axis::Y]);
    let ev = TwinEvaluator::new(&twin).expect("evaluator");
    let (lo, hi) = ev.bounds();
    let d = tempfile::tempdir().expect("tmp");
    let so = std::fs::read(lib_path()).expect("slave library");
    let f2 = d.path().join("twin2.fmu");
    let f3 = d.path().join("twin3.fmu");
    export_fmu_as(&twin, &f2, Some(&so), FmiVersion::V2).expect("export 2");
    export_fmu_as(&twin, &f3, Some(&so), FmiVersion::V3).expect("export 3");
    let want = reference(&twin, &lo, &hi);
    let y2 = run_fmi2(&f2, &lo, &hi);
    let y3 = run_fmi3(&f3, &lo, &hi);
    let (e2, e3, e23) = (max_dev(&y2, &want), max_dev(&y3, &want), max_dev(&y2, &y3));
    let f = |e: [f64; 2]| format!("{:.2e}, {:.2e}", e[0], e[1]);
    eprintln!(
        "rust-fmi, {STEPS} steps: max |FMU - simulate_twin| / peak (dx, dy): FMI 2 {}; FMI 3 \
         {}; FMI 2 vs FMI 3 {}",
        f(e2),
        f(e3),
        f(e23)
    );
    for e in [e2, e3, e23].iter().flatten() {
        assert!(*e <= 1e-9, "deviation {e}");
    }
}
