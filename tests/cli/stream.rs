//! `mtwin frf` streams a single long continuous record (`--json` says
//! `"reading": "streamed"`), writes the same FRF as the in-memory path, reads impact
//! records and sweeps into memory, and on a bad row mid-file exits 2 naming the line with nothing
//! written.

use crate::common::*;

use std::path::{Path, PathBuf};

/// A continuous record: pseudo-random force, two responses (lightly filtered force).
fn continuous_csv(rows: usize) -> String {
    let mut s = String::with_capacity(rows * 64);
    s.push_str("# generated, continuous excitation\nt,fx,ax,ay\n");
    let (mut state, mut a1, mut a2) = (12345u64, 0.0f64, 0.0f64);
    for i in 0..rows {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let f = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        a1 = 0.9 * a1 + f;
        a2 = 0.5 * a2 - 0.3 * f;
        s.push_str(&format!("{},{f},{a1},{a2}\n", i as f64 / 25_600.0));
    }
    s
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `mtwin --json frf FILE --out OUT EXTRA...`; returns the JSON summary.
fn frf_json(file: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["--json", "frf", s(file), "--out", s(out)];
    args.extend_from_slice(extra);
    let o = mtwin(&args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).expect("json summary")
}

#[test]
fn stream_flag_streams_and_writes_the_same_frf() {
    let d = tmp();
    let data = write(d.path(), "noise.csv", &continuous_csv(40_000));
    let streamed = d.path().join("streamed.csv");
    let in_memory = d.path().join("in_memory.csv");
    for est in ["h1", "h2"] {
        let js = frf_json(&data, &streamed, &["--stream", "--estimator", est]);
        assert_eq!(js["reading"], "streamed", "{js}");
        let jm = frf_json(&data, &in_memory, &["--estimator", est]);
        assert_eq!(
            jm["reading"], "in_memory",
            "small file is read into memory: {jm}"
        );
        assert_eq!(js["method"], jm["method"]);
        assert_eq!(
            std::fs::read(&streamed).unwrap(),
            std::fs::read(&in_memory).unwrap(),
            "{est}: streamed FRF file differs"
        );
    }
}

#[test]
fn a_large_file_is_streamed_by_default_unless_in_memory_is_asked() {
    let d = tmp();
    let text = continuous_csv(140_000);
    assert!(text.len() as u64 > 8 << 20, "{} bytes", text.len());
    let data = write(d.path(), "long.csv", &text);
    let out = d.path().join("frf.csv");
    let js = frf_json(&data, &out, &[]);
    assert_eq!(js["reading"], "streamed", "{js}");
    let first = std::fs::read(&out).unwrap();
    let jm = frf_json(&data, &out, &["--in-memory"]);
    assert_eq!(jm["reading"], "in_memory", "{jm}");
    assert_eq!(first, std::fs::read(&out).unwrap());
    // the human summary says so too
    let o = mtwin(&["frf", s(&data), "--out", s(&out)]);
    assert!(
        stderr(&o).contains("streamed 140000 rows"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn impact_records_are_read_into_memory_even_with_stream() {
    let d = tmp();
    let mut text = String::from("t,fx,ax\n");
    for i in 0..20_000 {
        let t = i as f64 * 1e-4;
        let since = (i % 5000) as f64 * 1e-4;
        // half-sine hit of 5 samples every 0.5 s
        let k = (i % 5000) as f64;
        let f = if k < 5.0 {
            100.0 * (std::f64::consts::PI * k / 5.0).sin()
        } else {
            0.0
        };
        let a = (-40.0 * since).exp() * (2.0 * std::f64::consts::PI * 300.0 * since).sin();
        text.push_str(&format!("{t},{f},{a}\n"));
    }
    let data = write(d.path(), "impact.csv", &text);
    let js = frf_json(&data, &d.path().join("frf.csv"), &["--stream"]);
    assert_eq!(js["reading"], "in_memory", "{js}");
    assert!(js["hits_used"].as_u64().unwrap() >= 2, "{js}");
}

/// A logarithmic sweep asked to stream is still recognised as a sweep, as in memory (the
/// streamed scan judges it from the same windows), and estimated as one: the same FRF
/// file, coherence from the line-to-line scatter, which the file states.
#[test]
fn a_sweep_asked_to_stream_is_estimated_as_a_sweep() {
    let d = tmp();
    let (fs, rows) = (10_240.0, 60_000usize);
    let dur = rows as f64 / fs;
    let (f0, f1) = (20.0f64, 2000.0f64);
    let k = (f1 / f0).ln() / dur;
    let mut text = String::from("# generated, logarithmic sweep\nt,fx,ax\n");
    let (mut v, mut x) = (0.0f64, 0.0f64);
    let (wn, zeta, dt) = (2.0 * std::f64::consts::PI * 300.0, 0.02, 1.0 / fs);
    for i in 0..rows {
        let t = i as f64 * dt;
        let f = (2.0 * std::f64::consts::PI * f0 * ((k * t).exp() - 1.0) / k).sin();
        // one mode, semi-implicit Euler at the sample rate (what it is does not matter:
        // the test compares the two readings of the same file)
        let a = f - 2.0 * zeta * wn * v - wn * wn * x;
        v += a * dt;
        x += v * dt;
        text.push_str(&format!("{t},{f},{a}\n"));
    }
    let data = write(d.path(), "sweep.csv", &text);
    let streamed = d.path().join("streamed.csv");
    let in_memory = d.path().join("in_memory.csv");
    let js = frf_json(&data, &streamed, &["--stream"]);
    let jm = frf_json(&data, &in_memory, &[]);
    assert_eq!(
        js["reading"], "in_memory",
        "a sweep is not Welch-streamed: {js}"
    );
    assert!(
        js["method"].as_str().unwrap().contains("chirp"),
        "{}",
        js["method"]
    );
    assert_eq!(js["method"], jm["method"]);
    let written = std::fs::read_to_string(&streamed).unwrap();
    assert_eq!(written, std::fs::read_to_string(&in_memory).unwrap());
    assert!(written.contains("# coherence_dof="), "{written:.300}");
}

#[test]
fn bad_row_mid_file_exits_2_names_the_line_and_writes_nothing() {
    let d = tmp();
    let mut lines: Vec<String> = continuous_csv(150_000).lines().map(String::from).collect();
    let bad = 100_002; // 1-based line
    let cells: Vec<String> = lines[bad - 1].split(',').map(String::from).collect();
    lines[bad - 1] = format!("{},{},oops,{}", cells[0], cells[1], cells[3]);
    let data = write(d.path(), "bad long.csv", &(lines.join("\n") + "\n"));
    assert!(std::fs::metadata(&data).unwrap().len() > 8 << 20);
    let out = d.path().join("frf.csv");
    for extra in [&[][..], &["--stream"][..]] {
        let mut args = vec!["frf", s(&data), "--out", s(&out)];
        args.extend_from_slice(extra);
        let o = mtwin(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains(&format!("bad long.csv:{bad} column 'ax'")),
            "line/column not named: {err}"
        );
        assert!(err.contains("'oops' is not a number"), "{err}");
        assert!(!out.exists(), "output written despite the error");
        let entries = std::fs::read_dir(d.path()).unwrap().count();
        assert_eq!(entries, 1, "stray files");
    }
}
