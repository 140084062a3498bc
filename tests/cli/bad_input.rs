//! Bad input never crashes and never writes output: exit 2, the file, line and column
//! named, nothing written.

use crate::common::*;

fn check_bad(csv: &str, line: usize, needle: &str) {
    let d = tmp();
    let data = d.path().join("bad data.csv");
    std::fs::write(&data, csv).unwrap();
    let out = d.path().join("frf.csv");
    for args in [
        vec!["frf", s(&data), "--out", s(&out)],
        vec!["identify", s(&data), "--out", s(&out)],
    ] {
        let o = mtwin(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("bad data.csv"), "file not named: {err}");
        if line > 0 {
            assert!(
                err.contains(&format!(":{line}")),
                "line {line} not named: {err}"
            );
        }
        assert!(
            err.to_lowercase().contains(needle),
            "'{needle}' not in: {err}"
        );
        assert!(!out.exists(), "output written despite the error");
        let leftovers: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
        assert_eq!(leftovers.len(), 1, "stray files: {leftovers:?}");
    }
}

fn good_rows(n: usize) -> String {
    (0..n)
        .map(|i| {
            format!(
                "{},{},{}\n",
                i as f64 * 1e-3,
                (i as f64).sin(),
                (i as f64).cos()
            )
        })
        .collect()
}

#[test]
fn nan_is_rejected_with_line_and_column() {
    let mut csv = String::from("t,fx,ax\n");
    csv.push_str(&good_rows(40));
    csv.push_str("0.040,NaN,1.0\n");
    check_bad(&csv, 42, "fx");
}

#[test]
fn text_in_a_number_is_rejected() {
    let mut csv = String::from("# comment\nt,fx,ax\n");
    csv.push_str(&good_rows(20));
    csv.push_str("0.020,1.0,abc\n");
    check_bad(&csv, 23, "ax");
}

#[test]
fn ragged_row_is_rejected() {
    let mut csv = String::from("t,fx,ax\n");
    csv.push_str(&good_rows(20));
    csv.push_str("0.020,1.0\n");
    check_bad(&csv, 22, "column");
}

#[test]
fn repeated_time_is_rejected() {
    let mut csv = String::from("t,fx,ax\n");
    csv.push_str(&good_rows(20));
    csv.push_str("0.019,1.0,2.0\n");
    check_bad(&csv, 22, "t");
}

#[test]
fn semicolon_separated_file_is_named_as_such() {
    check_bad("t;fx;ax\n0;1;2\n0.001;1;2\n", 1, "separated by semicolons");
}

#[test]
fn missing_force_column_is_rejected() {
    let csv: String = std::iter::once("t,ax\n".to_string())
        .chain((0..40).map(|i| format!("{},{}\n", i as f64 * 1e-3, i)))
        .collect();
    check_bad(&csv, 0, "force");
}

#[test]
fn empty_file_is_rejected() {
    check_bad("", 0, "no header and no data");
}

#[test]
fn usage_errors_exit_2() {
    let o = mtwin(&["identify", "x.csv", "--out", "t.json", "--order", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = mtwin(&["eval", "--twin", "t.json", "--at", "1,2", "--out", "f.csv"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("X,Y,Z"));
    let o = mtwin(&["frobnicate"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn missing_file_exits_2_and_names_it() {
    let d = tmp();
    let out = d.path().join("o.csv");
    let o = mtwin(&["frf", "no_such_file.csv", "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no_such_file.csv"));
    // a folder given for a file is bad input too (exit 2, not 1)
    let o = mtwin(&[
        "eval",
        "--twin",
        s(d.path()),
        "--at",
        "0,0,0",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // the cause said once (it used to repeat the I/O error after the message quoting it)
    for o in [
        o,
        mtwin(&[
            "eval",
            "--twin",
            "no_such_twin.json",
            "--at",
            "0,0,0",
            "--out",
            s(&out),
        ]),
    ] {
        let err = stderr(&o);
        assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    }
}

#[test]
fn twin_of_a_newer_schema_is_refused_clearly() {
    let d = tmp();
    let t = d.path().join("t.json");
    std::fs::write(&t, r#"{"schema":"mtwin-twin","version":99,"poses":[]}"#).unwrap();
    let out = d.path().join("f.csv");
    let o = mtwin(&["eval", "--twin", s(&t), "--at", "0,0,0", "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("newer"), "{}", stderr(&o));
    std::fs::write(&t, r#"{"hello":1}"#).unwrap();
    let o = mtwin(&["eval", "--twin", s(&t), "--at", "0,0,0", "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("not an mtwin twin file"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}
