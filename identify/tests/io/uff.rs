//! Universal File Format dataset 58/58b: the real pyuff example file against its text
//! companions, files written by pyuff (fixtures made by `scripts/make_uff_fixture.py`),
//! write → read round trips, Frf conversion, and bad files (clear errors, never a panic).

use identify::axis::{Axis, Channel};
use identify::frf::{Frf, FrfChannel};
use identify::read::{accelerance_to_receptance, read_complex_lines};
use identify::uff::{
    format_uff58, format_uff58b, frf_from_uff, parse_uff58, read_uff, uff_from_frf, write_uff58,
    write_uff58b, UffAxis, UffFunction, UffSelect, DATA_ACCELERATION, DATA_DISPLACEMENT,
    DATA_FORCE, DATA_FREQUENCY, FUNC_COHERENCE, FUNC_FRF,
};
use identify::Error;
use num_complex::Complex64;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

use crate::common::shared;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data")).join(rel)
}

/// Largest |a - b| / |b| over pairs (|b| > 0), for complex values.
fn max_rel(a: &[Complex64], b: &[Complex64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let d = (x - y).norm();
            if y.norm() > 0.0 {
                d / y.norm()
            } else {
                d
            }
        })
        .fold(0.0, f64::max)
}

// ---------------------------------------------------------------------------------------
// The real file: ladisk/pyuff meas_point_{1,2,3} as dataset 58
// ---------------------------------------------------------------------------------------

const REAL: &str = "data/pyuff_measured_frf/meas_points_frf_uff58.uff";

#[test]
fn real_file_matches_its_text_companions() {
    let funcs = read_uff(&shared(REAL)).unwrap();
    assert_eq!(funcs.len(), 3);
    let mut worst = 0.0f64;
    for (k, f) in funcs.iter().enumerate() {
        assert_eq!(f.func_type, FUNC_FRF);
        assert_eq!(f.ord_data_type, 6);
        assert!(f.is_complex);
        assert_eq!((f.response_node, f.response_dir), (1, 1));
        assert_eq!((f.reference_node, f.reference_dir), (k as i64 + 1, 1));
        assert_eq!(f.response_entity, "beam");
        assert_eq!(f.ordinate_axis.data_type, DATA_ACCELERATION);
        assert_eq!(f.denominator_axis.data_type, DATA_FORCE);
        assert_eq!(f.abscissa_axis.data_type, DATA_FREQUENCY);
        assert_eq!(f.abscissa_axis.units, "Hz");
        assert_eq!(
            f.id[0],
            format!("ladisk/pyuff data/meas_point_{}.txt", k + 1)
        );
        assert_eq!(f.abscissa.len(), 1001);
        for (i, x) in f.abscissa.iter().enumerate() {
            assert_eq!(*x, i as f64, "1 Hz grid from 0 Hz");
        }
        let txt = read_complex_lines(
            &shared(&format!("data/pyuff_measured_frf/meas_point_{}.txt", k + 1)),
            0.0,
            1.0,
        )
        .unwrap();
        let want: Vec<Complex64> = txt.iter().map(|p| p.1).collect();
        let rel = max_rel(&f.data, &want);
        // the UFF holds 12 significant digits (pyuff %20.11e)
        assert!(rel < 1e-10, "function {k}: max rel diff {rel:e}");
        worst = worst.max(rel);
    }
    eprintln!("real file vs meas_point_*.txt: max relative difference {worst:.2e}");
}

