//! The reports as a person reads them (issue 22): modes numbered from 1 in the reports,
//! the messages and `diagnosis.json`'s `mode_number`; poses printed as `(x, y, z) m` with
//! three decimals; the diagnosis headline in SPEC codes and its tables without raw JSON;
//! every pose of the campaign reachable; the lobes' jumps only where a new lobe begins
//! (an unstable island's tip, checked against the spectral radius); an 18-pose identify
//! report under 1.5 MB; the refit history and the demo's campaign files counted from 1;
//! the FRFs drawn as magnitude/phase, real/imaginary or both (`--frf-plot`).

use crate::common::*;
use identify::interpolate::TwinEvaluator;
use identify::lobes::{lobes_sd, lobes_zoa, stable_sd, Cut, SdOptions, Tool};
use identify::twin::Twin;
use std::path::Path;

/// The page's text outside its SVG figures.
fn text_outside_svg(html: &str) -> String {
    let mut out = String::new();
    let mut rest = html;
    while let Some(i) = rest.find("<svg") {
        out.push_str(&rest[..i]);
        rest = rest[i..].find("</svg>").map_or("", |j| &rest[i + j + 6..]);
    }
    out.push_str(rest);
    out
}

/// Every `(a, b, c)` of three numbers in `text`, as written.
fn triples(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices('(') {
        let Some(j) = text[i..].find(')') else {
            continue;
        };
        let inner = &text[i + 1..i + j];
        let parts: Vec<&str> = inner.split(", ").collect();
        if parts.len() == 3 && parts.iter().all(|p| p.parse::<f64>().is_ok()) {
            let after: String = text[i + j + 1..].chars().take(2).collect();
            out.push((inner.to_string(), after));
        }
    }
    out
}

/// Poses read `(0.200, 0.650, 0.050) m`: three decimals each, the unit after.
fn assert_poses_formatted(name: &str, text: &str) {
    let found = triples(text);
    for (inner, after) in &found {
        for p in inner.split(", ") {
            let decimals = p.split('.').nth(1).map_or(0, str::len);
            assert_eq!(decimals, 3, "{name}: pose ({inner}) not to 3 decimals");
        }
        assert_eq!(after, " m", "{name}: pose ({inner}) without its unit");
    }
}

