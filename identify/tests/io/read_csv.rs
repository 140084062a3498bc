//! Time-series and FRF CSV reading: every bad input names line and column; round trips;
//! generated valid files parse to the same numbers; the real data files read.

#![allow(clippy::needless_range_loop)] // naive reference code reads best with indices

use identify::axis::{Axis, Channel};
use identify::frf::{Frf, FrfChannel};
use identify::read::{
    parse_frf_csv, parse_timeseries, parse_timeseries_with_warnings, read_complex_lines,
    read_frf_csv, read_timeseries, write_frf_csv, write_timeseries,
};
use identify::timeseries::{ResponseKind, TimeSeries};
use identify::Error;
use num_complex::Complex64;
use proptest::prelude::*;
use std::path::Path;

use crate::common::shared;

const SRC: &str = "test.csv";

/// Header + `n` valid rows of t,fx,ax (row i is on line i + 2).
fn rows(n: usize) -> Vec<String> {
    let mut v = vec!["t,fx,ax".to_string()];
    for i in 0..n {
        v.push(format!(
            "{},{},{}",
            i as f64 * 0.001,
            (i as f64).sin(),
            (i as f64 * 0.3).cos()
        ));
    }
    v
}

fn join(v: &[String]) -> String {
    v.join("\n") + "\n"
}

/// Asserts a BadFile at `line` naming `column`; returns the message.
fn bad(text: &str, line: usize, column: Option<&str>) -> String {
    match parse_timeseries(text, Path::new(SRC)) {
        Err(Error::BadFile {
            file,
            line: l,
            column: c,
            msg,
        }) => {
            assert_eq!(file, Path::new(SRC));
            assert_eq!(l, line, "line, message: {msg}");
            assert_eq!(c.as_deref(), column, "column, message: {msg}");
            assert!(msg.len() > 20, "message too terse: {msg}");
            msg
        }
        other => panic!("expected BadFile at line {line}, got {other:?}"),
    }
}

#[test]
fn valid_file_with_comments_whitespace_and_crlf() {
    let text = "# sensor=PCB 086C03\r\n#rate=1kHz\r\n t , fx ,ax , x\r\n".to_string()
        + &(0..20)
            .map(|i| format!(" {} ,  {} , {} ,0.5\r\n", i as f64 * 1e-3, i, -(i as f64)))
            .collect::<String>();
    let ts = parse_timeseries(&text, Path::new(SRC)).unwrap();
    assert_eq!(ts.len(), 20);
    assert_eq!(ts.comments, vec!["sensor=PCB 086C03", "rate=1kHz"]);
    assert!((ts.dt - 1e-3).abs() < 1e-15);
    assert_eq!(ts.t0, 0.0);
    assert_eq!(ts.response_kind, Some(ResponseKind::Acceleration));
    assert_eq!(ts.force(Axis::X).unwrap()[7], 7.0);
    assert_eq!(ts.response(Axis::X).unwrap()[7], -7.0);
    assert_eq!(ts.mean_position(), [0.5, 0.0, 0.0]);
    assert!(ts.force(Axis::Y).is_none());
}

#[test]
fn unknown_columns_are_ignored_with_a_warning() {
    let mut v = rows(20);
    v[0] = "t,fx,ax,temperature".into();
    for r in v.iter_mut().skip(1) {
        r.push_str(",warm");
    }
    let (ts, w) = parse_timeseries_with_warnings(&join(&v), Path::new(SRC)).unwrap();
    assert_eq!(ts.len(), 20);
    assert_eq!(w.len(), 1);
    assert!(w[0].contains("temperature"), "{}", w[0]);
}

#[test]
fn displacement_file() {
    let mut v = rows(20);
    v[0] = "t,fy,dy,dz".into();
    for r in v.iter_mut().skip(1) {
        r.push_str(",1e-6");
    }
    let ts = parse_timeseries(&join(&v), Path::new(SRC)).unwrap();
    assert_eq!(ts.response_kind, Some(ResponseKind::Displacement));
    assert_eq!(ts.response_axes(), vec![Axis::Y, Axis::Z]);
    assert_eq!(ts.force_axes(), vec![Axis::Y]);
}

