//! The whole single-pose chain on REAL measured data (../shared/data/pyfrf_impact_hammer):
//! frf → identify → eval → simulate, through the command line.

use crate::common::*;

#[test]
fn real_impact_test_from_frf_to_simulation() {
    let data = shared_data().join("pyfrf_impact_hammer/impact_5hits.csv");
    let d = tmp();
    let frf = d.path().join("frf.csv");
    let o = mtwin(&["frf", s(&data), "--out", s(&frf)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&frf).unwrap();
    // comment lines first (the force's band, an exponential window when one was chosen),
    // then the header
    assert!(text
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .starts_with("f_hz,xx_re,xx_im,xx_coh"));
    assert!(
        text.lines().any(|l| l.starts_with("# force_band_hz=")),
        "the FRF CSV states the force's band"
    );

    let twin = d.path().join("twin.json");
    let o = mtwin(&[
        "identify",
        s(&data),
        "--out",
        s(&twin),
        "--fmin",
        "200",
        "--fmax",
        "4500",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let fit = summary["poses"][0]["fit"][0]["fit_pct"].as_f64().unwrap();
    assert!(fit >= 97.0, "receptance fit {fit} % < 97 %");
    // resonances the data README names are in the model
    let freqs: Vec<f64> = summary["poses"][0]["natural_freqs_hz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    for f0 in [810.0, 900.0, 2640.0, 3669.0, 4128.0] {
        assert!(
            freqs.iter().any(|f| (f - f0).abs() < 0.02 * f0),
            "no mode near {f0} Hz in {freqs:?}"
        );
    }

    let ev = d.path().join("eval.csv");
    let o = mtwin(&[
        "eval",
        "--twin",
        s(&twin),
        "--at",
        "0,0,0",
        "--out",
        s(&ev),
        "--lines",
        "50",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&ev).unwrap().lines().count(), 51);

    let pred = d.path().join("pred.csv");
    let o = mtwin(&["simulate", "--twin", s(&twin), s(&data), "--out", s(&pred)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let p = std::fs::read_to_string(&pred).unwrap();
    let mut lines = p.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next(), Some("t,dx"));
    assert_eq!(lines.count(), 128_000);
}

/// The report shows what the automatic fit of the real impact record holds that is not a
/// mode of the structure in the band (issue 22): pole pairs outside the fitted band
/// (residual terms) and modes within each other's half-power bandwidth (one peak, perhaps
/// fitted twice) carry a note in the modes table, decided from the twin file itself.
#[test]
fn real_impact_report_flags_residual_terms_and_doubled_modes() {
    let data = shared_data().join("pyfrf_impact_hammer/impact_5hits.csv");
    let d = tmp();
    let twin = d.path().join("twin.json");
    let report = d.path().join("identify.html");
    let o = mtwin(&[
        "identify",
        s(&data),
        "--out",
        s(&twin),
        "--report",
        s(&report),
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&twin).unwrap()).unwrap();
    let pose = &t["poses"][0];
    let band: Vec<f64> = pose["band_hz"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let modes: Vec<(f64, f64)> = pose["model"]["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            let wn = m["wn"].as_f64().unwrap();
            (
                wn / (2.0 * std::f64::consts::PI),
                m["zeta"].as_f64().unwrap(),
            )
        })
        .collect();
    // the sign of each mode's modal constant in xx (the record's one, direct, channel):
    // Re of b1·s + b0 at the pole s = −ζωn + iωn√(1−ζ²)
    let nums = pose["model"]["channels"][0]["num"].as_array().unwrap();
    let sign: Vec<f64> = pose["model"]["modes"]
        .as_array()
        .unwrap()
        .iter()
        .zip(nums)
        .map(|(m, n)| {
            let (wn, z) = (m["wn"].as_f64().unwrap(), m["zeta"].as_f64().unwrap());
            let re = n["b1"].as_f64().unwrap() * (-z * wn) + n["b0"].as_f64().unwrap();
            re.signum()
        })
        .collect();
    let html = std::fs::read_to_string(&report).unwrap();
    let at = html.find("<h2>Identified modes</h2>").expect("modes table");
    let table = &html[at..at + html[at..].find("</table>").unwrap()];
    let rows: Vec<&str> = table.split("<tr><td>").skip(1).collect();
    assert_eq!(rows.len(), modes.len());
    let residual = |(f, z): (f64, f64)| f < band[0] || f > band[1] || z >= 0.3;
    let (mut outside, mut doubled) = (0, 0);
    for (k, &(f, z)) in modes.iter().enumerate() {
        let row = rows[k];
        let is_out = f < band[0] || f > band[1];
        assert_eq!(
            row.contains("outside the fitted band"),
            is_out,
            "mode {} at {f:.1} Hz, band {band:?}: {row}",
            k + 1
        );
        outside += is_out as usize;
        let near = modes.iter().enumerate().any(|(j, &(g, y))| {
            j != k && !residual((g, y)) && (g - f).abs() < z * f + y * g && sign[j] * sign[k] < 0.0
        });
        let flagged = near && !residual((f, z));
        assert_eq!(
            row.contains("half-power bandwidth"),
            flagged,
            "mode {} at {f:.1} Hz: {row}",
            k + 1
        );
        doubled += flagged as usize;
    }
    // the record's automatic fit has both today; if a better default removes them, the
    // notes go with them and this count says so
    eprintln!("{outside} residual terms outside the band, {doubled} modes in a doubled peak");
}

/// The default twin of the real impact test predicts the held-out hit of the same data
/// in time (`diagnose`, cause `none`) at ≥ 90 %: no pole outside the fitted band rings
/// for seconds. A 7237 Hz pole above the 7022 Hz band edge at 0.001 % damping (narrower
/// than a line, so no line the fit used resolves it) made the held-out fit 73.7 %; the
/// band's lines allow it 7 % (93.8 %).
#[test]
fn real_impact_twin_predicts_its_held_out_hit() {
    let data = shared_data().join("pyfrf_impact_hammer/impact_5hits.csv");
    let d = tmp();
    let twin = d.path().join("twin.json");
    let o = mtwin(&["identify", s(&data), "--out", s(&twin), "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&twin).unwrap()).unwrap();
    let pose = &t["poses"][0];
    let (lo, hi) = (
        pose["band_hz"][0].as_f64().unwrap(),
        pose["band_hz"][1].as_f64().unwrap(),
    );
    // the FRF's line spacing: 1 Hz (1 s per hit)
    for m in pose["model"]["modes"].as_array().unwrap() {
        let (wn, z) = (m["wn"].as_f64().unwrap(), m["zeta"].as_f64().unwrap());
        let f = wn / (2.0 * std::f64::consts::PI);
        if f < lo || f > hi {
            assert!(
                2.0 * z * f >= 0.25,
                "pole at {f:.1} Hz outside the band {lo:.0}-{hi:.0} Hz: half-power band {:.3} Hz",
                2.0 * z * f
            );
        }
    }
    let out = d.path().join("diag");
    let o = mtwin(&[
        "diagnose",
        "--twin",
        s(&twin),
        s(&data),
        "--out",
        s(&out),
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dj: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagnosis.json")).unwrap())
            .unwrap();
    assert_eq!(dj["cause"], "none", "{dj}");
    let fit = dj["fit_before_pct"].as_f64().unwrap();
    assert!(fit >= 90.0, "held-out hit predicted at {fit:.1} %");
}