/// No number printed with every float digit (7 or more decimals) in the text.
fn assert_no_long_floats(name: &str, text: &str) {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'.' && i > 0 && b[i - 1].is_ascii_digit() {
            let n = b[i + 1..].iter().take_while(|c| c.is_ascii_digit()).count();
            let ctx = String::from_utf8_lossy(&b[i.saturating_sub(30)..(i + n + 1).min(b.len())]);
            assert!(n < 7, "{name}: a float with {n} decimals: …{ctx}");
            i += n;
        }
        i += 1;
    }
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn demo_reports_number_modes_from_1_format_poses_and_show_every_pose() {
    let d = tmp();
    let dir = d.path().join("demo");
    let o = mtwin(&["demo", "--out", s(&dir), "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    // identify.html: all 18 poses reachable, the modes table starts at mode 1
    let id = read(&dir.join("identify.html"));
    for n in 1..=18 {
        assert!(
            id.contains(&format!("id=\"pose-{n}\"")),
            "pose {n} not reachable"
        );
        assert!(
            id.contains(&format!("href=\"#pose-{n}\"")),
            "pose {n} not linked"
        );
    }
    assert!(!id.contains("id=\"pose-0\""));
    let modes = id.find("<h2>Identified modes</h2>").expect("modes table");
    let first_row = id[modes..]
        .find("<tr><td>")
        .map(|i| &id[modes + i..modes + i + 12]);
    assert_eq!(first_row, Some("<tr><td>1</t"), "modes start at 1");
    assert!(id.contains("noise-free"), "the fit is not explained");
    // every pose's table lists the modes as the twin file and the tracked-modes plot
    // number them (tracked across the poses: two modes that cross keep their numbers,
    // so a pose's table need not be in frequency order), from 1
    let twin: serde_json::Value = serde_json::from_str(&read(&dir.join("twin.json"))).unwrap();
    let mut crossing = 0;
    for (i, pose) in twin["poses"].as_array().unwrap().iter().enumerate() {
        let f_twin: Vec<f64> = pose["model"]["modes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["wn"].as_f64().unwrap() / (2.0 * std::f64::consts::PI))
            .collect();
        let at = id
            .find(&format!("<h3>Modes at pose {}</h3>", i + 1))
            .expect("pose's modes table");
        let table = &id[at..at + id[at..].find("</table>").unwrap()];
        let rows: Vec<(usize, f64)> = table
            .split("<tr><td>")
            .skip(1)
            .map(|r| {
                let c: Vec<&str> = r.split("</td><td>").collect();
                (c[0].parse().unwrap(), c[1].parse().unwrap())
            })
            .collect();
        assert_eq!(rows.len(), f_twin.len(), "pose {}", i + 1);
        for (k, (n, f)) in rows.iter().enumerate() {
            assert_eq!(*n, k + 1, "pose {}: rows not numbered from 1", i + 1);
            assert!(
                (f - f_twin[k]).abs() < 0.051,
                "pose {}: mode {n} is {f} Hz in the table, {} Hz in the twin",
                i + 1,
                f_twin[k]
            );
        }
        crossing += f_twin.windows(2).any(|w| w[1] < w[0]) as usize;
    }
    assert!(
        crossing > 0,
        "no crossing modes in the demo: the check checked little"
    );
    let t = text_outside_svg(&id);
    assert!(!t.contains("mode 0"), "identify.html: mode 0");
    assert_poses_formatted("identify.html", &t);
    assert_no_long_floats("identify.html", &t);

    // an 18-pose report opens comfortably: the curves thinned on a log-frequency grid
    // (peaks kept) and the SVGs compacted (6.6 MB before)
    let size = std::fs::metadata(dir.join("identify.html")).unwrap().len();
    assert!(
        size < 1_500_000,
        "identify.html of 18 poses is {size} bytes"
    );
    // the campaign's files count poses from 1 too
    let names: Vec<String> = std::fs::read_dir(dir.join("data/campaign"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().any(|n| n == "pose01_hammer_x.csv"),
        "{names:?}"
    );
    assert!(
        names.iter().any(|n| n == "pose18_hammer_y.csv"),
        "{names:?}"
    );
    assert!(!names.iter().any(|n| n.starts_with("pose00")), "{names:?}");
    // the leave-one-pose-out table gives each pose its number
    let loo = id
        .find("<h2>Leave-one-pose-out</h2>")
        .expect("leave-one-out table");
    assert!(
        id[loo..].contains("<tr><td>1</td><td>(0.000, 0.000, 0.000) m</td>"),
        "leave-one-out rows without the pose number"
    );

    // the refit's history entry says what changed in English
    let refit: serde_json::Value =
        serde_json::from_str(&read(&dir.join("twin_refit.json"))).unwrap();
    let summary = refit["history"].as_array().unwrap().last().unwrap()["summary"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(summary.ends_with(", 1 mode changed"), "{summary}");

    // refit.html: the demo wears the third mode (index 2) and says "mode 3"
    let rf = read(&dir.join("refit.html"));
    let t = text_outside_svg(&rf);
    let updated = t.find("<h2>Modes updated</h2>").expect("modes updated");
    assert!(
        t[updated..].contains("<tr><td>3</td><td>180.00</td>"),
        "refit.html does not call the worn mode 3"
    );
    assert!(
        rf.contains("mode 1 ("),
        "history legend not numbered from 1"
    );
    assert!(!rf.contains("mode 0"), "refit.html: mode 0");
    assert!(
        t.contains("mode 3 updated: held-out"),
        "one mode is not 'modes'"
    );
    assert!(!t.contains("modes 3 "), "refit.html: 'modes 3'");
    // the history counts its entries from 1 (entry 1: the identification)
    let hist = t.find("<h2>History</h2>").expect("history");
    let first = t[hist..]
        .find("<tr><td>")
        .map(|i| &t[hist + i..hist + i + 12]);
    assert_eq!(first, Some("<tr><td>1</t"), "history not numbered from 1");
    assert!(
        t[hist..].contains("<tr><td>2</td>"),
        "the refit is not entry 2"
    );
    assert!(!t[hist..].contains("<tr><td>0</td>"), "history entry 0");
    assert_poses_formatted("refit.html", &t);
    assert_no_long_floats("refit.html", &t);

    // diagnosis: SPEC code in the headline, details as rows, mode_number = mode + 1
    let dg = read(&dir.join("diagnosis/report.html"));
    let t = text_outside_svg(&dg);
    assert!(
        t.contains("<h2>Cause: <code>unmodeled_mode</code></h2>"),
        "headline without the SPEC code"
    );
    for raw in ["UnmodeledMode", "ModeChange", "{\"", "\":", "[", "]"] {
        assert!(!t.contains(raw), "diagnosis report shows {raw}");
    }
    assert_no_long_floats("diagnosis/report.html", &t);
    let v: serde_json::Value =
        serde_json::from_str(&read(&dir.join("diagnosis/diagnosis.json"))).unwrap();
    let mut checked = 0;
    let cands = v["candidates"].as_array().cloned().unwrap_or_default();
    for det in std::iter::once(&v["details"]).chain(cands.iter().map(|c| &c["details"])) {
        if let Some(k) = det.get("mode").and_then(serde_json::Value::as_u64) {
            assert_eq!(det["mode_number"].as_u64(), Some(k + 1), "{det}");
            checked += 1;
        }
    }
    assert!(checked > 0, "no candidate names a mode: {v}");

    // index.html: the fit explained, the refit method said
    let ix = read(&dir.join("index.html"));
    assert!(ix.contains("noise-free"), "index.html: fit not explained");
    assert!(
        ix.contains("method time"),
        "index.html: refit method not said"
    );
    assert_poses_formatted("index.html", &text_outside_svg(&ix));

    // the FRFs as the reader chooses: real and imaginary parts, or both with a switch
    let files = [
        dir.join("data/campaign/pose01_hammer_x.csv"),
        dir.join("data/campaign/pose01_hammer_y.csv"),
    ];
    for (view, re_im, mag_phase) in [
        ("mag-phase", false, true),
        ("re-im", true, false),
        ("both", true, true),
    ] {
        let html = d.path().join(format!("{view}.html"));
        let o = mtwin(&[
            "identify",
            s(&files[0]),
            s(&files[1]),
            "--out",
            s(&d.path().join(format!("{view}.json"))),
            "--report",
            s(&html),
            "--frf-plot",
            view,
            "-q",
        ]);
        assert_eq!(o.status.code(), Some(0), "{view}: {}", stderr(&o));
        let h = read(&html);
        assert_eq!(h.contains("Re H [µm/N]"), re_im, "{view}: real part");
        assert_eq!(h.contains("Im H [µm/N]"), re_im, "{view}: imaginary part");
        assert_eq!(h.contains("phase [°]"), mag_phase, "{view}: phase");
        assert_eq!(
            h.contains("type=\"radio\""),
            view == "both",
            "{view}: the switch"
        );
    }

    // the refit's messages number modes from 1 too
    let o = mtwin(&[
        "refit",
        "--twin",
        s(&dir.join("twin.json")),
        s(&dir.join("data/operating/milling_3300rpm.csv")),
        "--out",
        s(&d.path().join("r.json")),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("  mode 3: 180.00 Hz"), "{err}");
    assert!(err.contains("mode 3 updated"), "{err}");
    assert!(!err.contains("modes 3"), "{err}");
    // and its JSON gives each changed mode's number beside its index
    let o = mtwin(&[
        "refit",
        "--twin",
        s(&dir.join("twin.json")),
        s(&dir.join("data/operating/milling_3300rpm.csv")),
        "--out",
        s(&d.path().join("r2.json")),
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let modes = v["report"]["modes"].as_array().expect("modes");
    assert!(!modes.is_empty(), "{v}");
    for m in modes {
        assert_eq!(
            m["mode_number"].as_u64(),
            m["mode"].as_u64().map(|k| k + 1),
            "{m}"
        );
    }
}

/// Reads a lobes CSV: (rpm, zoa, sd, f_zoa, f_sd) per row.
fn lobes_rows(path: &Path) -> Vec<[f64; 5]> {
    read(path)
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|c| c.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3], v[4]]
        })
        .collect()
}

#[test]
fn lobes_jump_only_where_a_new_lobe_begins_and_the_jump_is_real() {
    let d = tmp();
    // the demo machine's exact model at its centre, as a twin
    let machine = vmachine::structure::ModalMachine::default_machine();
    let axes = [identify::axis::Axis::X, identify::axis::Axis::Y];
    let twin = machine.exact_twin([2, 2, 2], &axes);
    let twin_path = d.path().join("twin.json");
    twin.save(&twin_path).unwrap();
    let at = machine.center();
    let at_text = format!("{},{},{}", at[0], at[1], at[2]);
    let out = d.path().join("L.csv");
    let plot = d.path().join("L.svg");
    let o = mtwin(&[
        "lobes",
        "--plot",
        s(&plot),
        "--twin",
        s(&twin_path),
        "--at",
        &at_text,
        "--out",
        s(&out),
        "--teeth",
        "3",
        "--immersion",
        "0.5",
        "--rpm-min",
        "2000",
        "--rpm-max",
        "8000",
        "--speeds",
        "300",
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // the plot: both methods, the stable region shaded, the cut's data in the figure
    let svg = read(&plot);
    for needle in [
        "zero-order (Altintas–Budak)",
        "semi-discretisation (Insperger–Stépán)",
        "stable (below both limits)",
        "3 teeth",
        "ae/D 0.50",
        "down-milling",
        "Kt 600 N/mm²",
        "spindle speed [rpm]",
        "limiting axial depth of cut [mm]",
        "<polygon",
    ] {
        assert!(svg.contains(needle), "lobes plot lacks {needle}");
    }
    let rows = lobes_rows(&out);
    let model = {
        let t = Twin::load(&twin_path).unwrap();
        TwinEvaluator::new(&t).unwrap().model_at(at).clone()
    };
    let tool = Tool {
        teeth: 3,
        diameter_m: 0.016,
        helix_deg: 0.0,
    };
    let cut = Cut {
        radial_immersion: 0.5,
        down_milling: true,
        kt: 6e8,
        kr: 0.3,
    };
    // a step of more than 15 % between neighbouring speeds is looked at 20 times finer:
    // a steep flank of one lobe spreads over the finer speeds; a step that stays is
    // another lobe taking over (its chatter frequency differs), and for the exact
    // semi-discretisation the step must be an unstable island's tip
    let jump = |x: f64, y: f64| (x / y).ln().abs() > 0.15_f64.ln_1p();
    let mut drops = 0;
    for w in rows.windows(2) {
        let (a, b) = (w[0], w[1]);
        for (col, name) in [(1, "zoa"), (2, "sd")] {
            if !(a[col].is_finite() && b[col].is_finite() && jump(a[col], b[col])) {
                continue;
            }
            let fine: Vec<f64> = (0..=20)
                .map(|j| a[0] + (b[0] - a[0]) * j as f64 / 20.0)
                .collect();
            let pts = if name == "zoa" {
                lobes_zoa(&model, &tool, &cut, &fine).unwrap()
            } else {
                lobes_sd(&model, &tool, &cut, &fine, &SdOptions::default()).unwrap()
            };
            for q in pts.windows(2) {
                let (p0, p1) = (q[0], q[1]);
                if !(p0.ap_lim_m.is_finite()
                    && p1.ap_lim_m.is_finite()
                    && jump(p0.ap_lim_m, p1.ap_lim_m))
                {
                    continue;
                }
                let (fa, fb) = (p0.chatter_hz, p1.chatter_hz);
                assert!(
                    (fa / fb).ln().abs() > 0.01_f64.ln_1p(),
                    "{name}: {:.1} rpm {:.2} mm -> {:.1} rpm {:.2} mm within one lobe \
                     ({fa:.1} -> {fb:.1} Hz): a sampling or root-finding artefact",
                    p0.rpm,
                    p0.ap_lim_m * 1e3,
                    p1.rpm,
                    p1.ap_lim_m * 1e3
                );
                if name == "sd" {
                    // the lower limit's lobe is not there at the other speed: the cut
                    // there is stable just below it (the island's tip lies between),
                    // and unstable just above the lower limit where it was found
                    let (hi_rpm, lo_rpm, lo_ap) = if p0.ap_lim_m > p1.ap_lim_m {
                        (p0.rpm, p1.rpm, p1.ap_lim_m)
                    } else {
                        (p1.rpm, p0.rpm, p0.ap_lim_m)
                    };
                    let (stable, rho) =
                        stable_sd(&model, &tool, &cut, hi_rpm, 0.98 * lo_ap).unwrap();
                    assert!(
                        stable,
                        "sd: at {hi_rpm:.2} rpm the depth {:.2} mm is unstable (ρ {rho:.4}): \
                         the lobe found at {lo_rpm:.2} rpm was missed there",
                        0.98 * lo_ap * 1e3
                    );
                    let (stable, rho) =
                        stable_sd(&model, &tool, &cut, lo_rpm, 1.005 * lo_ap).unwrap();
                    assert!(
                        !stable,
                        "sd: {lo_rpm:.2} rpm just above its limit is stable (ρ {rho:.4})"
                    );
                    drops += 1;
                }
            }
        }
    }
    assert!(
        drops > 0,
        "no lobe's island tip in 2000-8000 rpm: the check checked nothing"
    );
}

/// `mtwin frf --report`: each channel's FRF with its coherence, drawn as the reader
/// chooses, over the band where the coherence holds.
#[test]
fn frf_report_draws_each_channel_as_chosen() {
    let d = tmp();
    let data = shared_data().join("pyfrf_impact_hammer/impact_5hits.csv");
    for (view, re_im, mag_phase) in [
        ("mag-phase", false, true),
        ("re-im", true, false),
        ("both", true, true),
    ] {
        let html = d.path().join(format!("{view}.html"));
        let o = mtwin(&[
            "frf",
            s(&data),
            "--out",
            s(&d.path().join(format!("{view}.csv"))),
            "--report",
            s(&html),
            "--frf-plot",
            view,
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(0), "{view}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["report"].as_str(), Some(s(&html)), "{v}");
        let h = read(&html);
        assert!(h.contains("xx receptance"), "{view}: no xx figure");
        assert!(h.contains("coherence γ²"), "{view}: no coherence");
        assert_eq!(h.contains("Re H [µm/N]"), re_im, "{view}: real part");
        assert_eq!(h.contains("phase [°]"), mag_phase, "{view}: phase");
        assert_eq!(h.contains("type=\"radio\""), view == "both", "{view}");
        assert_no_long_floats(view, &text_outside_svg(&h));
    }
    // the report is an output: never one of the inputs
    let o = mtwin(&[
        "frf",
        s(&data),
        "--out",
        s(&d.path().join("x.csv")),
        "--report",
        s(&data),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