#[test]
fn real_file_to_receptance() {
    let funcs = read_uff(&shared(REAL)).unwrap();
    // three FRFs give the same channel xx: selecting nothing is ambiguous
    let err = frf_from_uff(&funcs, &UffSelect::default()).unwrap_err();
    assert!(err.to_string().contains("both give channel xx"), "{err}");
    for node in 1..=3 {
        let frf = frf_from_uff(
            &funcs,
            &UffSelect {
                reference_node: Some(node),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(frf.freqs_hz.len(), 1000, "0 Hz dropped (accelerance)");
        assert_eq!(frf.freqs_hz[0], 1.0);
        assert_eq!(frf.channels.len(), 1);
        assert_eq!(frf.channels[0].channel, Channel::new(Axis::X, Axis::X));
        let txt = read_complex_lines(
            &shared(&format!("data/pyuff_measured_frf/meas_point_{node}.txt")),
            0.0,
            1.0,
        )
        .unwrap();
        let want = accelerance_to_receptance(&txt, Channel::new(Axis::X, Axis::X));
        assert_eq!(frf.freqs_hz, want.freqs_hz);
        let rel = max_rel(&frf.channels[0].h, &want.channels[0].h);
        assert!(rel < 1e-10, "node {node}: {rel:e}");
    }
}

#[test]
fn real_file_with_crlf_and_blank_lines_between_blocks() {
    let text = std::fs::read_to_string(shared(REAL)).unwrap();
    let crlf = text
        .replace('\n', "\r\n")
        .replace("    -1\r\n    -1", "    -1\r\n\r\n    -1");
    let crlf = format!("\u{feff}{crlf}"); // and a byte-order mark
    let a = parse_uff58(text.as_bytes(), Path::new("a.uff")).unwrap();
    let b = parse_uff58(crlf.as_bytes(), Path::new("b.uff")).unwrap();
    assert_eq!(a.len(), 3);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.data, y.data);
        assert_eq!(x.abscissa, y.abscissa);
        assert_eq!(x.id, y.id);
    }
}

// ---------------------------------------------------------------------------------------
// Files written by pyuff 2.5.8
// ---------------------------------------------------------------------------------------

#[derive(serde::Deserialize)]
struct Want {
    id1: String,
    func_type: i32,
    response_node: i64,
    response_dir: i32,
    reference_node: i64,
    reference_dir: i32,
    ordinate: i32,
    ord_data_type: i32,
    even: bool,
    x: Vec<f64>,
    re: Vec<f64>,
    im: Vec<f64>,
}

#[derive(serde::Deserialize)]
struct Fixture {
    functions: Vec<Want>,
}

fn fixture() -> Vec<Want> {
    let s = std::fs::read_to_string(data("uff_pyuff_values.json")).unwrap();
    serde_json::from_str::<Fixture>(&s).unwrap().functions
}

/// Compares read functions with the fixture values; returns the max relative
/// difference of the double-precision functions.
fn compare_with_fixture(funcs: &[UffFunction], want: &[Want]) -> f64 {
    assert_eq!(funcs.len(), want.len());
    let mut worst = 0.0f64;
    for (f, w) in funcs.iter().zip(want) {
        assert_eq!(f.id[0], w.id1);
        assert_eq!(f.func_type, w.func_type);
        assert_eq!(
            (f.response_node, f.response_dir),
            (w.response_node, w.response_dir)
        );
        assert_eq!(
            (f.reference_node, f.reference_dir),
            (w.reference_node, w.reference_dir)
        );
        assert_eq!(f.ordinate_axis.data_type, w.ordinate);
        assert_eq!(f.ord_data_type, w.ord_data_type);
        assert_eq!(f.response_entity, "tcp");
        assert_eq!(f.abscissa.len(), w.x.len(), "{}", w.id1);
        for (a, b) in f.abscissa.iter().zip(&w.x) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{}: x {a} vs {b}", w.id1);
        }
        let wz: Vec<Complex64> =
            w.re.iter()
                .zip(&w.im)
                .map(|(r, i)| Complex64::new(*r, *i))
                .collect();
        let rel = max_rel(&f.data, &wz);
        if w.ord_data_type == 5 {
            // single precision, 6 significant digits (E13.5)
            assert!(rel < 1e-5, "{}: {rel:e}", w.id1);
        } else {
            assert!(rel < 1e-10, "{}: {rel:e}", w.id1);
            worst = worst.max(rel);
        }
        let _ = w.even;
    }
    worst
}