#[test]
fn bad_values_name_line_and_column() {
    for (cell, col_idx, col) in [
        ("NaN", 1, "fx"),
        ("inf", 2, "ax"),
        ("-Infinity", 1, "fx"),
        ("", 2, "ax"),
        ("  ", 1, "fx"),
        ("abc", 2, "ax"),
        ("1.2.3", 0, "t"),
        ("1,5", 1, "fx"),
    ] {
        let mut v = rows(30);
        let mut cells: Vec<String> = v[6].split(',').map(str::to_owned).collect();
        cells[col_idx] = cell.into();
        v[6] = cells.join(",");
        if cell == "1,5" {
            // a decimal comma makes the row ragged
            bad(&join(&v), 7, None);
        } else {
            bad(&join(&v), 7, Some(col));
        }
    }
}

#[test]
fn ragged_rows() {
    let mut v = rows(30);
    v[10] = "0.009,1".into();
    let m = bad(&join(&v), 11, None);
    assert!(m.contains("2 cells"), "{m}");
    let mut v = rows(30);
    v[12] += ",7";
    bad(&join(&v), 13, None);
}

#[test]
fn time_problems_name_the_first_bad_line() {
    // a missing row: the step into the next row is twice the others
    let mut v = rows(40);
    v.remove(10);
    let m = bad(&join(&v), 11, Some("t"));
    assert!(m.contains("1 %"), "{m}");
    // repeated row
    let mut v = rows(40);
    let dup = v[10].clone();
    v.insert(11, dup);
    let m = bad(&join(&v), 12, Some("t"));
    assert!(m.contains("does not increase"), "{m}");
    // decreasing
    let mut v = rows(40);
    v.swap(20, 21);
    bad(&join(&v), 22, Some("t"));
    // jitter of 2 % on one step
    let mut v = rows(40);
    v[30] = format!("{},0,0", 29.0 * 0.001 + 0.02 * 0.001);
    bad(&join(&v), 31, Some("t"));
    // jitter of 0.5 % is fine
    let mut v = rows(40);
    v[30] = format!("{},0,0", 29.0 * 0.001 + 0.005 * 0.001);
    assert!(parse_timeseries(&join(&v), Path::new(SRC)).is_ok());
}

#[test]
fn header_problems() {
    let mut v = rows(20);
    v[0] = "time,fx,ax".into();
    assert!(bad(&join(&v), 1, None).contains("'t'"));
    let mut v = rows(20);
    v[0] = "t,ax,ay".into();
    assert!(bad(&join(&v), 1, None).contains("force"));
    let mut v = rows(20);
    v[0] = "t,fx,fx".into();
    bad(&join(&v), 1, Some("fx"));
    let mut v = rows(20);
    v[0] = "t,fx,ax".into();
    for r in v.iter_mut().skip(1) {
        r.push_str(",0");
    }
    v[0] = "t,fx,ax,dx".into();
    bad(&join(&v), 1, Some("dx"));
    // comment lines before the header shift the line numbers
    let mut v = rows(20);
    v.insert(0, "# meta".into());
    v[1] = "t,ay".into();
    bad(&join(&v), 2, None);
}

#[test]
fn too_short_empty_and_header_only() {
    let m = bad(&join(&rows(15)), 0, None);
    assert!(m.contains("16"), "{m}");
    assert!(parse_timeseries(&join(&rows(16)), Path::new(SRC)).is_ok());
    bad("", 0, None);
    bad("# only a comment\n\n", 0, None);
    bad("t,fx,ax\n", 1, None);
    bad("# c\nt,fx,ax\n\n", 2, None);
}

fn tmpdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

#[test]
fn timeseries_round_trip() {
    let n = 50;
    let mut ts = TimeSeries {
        source: String::new(),
        t0: 0.125,
        dt: 1.0 / 3000.0,
        response_kind: Some(ResponseKind::Displacement),
        comments: vec!["pose A".into(), " indented".into()],
        ..TimeSeries::default()
    };
    ts.force[0] = Some((0..n).map(|i| (i as f64 * 0.7).sin() * 1e3).collect());
    ts.force[2] = Some((0..n).map(|i| 1.0 / (i as f64 + 3.0)).collect());
    ts.response[1] = Some(
        (0..n)
            .map(|i| (i as f64).cos() * 1.234_567_890_123e-7)
            .collect(),
    );
    ts.position[0] = Some(vec![0.3; n]);
    let d = tmpdir();
    let p = d.path().join("rt.csv");
    write_timeseries(&p, &ts).unwrap();
    let back = read_timeseries(&p).unwrap();
    assert_eq!(back.force, ts.force);
    assert_eq!(back.response, ts.response);
    assert_eq!(back.position, ts.position);
    assert_eq!(back.comments, ts.comments);
    assert_eq!(back.response_kind, ts.response_kind);
    assert_eq!(back.t0, ts.t0);
    assert!((back.dt - ts.dt).abs() < 1e-12 * ts.dt);
    assert_eq!(back.source, p.display().to_string());
    let mut bad = ts.clone();
    bad.force[0].as_mut().unwrap()[5] = f64::INFINITY;
    assert!(write_timeseries(&p, &bad).is_err());
    let mut bad = ts.clone();
    bad.position[0].as_mut().unwrap().pop();
    assert!(write_timeseries(&p, &bad).is_err());
}

