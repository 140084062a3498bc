//! Messages say their thing once and in the user's terms; help points to docs/formats.md;
//! the lobes CSV has no empty column (issue 22).

use crate::common::*;
use std::path::{Path, PathBuf};

/// A one-pose twin identified from the tryout campaign's first record, in `dir`.
fn twin_in(dir: &Path) -> PathBuf {
    let data = shared_data().join("tryout_gantry/campaign/g00_x.csv");
    let twin = dir.join("twin.json");
    let o = mtwin(&["identify", s(&data), "--out", s(&twin), "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    twin
}

fn eval_twin(twin: &Path, out: &Path) -> std::process::Output {
    mtwin(&["eval", "--twin", s(twin), "--at", "0,0,0", "--out", s(out)])
}

#[test]
fn a_wrong_type_in_a_twin_file_is_named_at_its_line_and_column() {
    let d = tmp();
    let twin = twin_in(d.path());
    let text = std::fs::read_to_string(&twin).unwrap();
    // the first damping ratio becomes text
    let at = text.find("\"zeta\": ").unwrap() + "\"zeta\": ".len();
    let end = at + text[at..].find(['\n', ',']).unwrap();
    let bad = format!("{}\"x\"{}", &text[..at], &text[end..]);
    let line = text[..at].matches('\n').count() + 1;
    let path = d.path().join("bad twin.json");
    std::fs::write(&path, bad).unwrap();
    let out = d.path().join("f.csv");
    let o = eval_twin(&path, &out);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // `FILE:LINE:COLUMN: not a valid twin file: ...`
    let place = format!("bad twin.json:{line}:");
    let after = err
        .split(&place)
        .nth(1)
        .unwrap_or_else(|| panic!("line {line} not named: {err}"));
    let (column, rest) = after.split_once(':').unwrap();
    assert!(
        column.parse::<usize>().is_ok_and(|c| c > 0),
        "no column: {err}"
    );
    assert!(
        rest.starts_with(" not a valid twin file: invalid type"),
        "{err}"
    );
    assert_eq!(err.matches("invalid type").count(), 1, "{err}");
    assert!(!err.contains("at line"), "line said twice: {err}");
    assert!(!out.exists());

    // broken JSON: the parser's complaint once, with its place
    let mut half = text.len() / 2;
    while !text.is_char_boundary(half) {
        half -= 1;
    }
    std::fs::write(&path, &text[..half]).unwrap();
    let err = stderr(&eval_twin(&path, &out));
    assert_eq!(err.matches("EOF while parsing").count(), 1, "{err}");
    assert!(!err.contains("at line"), "{err}");
}

#[test]
fn a_folder_or_a_csv_given_as_twin_is_bad_input_for_every_command() {
    let d = tmp();
    let csv = d.path().join("data.csv");
    let rows: String = (0..40)
        .map(|i| format!("{},1,2\n", i as f64 * 1e-3))
        .collect();
    std::fs::write(&csv, format!("t,fx,ax\n{rows}")).unwrap();
    let out = d.path().join("out");
    let (o, dir) = (s(&out), s(d.path()));
    for twin in [dir, s(&csv)] {
        for args in [
            vec!["eval", "--twin", twin, "--at", "0,0,0", "--out", o],
            vec!["simulate", "--twin", twin, s(&csv), "--out", o],
            vec!["refit", "--twin", twin, s(&csv), "--out", o],
            vec!["diagnose", "--twin", twin, s(&csv), "--out", o],
            vec!["export", "--twin", twin, "--out", o],
            vec!["lobes", "--twin", twin, "--at", "0,0,0", "--out", o],
        ] {
            let r = mtwin(&args);
            let err = stderr(&r);
            assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
            assert!(err.contains(twin), "{args:?}: twin not named: {err}");
            assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
            for cause in ["Is a directory", "expected value"] {
                assert!(err.matches(cause).count() <= 1, "{args:?}: {err}");
            }
        }
    }
}

#[test]
fn a_missing_row_reports_time_steps_in_readable_units() {
    let d = tmp();
    let data = d.path().join("missing.csv");
    let mut csv = String::from("t,fx,ax\n");
    for i in (0..100).filter(|&i| i != 50) {
        let t = i as f64 * 1e-3;
        csv.push_str(&format!(
            "{t:?},{},{}\n",
            (i as f64).sin(),
            (i as f64).cos()
        ));
    }
    std::fs::write(&data, csv).unwrap();
    let o = mtwin(&["frf", s(&data), "--out", s(&d.path().join("f.csv"))]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("missing.csv:52"), "{err}");
    assert!(
        err.contains("time step 2 ms differs by more than 1 % from the typical step 1 ms"),
        "{err}"
    );
    assert!(!err.contains("e-3"), "{err}");
}

/// White-noise force through a lightly damped 1-DOF filter, as time-series CSV.
fn shaker_record(path: &Path, n: usize) {
    let (fs, f0, zeta, k) = (2000.0, 120.0, 0.03, 1e6);
    let (w, dt) = (2.0 * std::f64::consts::PI * f0, 1.0 / fs);
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let (mut x, mut v) = (0.0f64, 0.0f64);
    let mut csv = String::from("t,fx,dx\n");
    for i in 0..n {
        let f = 100.0 * rnd();
        // semi-implicit Euler at 8 substeps
        for _ in 0..8 {
            let a = f * w * w / k - 2.0 * zeta * w * v - w * w * x;
            v += a * dt / 8.0;
            x += v * dt / 8.0;
        }
        csv.push_str(&format!("{:?},{f:?},{x:?}\n", i as f64 * dt));
    }
    std::fs::write(path, csv).unwrap();
}

#[test]
fn averages_are_named_by_what_they_are() {
    let d = tmp();
    let data = d.path().join("shaker.csv");
    shaker_record(&data, 16384);
    let out = d.path().join("f.csv");
    let o = mtwin(&[
        "frf",
        s(&data),
        "--out",
        s(&out),
        "--excitation",
        "continuous",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains(" segments used"), "{err}");
    assert!(!err.contains("hits"), "{err}");
    let o = mtwin(&["frf", s(&data), "--out", s(&out), "--excitation", "chirp"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains(" 1 record used"), "{err}");
    assert!(!err.contains("hits"), "{err}");
    let o = mtwin(&[
        "frf",
        s(&data),
        "--out",
        s(&out),
        "--excitation",
        "continuous",
        "--json",
    ]);
    let js: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(js["averages_of"], "segments", "{js}");
    assert_eq!(js["averages"], js["hits_used"], "{js}");

    let impact = shared_data().join("tryout_gantry/campaign/g00_x.csv");
    let err = stderr(&mtwin(&["frf", s(&impact), "--out", s(&out)]));
    assert!(err.contains(" hits averaged"), "{err}");
    // the summary says each thing once: the estimator, the line spacing, the hits
    let line = err
        .lines()
        .find(|l| l.contains(" -> "))
        .expect("summary line");
    assert_eq!(line.matches("H1").count(), 1, "{line}");
    assert_eq!(line.matches("hits averaged").count(), 1, "{line}");
    assert!(!line.contains("used"), "{line}");
    assert_eq!(line.matches(" Hz").count(), 1, "{line}");
    assert!(line.contains(" dropped"), "{line}");
}

#[test]
fn campaign_warnings_are_summarised_and_verbose_prints_each() {
    let d = tmp();
    let dir = shared_data().join("tryout_gantry/campaign");
    let files: Vec<PathBuf> = ["g00_x", "g00_y", "g01_x", "g01_y", "g02_x", "g02_y"]
        .iter()
        .map(|f| dir.join(format!("{f}.csv")))
        .collect();
    let twin = d.path().join("t.json");
    let run = |extra: &[&str]| {
        let mut args = vec!["identify"];
        args.extend(files.iter().map(|f| s(f)));
        args.extend(["--out", s(&twin)]);
        args.extend(extra);
        let o = mtwin(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        o
    };
    let warnings = |o: &std::process::Output| {
        stderr(o)
            .lines()
            .filter(|l| l.starts_with("warning:"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let short = run(&[]);
    let all = run(&["--verbose"]);
    let js: serde_json::Value = serde_json::from_slice(&run(&["--json"]).stdout).unwrap();
    let (short, all) = (warnings(&short), warnings(&all));
    let listed = js["warnings"].as_array().unwrap().len();
    assert_eq!(
        all.len(),
        listed,
        "--verbose prints each of the JSON's warnings"
    );
    assert!(
        short.len() * 2 < all.len(),
        "not summarised: {} of {} lines\n{short:#?}",
        short.len(),
        all.len()
    );
    // one line per kind, saying where: "N records at M poses: response y is not at rest ..."
    let rest: Vec<&String> = short
        .iter()
        .filter(|l| l.contains("response z is not at rest"))
        .collect();
    assert_eq!(rest.len(), 1, "{short:#?}");
    assert!(rest[0].contains("records at 3 poses"), "{}", rest[0]);
    assert!(!rest[0].contains(".csv"), "{}", rest[0]);
    assert!(
        stderr(&run(&[])).contains("--verbose prints each"),
        "no pointer to --verbose"
    );
}

#[test]
fn identify_with_fmax_gets_no_hint_about_its_automatic_band() {
    let d = tmp();
    let data = shared_data().join("tryout_gantry/campaign/g00_x.csv");
    let twin = d.path().join("t.json");
    let o = mtwin(&["identify", s(&data), "--out", s(&twin), "--fmax", "2500"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("automatic band"), "{err}");
    assert!(!err.contains("set fmax"), "{err}");
    let o = mtwin(&["frf", s(&data), "--out", s(&d.path().join("f.csv"))]);
    assert!(!stderr(&o).contains("set fmax"), "{}", stderr(&o));
}

#[test]
fn help_has_no_rustdoc_escapes_and_points_to_the_formats_doc() {
    let formats =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/formats.md"))
            .expect("docs/formats.md");
    let headings: Vec<&str> = formats
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .collect();
    let mut pointers = 0;
    for cmd in [
        "demo", "frf", "identify", "eval", "simulate", "refit", "diagnose", "export", "lobes",
    ] {
        let o = mtwin(&[cmd, "--help"]);
        let help = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(o.status.code(), Some(0), "{cmd}");
        assert!(!help.contains("\\["), "{cmd}: {help}");
        assert!(!help.contains("SPEC section"), "{cmd}: {help}");
        // every `docs/formats.md, "Section"` names a section of the file
        for part in help.split("docs/formats.md").skip(1) {
            pointers += 1;
            let part = part.trim_start_matches([',', ' ', '\n']);
            if let Some(name) = part.strip_prefix('"').and_then(|p| p.split('"').next()) {
                let name = name.split_whitespace().collect::<Vec<_>>().join(" ");
                assert!(
                    headings.contains(&name.as_str()),
                    "{cmd}: no section '{name}'"
                );
            }
        }
    }
    assert!(pointers >= 4, "too few pointers to docs/formats.md");
    for section in [
        "Time-series CSV",
        "FRF CSV",
        "Universal files",
        "Twin file",
        "Diagnosis output",
        "Refit report",
        "Lobes CSV",
    ] {
        assert!(headings.contains(&section), "no section {section}");
    }
}

fn csv_columns(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (head, rows)
}

#[test]
fn lobes_csv_has_no_empty_column_and_announces_a_second_file() {
    let d = tmp();
    let twin = twin_in(d.path());
    let out = d.path().join("L.csv");
    let lobes = |extra: &[&str]| {
        let mut args = vec![
            "lobes",
            "--twin",
            s(&twin),
            "--at",
            "0.2,0.15,0.05",
            "--out",
            s(&out),
            "--speeds",
            "12",
        ];
        args.extend(extra);
        let o = mtwin(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        stderr(&o)
    };
    let check = |path: &Path, head: &[&str], n: usize| {
        let (h, rows) = csv_columns(path);
        assert_eq!(h, head, "{}", path.display());
        assert_eq!(rows.len(), n);
        for r in &rows {
            assert_eq!(r.len(), head.len());
            assert!(r.iter().all(|c| !c.is_empty()), "empty cell: {r:?}");
        }
    };
    // default: both methods at the same speeds, one file
    let err = lobes(&[]);
    check(
        &out,
        &[
            "rpm",
            "ap_lim_zoa_m",
            "ap_lim_sd_m",
            "chatter_hz_zoa",
            "chatter_hz_sd",
        ],
        12,
    );
    let sd = d.path().join("L.sd.csv");
    assert!(!sd.exists());
    assert!(err.contains("semi-discretisation"), "{err}");
    // other SD speeds: their own file, named in the summary
    let err = lobes(&["--sd-speeds", "5"]);
    check(&out, &["rpm", "ap_lim_zoa_m", "chatter_hz_zoa"], 12);
    check(&sd, &["rpm", "ap_lim_sd_m", "chatter_hz_sd"], 5);
    assert!(err.contains(s(&sd)), "second file not announced: {err}");
    // zero-order only
    std::fs::remove_file(&sd).unwrap();
    lobes(&["--sd-speeds", "0"]);
    check(&out, &["rpm", "ap_lim_zoa_m", "chatter_hz_zoa"], 12);
    assert!(!sd.exists());
}

/// A bad pose in a twin file is named as the reports count poses (from 1), with the
/// file's array index beside it.
#[test]
fn a_bad_pose_in_a_twin_file_is_counted_from_1() {
    let d = tmp();
    let twin = twin_in(d.path());
    let text = std::fs::read_to_string(&twin).unwrap();
    // the first damping ratio becomes negative: an unstable mode at the first pose
    let at = text.find("\"zeta\": ").unwrap() + "\"zeta\": ".len();
    let bad = format!("{}-{}", &text[..at], &text[at..]);
    let path = d.path().join("unstable.json");
    std::fs::write(&path, bad).unwrap();
    let o = eval_twin(&path, &d.path().join("f.csv"));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("pose 1 (`poses[0]`): model has an unstable mode"),
        "{err}"
    );
    assert!(!err.contains("pose 0"), "{err}");
}