#[test]
fn pyuff_ascii_fixture() {
    let funcs = read_uff(&data("uff_pyuff_ascii.uff")).unwrap();
    let want = fixture();
    let rel = compare_with_fixture(&funcs, &want);
    eprintln!("pyuff ASCII fixture: max relative difference {rel:.2e}");
    assert!(!funcs[2].is_complex && funcs[2].func_type == FUNC_COHERENCE);
    assert!(!funcs[3].abscissa.windows(2).any(|w| w[1] <= w[0]));
}

#[test]
fn pyuff_binary_fixture_is_exact() {
    let funcs = read_uff(&data("uff_pyuff_binary.uff")).unwrap();
    let want = fixture();
    let rel = compare_with_fixture(&funcs, &want[..4]);
    // binary doubles are exact; serde_json's default float parser may be 1 ulp off
    assert!(rel < 1e-15, "{rel:e}");
}

/// The analytic receptance of `scripts/make_uff_fixture.py`.
fn analytic(f: f64, out: Axis, inp: Axis) -> Complex64 {
    let modes = [(120.0, 0.03, 2.0), (310.0, 0.02, 5.0)];
    let phi = |a: Axis| match a {
        Axis::X => [1.0, 0.6],
        Axis::Y => [0.5, -0.8],
        Axis::Z => [0.0, 0.0],
    };
    let w = 2.0 * std::f64::consts::PI * f;
    let mut h = Complex64::new(0.0, 0.0);
    for (k, (fn_, z, m)) in modes.iter().enumerate() {
        let wn = 2.0 * std::f64::consts::PI * fn_;
        h += phi(out)[k] * phi(inp)[k] / m / Complex64::new(wn * wn - w * w, 2.0 * z * wn * w);
    }
    h
}

