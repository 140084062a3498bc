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
    assert!(text
        .lines()
        .next()
        .unwrap()
        .starts_with("f_hz,xx_re,xx_im,xx_coh"));

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