fn sample_frf() -> Frf {
    let f: Vec<f64> = (1..=40).map(|k| k as f64 * 2.5).collect();
    let h = |s: f64| -> Vec<Complex64> {
        f.iter()
            .map(|&x| Complex64::new(1.0, 0.0) / Complex64::new(1e6 - x * x * s, 30.0 * x))
            .collect()
    };
    Frf {
        channels: vec![
            FrfChannel {
                channel: Channel::new(Axis::X, Axis::X),
                h: h(1.0),
                coherence: Some(f.iter().map(|x| 1.0 / (1.0 + x / 100.0)).collect()),
            },
            FrfChannel {
                channel: Channel::new(Axis::Y, Axis::X),
                h: h(2.0),
                coherence: None,
            },
        ],
        freqs_hz: f,
    }
}

#[test]
fn frf_round_trip() {
    let frf = sample_frf();
    let d = tmpdir();
    let p = d.path().join("frf.csv");
    write_frf_csv(&p, &frf).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(
        text.starts_with("f_hz,xx_re,xx_im,xx_coh,yx_re,yx_im\n"),
        "{text}"
    );
    assert_eq!(read_frf_csv(&p).unwrap(), frf);
    // what would not read back is refused, and the old file stays
    let mut bad = frf.clone();
    bad.channels[0].h[3].re = f64::NAN;
    assert!(write_frf_csv(&p, &bad).is_err());
    let mut bad = frf.clone();
    bad.channels[1].h.pop();
    assert!(write_frf_csv(&p, &bad).is_err());
    let mut bad = frf.clone();
    bad.freqs_hz[2] = bad.freqs_hz[1];
    assert!(write_frf_csv(&p, &bad).is_err());
    assert_eq!(read_frf_csv(&p).unwrap(), frf);
}

fn bad_frf(text: &str, line: usize, column: Option<&str>) {
    match parse_frf_csv(text, Path::new("frf.csv")) {
        Err(Error::BadFile {
            line: l,
            column: c,
            msg,
            ..
        }) => {
            assert_eq!(l, line, "{msg}");
            assert_eq!(c.as_deref(), column, "{msg}");
        }
        other => panic!("expected BadFile at line {line}, got {other:?}"),
    }
}

#[test]
fn frf_bad_inputs() {
    let h = "f_hz,xx_re,xx_im,xx_coh\n";
    bad_frf("", 0, None);
    bad_frf(h, 1, None);
    bad_frf(&format!("{h}1,0,0,1\n1,0,0,1\n"), 3, Some("f_hz"));
    bad_frf(&format!("{h}2,0,0,1\n1,0,0,1\n"), 3, Some("f_hz"));
    bad_frf(&format!("{h}1,0,0,1.2\n"), 2, Some("xx_coh"));
    bad_frf(&format!("{h}1,0,0,-0.1\n"), 2, Some("xx_coh"));
    bad_frf(&format!("{h}1,nan,0,1\n"), 2, Some("xx_re"));
    bad_frf(&format!("{h}1,0,,1\n"), 2, Some("xx_im"));
    bad_frf(&format!("{h}1,0,0\n"), 2, None);
    bad_frf("f_hz,xx_re,xx_coh\n1,0,1\n", 1, Some("xx_im"));
    bad_frf("f_hz,xx_re,xx_im,xx_mag\n1,0,0,1\n", 1, Some("xx_mag"));
    bad_frf("f_hz,xq_re,xq_im\n1,0,0\n", 1, Some("xq_re"));
    bad_frf("freq,xx_re,xx_im\n1,0,0\n", 1, Some("freq"));
    bad_frf("f_hz,xx_re,xx_im,xx_re\n1,0,0,0\n", 1, Some("xx_re"));
    bad_frf("f_hz,xx_re,xx_im\n-1,0,0\n", 2, Some("f_hz"));
    // whitespace and CRLF are fine
    let ok = parse_frf_csv(
        "f_hz, xx_re ,xx_im\r\n 1 , 2e-6 , -1e-6 \r\n2,0,0\r\n",
        Path::new("f.csv"),
    )
    .unwrap();
    assert_eq!(ok.channels[0].h[0], Complex64::new(2e-6, -1e-6));
}