#[test]
fn pyuff_fixture_to_frf_matches_the_analytic_receptance() {
    let funcs = read_uff(&data("uff_pyuff_ascii.uff")).unwrap();
    let node7 = frf_from_uff(
        &funcs,
        &UffSelect {
            response_node: Some(7),
            reference_node: Some(7),
            ..Default::default()
        },
    )
    .unwrap();
    // yx is accelerance: 0 Hz dropped for all channels
    assert_eq!(node7.freqs_hz.len(), 400);
    assert_eq!(node7.freqs_hz[0], 2.5);
    let names: Vec<String> = node7.channels.iter().map(|c| c.channel.name()).collect();
    assert_eq!(names, ["xx", "yx"]);
    let mut worst = 0.0f64;
    for c in &node7.channels {
        let want: Vec<Complex64> = node7
            .freqs_hz
            .iter()
            .map(|&f| analytic(f, c.channel.output, c.channel.input))
            .collect();
        let rel = max_rel(&c.h, &want);
        assert!(rel < 1e-10, "{}: {rel:e}", c.channel);
        worst = worst.max(rel);
    }
    let coh = node7.channels[0].coherence.as_ref().expect("coherence xx");
    assert_eq!(coh.len(), 400);
    assert!((coh[0] - (1.0 - 0.5 * (-((2.5f64 - 310.0) / 40.0).powi(2)).exp())).abs() < 1e-11);
    assert!(node7.channels[1].coherence.is_none());

    // node 8: uneven grid, reference direction -Y flips the sign
    let node8 = frf_from_uff(
        &funcs,
        &UffSelect {
            reference_node: Some(8),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(node8.channels[0].channel, Channel::new(Axis::X, Axis::Y));
    assert_eq!(node8.freqs_hz.len(), 120);
    let want: Vec<Complex64> = node8
        .freqs_hz
        .iter()
        .map(|&f| analytic(f, Axis::X, Axis::Y))
        .collect();
    let rel = max_rel(&node8.channels[0].h, &want);
    assert!(rel < 1e-10, "xy: {rel:e}");
    eprintln!("pyuff fixture → Frf vs analytic receptance: xx/yx {worst:.2e}, xy {rel:.2e}");

    // node 9: single precision zz, 0 Hz kept (receptance)
    let node9 = frf_from_uff(
        &funcs,
        &UffSelect {
            reference_node: Some(9),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(node9.freqs_hz.len(), 401);
    assert_eq!(node9.channels[0].channel, Channel::new(Axis::Z, Axis::Z));
}

// ---------------------------------------------------------------------------------------
// Round trips through our writer
// ---------------------------------------------------------------------------------------

fn sample_functions() -> Vec<UffFunction> {
    let even: Vec<f64> = (0..37).map(|i| 10.0 + 0.25 * i as f64).collect();
    let uneven: Vec<f64> = (0..23).map(|i| 3.0 * 1.17f64.powi(i)).collect();
    let z = |i: usize| {
        Complex64::new(
            (i as f64 * 0.7).sin() * 1e-6,
            -(i as f64 * 0.3).cos() * 3.3e-7,
        )
    };
    vec![
        UffFunction {
            id: [
                "complex even".into(),
                "second id line".into(),
                "22-Nov-25 10:00:00".into(),
                "id 4".into(),
                "id 5".into(),
            ],
            func_type: FUNC_FRF,
            func_id: 3,
            response_entity: "spindle".into(),
            response_node: 123456,
            response_dir: -3,
            reference_node: 9,
            reference_dir: 2,
            ordinate_axis: UffAxis::new(DATA_DISPLACEMENT, "displacement", "m"),
            denominator_axis: UffAxis::new(DATA_FORCE, "force", "N"),
            abscissa_axis: UffAxis::new(DATA_FREQUENCY, "frequency", "Hz"),
            abscissa: even.clone(),
            data: (0..even.len()).map(z).collect(),
            ..Default::default()
        },
        UffFunction {
            id: [
                "complex uneven".into(),
                "a".into(),
                "b".into(),
                "c".into(),
                "d".into(),
            ],
            func_type: FUNC_FRF,
            response_node: 1,
            response_dir: 1,
            reference_node: 1,
            reference_dir: 1,
            abscissa: uneven.clone(),
            data: (0..uneven.len()).map(|i| -z(i) * 1e3).collect(),
            ..Default::default()
        },
        UffFunction {
            id: [
                "real uneven".into(),
                "a".into(),
                "b".into(),
                "c".into(),
                "d".into(),
            ],
            func_type: FUNC_COHERENCE,
            ord_data_type: 4,
            is_complex: false,
            abscissa: uneven.clone(),
            data: (0..uneven.len())
                .map(|i| Complex64::new(1.0 / (1.0 + i as f64), 0.0))
                .collect(),
            ..Default::default()
        },
        UffFunction {
            id: [
                "real even".into(),
                "a".into(),
                "b".into(),
                "c".into(),
                "d".into(),
            ],
            func_type: FUNC_COHERENCE,
            ord_data_type: 4,
            is_complex: false,
            abscissa: even.clone(),
            data: (0..even.len())
                .map(|i| Complex64::new(-(i as f64) * 123.456, 0.0))
                .collect(),
            ..Default::default()
        },
    ]
}

fn assert_round_trip(a: &[UffFunction], b: &[UffFunction], rel_data: f64, rel_x: f64) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.id, y.id);
        assert_eq!(
            (x.func_type, x.func_id, x.response_node, x.response_dir),
            (y.func_type, y.func_id, y.response_node, y.response_dir)
        );
        assert_eq!(
            (x.reference_node, x.reference_dir, x.is_complex),
            (y.reference_node, y.reference_dir, y.is_complex)
        );
        assert_eq!(x.response_entity, y.response_entity);
        assert_eq!(x.ordinate_axis, y.ordinate_axis);
        assert_eq!(x.denominator_axis, y.denominator_axis);
        assert_eq!(x.abscissa_axis, y.abscissa_axis);
        assert_eq!(x.data.len(), y.data.len());
        for (p, q) in x.abscissa.iter().zip(&y.abscissa) {
            assert!((p - q).abs() <= rel_x * p.abs().max(1e-300), "x {p} vs {q}");
        }
        for (p, q) in x.data.iter().zip(&y.data) {
            assert!((p - q).norm() <= rel_data * p.norm(), "{p} vs {q}");
        }
    }
}

#[test]
fn ascii_and_binary_round_trip() {
    let funcs = sample_functions();
    let dir = tempfile::tempdir().unwrap();
    let pa = dir.path().join("a.uff");
    let pb = dir.path().join("b.uff");
    write_uff58(&pa, &funcs).unwrap();
    write_uff58b(&pb, &funcs).unwrap();
    let a = read_uff(&pa).unwrap();
    let b = read_uff(&pb).unwrap();
    // 13-14 significant digits in ASCII (half a unit in the 13th: 5e-13); abscissa 7
    // digits when uneven
    assert_round_trip(&funcs, &a, 6e-13, 5e-7);
    assert_round_trip(&funcs, &b, 0.0, 0.0);
    // even grids come back exactly when min and increment are short decimals
    assert_eq!(a[0].abscissa, funcs[0].abscissa);
    let text = std::fs::read_to_string(&pa).unwrap();
    assert!(text.starts_with("    -1\n    58\n"));
    assert!(text.lines().all(|l| l.len() <= 80), "80-column records");
}

#[test]
fn frf_round_trip_with_coherence() {
    let freqs: Vec<f64> = (0..200).map(|i| i as f64 * 5.0).collect();
    let ch = |o, i, s: f64| FrfChannel {
        channel: Channel::new(o, i),
        h: freqs
            .iter()
            .map(|&f| analytic(f, Axis::X, Axis::Y) * s)
            .collect(),
        coherence: (s > 0.0).then(|| freqs.iter().map(|f| 1.0 - f / 2000.0).collect()),
    };
    let frf = Frf {
        freqs_hz: freqs.clone(),
        channels: vec![
            ch(Axis::X, Axis::X, 1.0),
            ch(Axis::Y, Axis::X, -2.0),
            ch(Axis::Z, Axis::Y, 3.0),
        ],
    };
    let funcs = uff_from_frf(&frf, 42);
    assert_eq!(funcs.len(), 5, "3 FRFs + 2 coherences");
    for (bytes, exact) in [
        (format_uff58(&funcs).unwrap().into_bytes(), false),
        (format_uff58b(&funcs).unwrap(), true),
    ] {
        let back = parse_uff58(&bytes, Path::new("frf.uff")).unwrap();
        let got = frf_from_uff(&back, &UffSelect::default()).unwrap();
        assert_eq!(got.freqs_hz, frf.freqs_hz);
        assert_eq!(got.channels.len(), 3);
        for (g, w) in got.channels.iter().zip(&frf.channels) {
            assert_eq!(g.channel, w.channel);
            let rel = max_rel(&g.h, &w.h);
            assert!(if exact { rel == 0.0 } else { rel < 6e-13 }, "{rel:e}");
            match (&g.coherence, &w.coherence) {
                (Some(a), Some(b)) => {
                    for (p, q) in a.iter().zip(b) {
                        assert!((p - q).abs() < 1e-13);
                    }
                }
                (None, None) => {}
                _ => panic!("coherence of {} lost or invented", g.channel),
            }
        }
    }
}

/// Writes our files for `scripts/check_uff_with_pyuff.py` (pyuff reads what we write).
#[test]
fn writer_output_for_pyuff() {
    let dir = std::env::temp_dir().join("mtwin_uff_check");
    std::fs::create_dir_all(&dir).unwrap();
    let funcs = sample_functions();
    write_uff58(&dir.join("ascii.uff"), &funcs).unwrap();
    write_uff58b(&dir.join("binary.uff"), &funcs).unwrap();
    let vals: Vec<serde_json::Value> = funcs
        .iter()
        .map(|f| {
            serde_json::json!({
                "id1": f.id[0],
                "func_type": f.func_type,
                "rsp_node": f.response_node,
                "rsp_dir": f.response_dir,
                "ref_node": f.reference_node,
                "ref_dir": f.reference_dir,
                "x": f.abscissa,
                "re": f.data.iter().map(|z| z.re).collect::<Vec<_>>(),
                "im": f.data.iter().map(|z| z.im).collect::<Vec<_>>(),
            })
        })
        .collect();
    std::fs::write(
        dir.join("values.json"),
        serde_json::to_string(&vals).unwrap(),
    )
    .unwrap();
}

// ---------------------------------------------------------------------------------------
// Bad files
// ---------------------------------------------------------------------------------------

/// Asserts a BadFile at `line` whose message contains `needle`.
fn bad(text: &str, line: usize, needle: &str) -> String {
    match parse_uff58(text.as_bytes(), Path::new("bad.uff")) {
        Err(e @ Error::BadFile { .. }) => {
            let Error::BadFile {
                ref file,
                line: l,
                ref msg,
                ..
            } = e
            else {
                unreachable!()
            };
            assert_eq!(file, Path::new("bad.uff"));
            assert_eq!(l, line, "line; message: {e}");
            assert!(msg.contains(needle), "'{needle}' not in: {e}");
            assert!(e.to_string().starts_with("bad.uff:"), "{e}");
            e.to_string()
        }
        other => panic!("expected BadFile at line {line}, got {other:?}"),
    }
}

fn small_file() -> String {
    let f = &sample_functions()[0..1];
    format_uff58(f).unwrap()
}

#[test]
fn bad_files_name_line_and_fix() {
    let good = small_file();
    let lines: Vec<&str> = good.lines().collect();
    let n = lines.len(); // 13 header lines, 19 data lines, closing -1
    assert_eq!(n, 13 + 19 + 1);
    parse_uff58(good.as_bytes(), Path::new("ok.uff")).unwrap();

    // truncated data: the last data lines and the closing -1 are missing
    let t = lines[..n - 4].join("\n");
    let m = bad(&t, n - 4, "truncated");
    eprintln!("truncated: {m}");

    // truncated header
    bad(&lines[..9].join("\n"), 9, "truncated");

    // non-numeric data field on line 20
    let mut v: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    v[19] = v[19].replacen('E', "X", 1);
    let m = bad(&(v.join("\n") + "\n"), 20, "is not a number");
    eprintln!("non-numeric: {m}");

    // point count says 38 but the data hold 37 points
    let mut v: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    v[8] = v[8].replacen("        37", "        38", 1);
    let m = bad(&(v.join("\n") + "\n"), n, "declares 38 points");
    eprintln!("count: {m}");
    // ... and 36: too many values, found on the last data line
    v[8] = v[8].replacen("        38", "        36", 1);
    bad(&(v.join("\n") + "\n"), n - 1, "more than the 72 values");

    // bad ordinate data type
    let mut v: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    v[8] = v[8].replacen("         6", "         7", 1);
    bad(&(v.join("\n") + "\n"), 9, "ordinate data type 7");

    // non-numeric node
    let mut v: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    v[7] = v[7].replacen("123456", "12a456", 1);
    bad(&(v.join("\n") + "\n"), 8, "not an integer");

    // no dataset 58 at all
    bad("    -1\n   164\n  1 SI\n    -1\n", 0, "only datasets 164");
    bad("", 0, "no datasets at all");
    // text outside blocks
    bad("hello\n", 1, "outside any dataset");
    // another dataset without its closing -1
    bad("    -1\n    15\n  1 2 3\n", 1, "no closing");
    // NaN in the data
    let mut v: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    v[14] = format!("{:>20}{}", "NaN", &v[14][20..]);
    bad(&(v.join("\n") + "\n"), 15, "NaN");

    // binary: truncated data
    let b = format_uff58b(&sample_functions()[0..1]).unwrap();
    match parse_uff58(&b[..b.len() - 100], Path::new("b.uff")) {
        Err(Error::BadFile { line, msg, .. }) => {
            assert_eq!(line, 14);
            assert!(msg.contains("truncated"), "{msg}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn fixed_width_fields_without_blanks_and_fortran_exponents() {
    // 4E20.12 fields that touch (20-character numbers), Fortran D exponents
    let head = "    -1\n    58\nid1\nid2\nid3\nid4\nid5\n\
        \x20   4         0    0         0       NONE         1   1       NONE         1   1\n\
        \x20        6         2         1  1.00000E+00  2.00000E+00  0.00000E+00\n\
        \x20       18    0    0    0 NONE                 Hz\n\
        \x20       12    0    0    0 NONE                 NONE\n\
        \x20       13    0    0    0 NONE                 NONE\n\
        \x20        0    0    0    0 NONE                 NONE\n";
    let text = format!(
        "{head}-1.2345678901234E-02-2.3456789012345E+03{:>20}{:>20}\n    -1\n",
        "1.5D+00", "-0.25D-01"
    );
    let f = parse_uff58(text.as_bytes(), Path::new("t.uff")).unwrap();
    assert_eq!(f[0].abscissa, [1.0, 3.0]);
    assert_eq!(
        f[0].data,
        [
            Complex64::new(-1.2345678901234e-2, -2.3456789012345e3),
            Complex64::new(1.5, -0.025)
        ]
    );
    assert_eq!(f[0].id[4], "id5");
}

#[test]
fn writer_rejects_what_would_not_read_back() {
    let mut f = sample_functions();
    f[0].data[3] = Complex64::new(f64::NAN, 0.0);
    assert!(format_uff58(&f[..1]).is_err());
    let mut f = sample_functions();
    f[0].response_node = 12_345_678_901;
    assert!(format_uff58(&f[..1])
        .unwrap_err()
        .to_string()
        .contains("response node"));
    let mut f = sample_functions();
    f[2].data[0].im = 1.0;
    assert!(format_uff58b(&f[2..3]).is_err());
}

// ---------------------------------------------------------------------------------------
// Never a panic
// ---------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = parse_uff58(&bytes, Path::new("fuzz.uff"));
        // also behind a valid opening, so the header and data paths are reached
        let mut v = b"    -1\n    58\n".to_vec();
        v.extend_from_slice(&bytes);
        let _ = parse_uff58(&v, Path::new("fuzz.uff"));
        let mut v = b"    -1\n    58b     1     2          11         16\n".to_vec();
        v.extend_from_slice(&bytes);
        let _ = parse_uff58(&v, Path::new("fuzz.uff"));
    }

    #[test]
    fn mutated_valid_files_never_panic(
        cut in 0usize..5000,
        pos in 0usize..5000,
        byte in any::<u8>(),
        line in 0usize..40,
        junk in "[ -~]{0,30}",
        binary in any::<bool>(),
    ) {
        let funcs = sample_functions();
        let good = if binary {
            format_uff58b(&funcs).unwrap()
        } else {
            format_uff58(&funcs).unwrap().into_bytes()
        };
        // truncation: an error unless only trailing blank lines were cut
        let c = cut % (good.len() + 1);
        let r = parse_uff58(&good[..c], Path::new("fuzz.uff"));
        if c + 1 < good.len() && c > 0 {
            prop_assert!(r.is_err() || r.unwrap().len() < funcs.len());
        }
        // one byte replaced
        let mut m = good.clone();
        let p = pos % m.len();
        m[p] = byte;
        let _ = parse_uff58(&m, Path::new("fuzz.uff"));
        // one line replaced by junk
        if !binary {
            let text = String::from_utf8(good).unwrap();
            let mut lines: Vec<&str> = text.lines().collect();
            let k = line % lines.len();
            lines[k] = &junk;
            let _ = parse_uff58(lines.join("\n").as_bytes(), Path::new("fuzz.uff"));
        }
    }

    #[test]
    fn random_values_round_trip(
        vals in proptest::collection::vec((-1e30f64..1e30, -1e-30f64..1e-30), 1..50),
        f0 in 0.0f64..1000.0,
        df in 0.001f64..100.0,
    ) {
        let n = vals.len();
        let f = UffFunction {
            func_type: FUNC_FRF,
            abscissa: (0..n).map(|i| f0 + df * i as f64).collect(),
            data: vals.iter().map(|(a, b)| Complex64::new(*a, *b)).collect(),
            ..Default::default()
        };
        let text = format_uff58(std::slice::from_ref(&f)).unwrap();
        let back = parse_uff58(text.as_bytes(), Path::new("rt.uff")).unwrap();
        prop_assert_eq!(back.len(), 1);
        for (p, q) in f.data.iter().zip(&back[0].data) {
            prop_assert!((p.re - q.re).abs() <= 6e-13 * p.re.abs());
            prop_assert!((p.im - q.im).abs() <= 6e-13 * p.im.abs());
        }
        // the grid: min and increment have 7 significant digits
        let span = f0 + df * n as f64;
        for (p, q) in f.abscissa.iter().zip(&back[0].abscissa) {
            prop_assert!((p - q).abs() <= 1e-6 * span, "{} vs {}", p, q);
        }
        let b = format_uff58b(std::slice::from_ref(&f)).unwrap();
        let back = parse_uff58(&b, Path::new("rt.uff")).unwrap();
        prop_assert_eq!(&back[0].data, &f.data);
    }
}

/// Header layout of pyuff's `data/Sample_UFF58_ascii.uff` (commercial software export):
/// an entity name with a blank, a time response in real single precision (6E13.5).
#[test]
fn commercial_header_single_precision_time_response() {
    let text = "    -1\n    58\nMic 01.0Scalar\nNONE\n18-Apr-16 13:49:58\nNONE\nNONE\n\
        \x20   1         0    0         0 Mic 01             0   1 NONE               0   0\n\
        \x20        2         8         1  0.00000E+00  1.52588E-05  0.00000E+00\n\
        \x20       17    0    0    0 time                 s                   \n\
        \x20       21    0    0    0 Pressure             Pa                  \n\
        \x20        0    0    0    0 NONE                 NONE                \n\
        \x20        0    0    0    0 NONE                 NONE                \n\
        \x20-1.47553E-02 -1.72957E-02 -1.66101E-02 -1.61988E-02 -1.68925E-02 -1.53669E-02\n\
        \x20-1.44522E-02  3.44719E-04\n    -1\n";
    let f = parse_uff58(text.as_bytes(), Path::new("mic.uff")).unwrap();
    assert_eq!(f.len(), 1);
    let f = &f[0];
    assert_eq!(f.func_type, 1);
    assert_eq!(f.response_entity, "Mic 01");
    assert_eq!((f.response_node, f.response_dir), (0, 1));
    assert_eq!(f.reference_entity, "NONE");
    assert_eq!(f.ord_data_type, 2);
    assert!(!f.is_complex);
    assert_eq!(f.abscissa_axis.label, "time");
    assert_eq!(f.abscissa_axis.units, "s");
    assert_eq!(f.ordinate_axis.units, "Pa");
    assert_eq!(f.data.len(), 8);
    assert_eq!(f.data[7], Complex64::new(3.44719e-4, 0.0));
    assert!((f.abscissa[7] - 7.0 * 1.52588e-5).abs() < 1e-18);
    // and it is not an FRF
    assert!(frf_from_uff(std::slice::from_ref(f), &UffSelect::default()).is_err());
}