#[test]
fn real_impact_csv_reads() {
    let ts = read_timeseries(&shared("data/pyfrf_impact_hammer/impact_5hits.csv")).unwrap();
    assert_eq!(ts.len(), 128_000);
    assert!((ts.fs() - 25_600.0).abs() < 1e-6);
    assert_eq!(ts.force_axes(), vec![Axis::X]);
    assert_eq!(ts.response_axes(), vec![Axis::X]);
    assert_eq!(ts.response_kind, Some(ResponseKind::Acceleration));
    assert_eq!(ts.comments.len(), 2);
    let fmax = ts
        .force(Axis::X)
        .unwrap()
        .iter()
        .cloned()
        .fold(0.0, f64::max);
    assert!(fmax > 60.0 && fmax < 100.0, "{fmax}");
}

#[test]
fn pyuff_complex_lines_read() {
    let v = read_complex_lines(
        &shared("data/pyuff_measured_frf/meas_point_1.txt"),
        0.0,
        1.0,
    )
    .unwrap();
    assert_eq!(v.len(), 1001);
    assert_eq!(v[1000].0, 1000.0);
    assert_eq!(
        v[0].1,
        Complex64::new(-0.0774752256830106, 2.6838208936737454e-08)
    );
    let frf = identify::read::accelerance_to_receptance(&v, Channel::new(Axis::X, Axis::X));
    assert_eq!(frf.freqs_hz.len(), 1000);
    assert_eq!(frf.freqs_hz[0], 1.0);
    // resonance near 142 Hz in the documented list: a local maximum of |A| within ±3 Hz
    let a: Vec<f64> = v.iter().map(|(_, z)| z.norm()).collect();
    let (i, _) = (130..155)
        .map(|i| (i, a[i]))
        .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    assert!((139..=145).contains(&i), "peak at {i} Hz");
}

fn fmt_num(v: f64, style: u8) -> String {
    match style {
        0 => format!("{v}"),
        1 => format!("{v:e}"),
        _ => format!("  {v:E} "),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Any valid generated CSV parses to exactly the written numbers.
    #[test]
    fn generated_csv_parses_to_same_numbers(
        n in 16usize..60,
        dt in 1e-6f64..1e-1,
        t0 in -10.0f64..10.0,
        cols in proptest::sample::subsequence(vec!["fx", "fy", "fz", "dx", "dy", "x", "z"], 1..7),
        vals in proptest::collection::vec(-1e9f64..1e9, 60 * 7),
        scale in proptest::sample::select(vec![1.0, 1e-9, 1e-300, 1e12]),
        style in 0u8..3,
        crlf in any::<bool>(),
    ) {
        let mut cols = cols;
        if !cols.iter().any(|c| c.starts_with('f')) {
            cols.insert(0, "fy");
        }
        let eol = if crlf { "\r\n" } else { "\n" };
        let mut text = format!("# generated{eol}t,{}{eol}", cols.join(","));
        let mut expect = vec![Vec::new(); cols.len()];
        for i in 0..n {
            text += &fmt_num(t0 + i as f64 * dt, style);
            for (j, e) in expect.iter_mut().enumerate() {
                let v = vals[i * 7 + j] * scale;
                text += ",";
                text += &fmt_num(v, style);
                e.push(v);
            }
            text += eol;
        }
        let ts = parse_timeseries(&text, Path::new("gen.csv")).unwrap();
        prop_assert_eq!(ts.len(), n);
        prop_assert!(((ts.dt - dt) / dt).abs() < 1e-6);
        for (name, e) in cols.iter().zip(&expect) {
            let a = Axis::from_letter(name.chars().last().unwrap()).unwrap();
            let got = match name.chars().next().unwrap() {
                'f' => ts.force(a).unwrap().to_vec(),
                'd' => ts.response(a).unwrap().to_vec(),
                _ => ts.position[a.index()].clone().unwrap(),
            };
            prop_assert_eq!(&got, e);
        }
    }
}
