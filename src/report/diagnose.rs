//! The diagnosis report (`mtwin diagnose`'s report.html): the headline in the SPEC's
//! cause codes, what was found, the causes tried, and the measured against the simulated
//! response of the original and the extended twin on the held-out data.

use crate::report::{esc, figure, page, phase_breaks, Figure, Panel, Scale, Series};
use anyhow::Result;
use identify::diagnose::{evidence, slice, split, DiagnoseOptions};
use identify::extended::simulate_as_measured;
use identify::twin::Twin;

/// A value of a diagnosis' `details` as a person reads it: numbers to four significant
/// digits, lists joined, text as is (HTML-escaped); never JSON syntax.
fn value_text(v: &serde_json::Value) -> String {
    use serde_json::Value;
    match v {
        Value::Null => "—".into(),
        Value::Bool(b) => if *b { "yes" } else { "no" }.into(),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.to_string(),
            (None, Some(f)) => sig4(f),
            _ => n.to_string(),
        },
        Value::String(s) => esc(s),
        Value::Array(a) => a.iter().map(value_text).collect::<Vec<_>>().join(", "),
        Value::Object(o) => o
            .iter()
            .map(|(k, v)| format!("{}: {}", esc(k), value_text(v)))
            .collect::<Vec<_>>()
            .join("; "),
    }
}

/// Two decimals, or `—` for a number that is not one (a score a cause does not have).
fn num2(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "—".into()
    }
}

/// Four significant digits, no exponent for everyday magnitudes.
fn sig4(f: f64) -> String {
    if f == 0.0 || !f.is_finite() {
        return f.to_string();
    }
    let e = f.abs().log10().floor() as i32;
    if !(-4..6).contains(&e) {
        return format!("{f:.3e}");
    }
    let d = (3 - e).max(0) as usize;
    let t = format!("{f:.d$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// A cause's `details` as rows of `key: value` (the mode as numbered in the reports,
/// from 1: `mode_number` is shown as `mode`, the 0-based index is left out).
fn details_rows(d: &serde_json::Map<String, serde_json::Value>) -> String {
    let mut rows = String::new();
    for (k, v) in d {
        let key = match k.as_str() {
            "mode" if d.contains_key("mode_number") => continue,
            "mode_number" => "mode",
            k => k,
        };
        // a damping ratio also as the percentage the summary says, a short time in µs
        let pct = match v.as_f64() {
            Some(z) if key.contains("damping") && z.abs() < 1.0 => {
                format!(" ({:.2} %)", 100.0 * z)
            }
            Some(t) if key.ends_with("_s") && t != 0.0 && t.abs() < 1e-3 => {
                format!(" ({:.2} µs)", t * 1e6)
            }
            _ => String::new(),
        };
        rows.push_str(&format!(
            "<tr><th>{}</th><td>{}{pct}</td></tr>",
            esc(key),
            value_text(v)
        ));
    }
    if rows.is_empty() {
        "—".into()
    } else {
        format!("<table class=\"kv\">{rows}</table>")
    }
}

/// The headline of the report: the SPEC code of the cause and the summary.
fn headline(diag: &identify::diagnose::Diagnosis) -> String {
    format!(
        "<h2>Cause: <code>{}</code></h2><p>{}</p>",
        diag.cause,
        esc(&diag.summary)
    )
}

/// The stretch of the held-out part `[a, end)` worth showing: around the strongest
/// response (a hit), from a little before it until its decay has fallen below 2 % of its
/// peak, at most `max` samples; continuous data keep the first `max` samples.
fn signal_window(m: &[f64], a: usize, end: usize, max: usize) -> (usize, usize) {
    let end = end.min(m.len());
    if a >= end {
        return (a, end);
    }
    let peak_i = (a..end)
        .max_by(|&i, &j| m[i].abs().total_cmp(&m[j].abs()))
        .unwrap_or(a);
    let peak = m[peak_i].abs();
    if peak == 0.0 {
        return (a, (a + max).min(end));
    }
    let last = (peak_i..end)
        .rev()
        .find(|&i| m[i].abs() > 0.02 * peak)
        .unwrap_or(peak_i);
    let len = last - peak_i;
    let start = peak_i.saturating_sub(len / 10 + 5).max(a);
    let stop = (last + len / 10 + 5).min(end);
    if stop - start > max {
        (start, start + max)
    } else {
        (start, stop)
    }
}

/// The diagnosis report: the cause, the causes tried, the held-out response and the FRF
/// evidence.
pub fn report(
    twin: &Twin,
    ext: &Twin,
    series: &[identify::timeseries::TimeSeries],
    diag: &identify::diagnose::Diagnosis,
    opts: &DiagnoseOptions,
) -> Result<String> {
    let mut body = headline(diag);
    body.push_str(&format!(
        "<p>Held-out fit: original twin <b>{:.2} %</b>, extended twin <b>{:.2} %</b>. FRF \
         misfit of the original twin: {:.1} standard errors (RMS).</p><h3>What was found</h3>{}",
        diag.fit_before_pct,
        diag.fit_after_pct,
        diag.chi_before,
        details_rows(&diag.details)
    ));
    body.push_str(
        "<h3>Causes tried</h3><table><tr><th>cause</th><th>FRF misfit χ</th>\
         <th>held-out fit %</th><th>numbers</th></tr>",
    );
    for c in &diag.candidates {
        body.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td style='text-align:left'>{}</td></tr>",
            c.cause,
            num2(c.chi),
            num2(c.fit_holdout_pct),
            details_rows(&c.details)
        ));
    }
    body.push_str("</table>");
    held_out_section(&mut body, twin, ext, &series[0], opts)?;
    frf_evidence_section(&mut body, twin, ext, series, opts)?;
    Ok(page("mtwin diagnosis", &body))
}

/// Measured vs simulated response on the held-out part of the first record, where the
/// signal is, with what each twin leaves unexplained.
fn held_out_section(
    body: &mut String,
    twin: &Twin,
    ext: &Twin,
    ts: &identify::timeseries::TimeSeries,
    opts: &DiagnoseOptions,
) -> Result<()> {
    let sp = split(ts, opts.holdout_fraction);
    let y0 = simulate_as_measured(twin, ts)?;
    let y1 = simulate_as_measured(ext, ts)?;
    let a = sp.holdout_start;
    // one window for every axis, from the axis that responds most (the hit's direction):
    // a cross axis's small response would otherwise stretch it over its noise
    let modelled = |ax: identify::axis::Axis| {
        y0.get(ax.index())
            .is_some_and(|v| v.iter().any(|x| *x != 0.0))
    };
    let lead = ts
        .response_axes()
        .into_iter()
        .filter(|ax| modelled(*ax))
        .filter_map(|ax| {
            let m = ts.response(ax)?;
            let peak = m.get(a..)?.iter().fold(0.0_f64, |p, v| p.max(v.abs()));
            Some((ax, peak))
        })
        .max_by(|x, y| x.1.total_cmp(&y.1));
    let window = lead
        .and_then(|(ax, _)| ts.response(ax))
        .map(|m| signal_window(m, a, ts.len(), 4000));
    for ax in ts.response_axes() {
        let (Some(m), Some((lo, hi))) = (ts.response(ax), window) else {
            continue;
        };
        if hi <= lo + 1 || !modelled(ax) {
            continue;
        }
        let accel = ts.response_kind == Some(identify::timeseries::ResponseKind::Acceleration);
        let (scale, unit) = if accel {
            (1.0, "acceleration [m/s²]")
        } else {
            (1e6, "displacement [µm]")
        };
        let t: Vec<f64> = (lo..hi).map(|i| (i - lo) as f64 * ts.dt * 1e3).collect();
        let ms: Vec<f64> = m[lo..hi].iter().map(|v| v * scale).collect();
        let s0: Vec<f64> = y0[ax.index()][lo..hi].iter().map(|v| v * scale).collect();
        let s1: Vec<f64> = y1[ax.index()][lo..hi].iter().map(|v| v * scale).collect();
        let r0: Vec<f64> = ms.iter().zip(&s0).map(|(a, b)| a - b).collect();
        let r1: Vec<f64> = ms.iter().zip(&s1).map(|(a, b)| a - b).collect();
        let resp = [
            Series {
                label: "measured",
                x: &t,
                y: &ms,
                color: 0,
                points: false,
            },
            Series {
                label: "twin",
                x: &t,
                y: &s0,
                color: 1,
                points: false,
            },
            Series {
                label: "extended twin",
                x: &t,
                y: &s1,
                color: 2,
                points: false,
            },
        ];
        let res = [
            Series {
                label: "measured − twin",
                x: &t,
                y: &r0,
                color: 1,
                points: false,
            },
            Series {
                label: "measured − extended twin",
                x: &t,
                y: &r1,
                color: 2,
                points: false,
            },
        ];
        let title = format!(
            "held-out response {ax} ({}), from t = {:.3} s",
            ts.source,
            ts.t0 + lo as f64 * ts.dt
        );
        let resid_label = if accel {
            "residual [m/s²]"
        } else {
            "residual [µm]"
        };
        body.push_str(&format!(
            "<p>Held-out part of <code>{}</code>, axis {ax}: the stretch where the response is \
             (until the strongest axis has decayed to 2 % of its peak), and below it what each \
             twin leaves unexplained.</p>",
            esc(&ts.source)
        ));
        body.push_str(&figure(&Figure {
            title: &title,
            xlabel: "time [ms]",
            xscale: Scale::Lin,
            xrange: None,
            width: 760,
            panels: &[
                Panel::new(unit, Scale::Lin, &resp, 260),
                Panel::new(resid_label, Scale::Lin, &res, 150),
            ],
        }));
    }
    Ok(())
}

/// The FRF evidence (the building part of the records) against the twin and the
/// extended twin, per channel.
fn frf_evidence_section(
    body: &mut String,
    twin: &Twin,
    ext: &Twin,
    series: &[identify::timeseries::TimeSeries],
    opts: &DiagnoseOptions,
) -> Result<()> {
    let parts: Vec<_> = series
        .iter()
        .map(|r| {
            let s = split(r, opts.holdout_fraction);
            slice(r, 0, s.holdout_start)
        })
        .collect();
    if let Ok(ev) = evidence(&parts) {
        let pose = series[0].mean_position();
        let m0 = twin.model_at(pose)?;
        let m1 = ext.model_at(pose)?;
        let band = (
            twin.poses
                .iter()
                .map(|p| p.band_hz[0])
                .fold(f64::INFINITY, f64::min),
            twin.poses.iter().map(|p| p.band_hz[1]).fold(0.0, f64::max),
        );
        for (ch, h, g) in &ev.channels {
            let idx: Vec<usize> = (0..ev.freqs_hz.len())
                .filter(|&i| ev.freqs_hz[i] >= band.0 && ev.freqs_hz[i] <= band.1)
                .collect();
            let idx: Vec<usize> = idx.into_iter().filter(|&i| ev.freqs_hz[i] > 0.0).collect();
            let fr: Vec<f64> = idx.iter().map(|&i| ev.freqs_hz[i]).collect();
            let meas: Vec<f64> = idx.iter().map(|&i| h[i].norm() * 1e6).collect();
            let meas_ph: Vec<f64> = idx.iter().map(|&i| h[i].arg().to_degrees()).collect();
            let model = |m: &identify::model::ModalModel| -> (Vec<f64>, Vec<f64>) {
                match m.channel_index(*ch) {
                    Some(ci) => fr
                        .iter()
                        .map(|&f| {
                            let v = m.eval_hz(ci, f);
                            (v.norm() * 1e6, v.arg().to_degrees())
                        })
                        .unzip(),
                    None => (vec![0.0; fr.len()], vec![f64::NAN; fr.len()]),
                }
            };
            let ((a0, p0), (a1, p1)) = (model(&m0), model(&m1));
            let ((f0, p0), (f1, p1)) = (phase_breaks(&fr, &p0), phase_breaks(&fr, &p1));
            let coh: Vec<f64> = idx.iter().map(|&i| g[i]).collect();
            let mag = [
                Series {
                    label: "measured H1",
                    x: &fr,
                    y: &meas,
                    color: 0,
                    points: false,
                },
                Series {
                    label: "twin",
                    x: &fr,
                    y: &a0,
                    color: 1,
                    points: false,
                },
                Series {
                    label: "extended twin",
                    x: &fr,
                    y: &a1,
                    color: 2,
                    points: false,
                },
            ];
            let ph = [
                Series {
                    label: "",
                    x: &fr,
                    y: &meas_ph,
                    color: 0,
                    points: true,
                },
                Series {
                    label: "",
                    x: &f0,
                    y: &p0,
                    color: 1,
                    points: false,
                },
                Series {
                    label: "",
                    x: &f1,
                    y: &p1,
                    color: 2,
                    points: false,
                },
            ];
            let cs = [Series {
                label: "",
                x: &fr,
                y: &coh,
                color: 3,
                points: false,
            }];
            let log = band.0 > 0.0 && band.1 / band.0 >= 8.0;
            body.push_str(&figure(&Figure {
                title: &format!("FRF {ch}: measured (building part) vs twin"),
                xlabel: "frequency [Hz]",
                xscale: if log { Scale::Log } else { Scale::Lin },
                xrange: None,
                width: 760,
                panels: &[
                    Panel::new("|H| [µm/N]", Scale::Log, &mag, 250),
                    Panel {
                        yrange: Some((-190.0, 190.0)),
                        ..Panel::new("phase [°]", Scale::Phase, &ph, 130)
                    },
                    Panel {
                        yrange: Some((0.0, 1.05)),
                        ..Panel::new("coherence γ²", Scale::Lin, &cs, 100)
                    },
                ],
            }));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{details_rows, headline, signal_window};
    use identify::diagnose::{Cause, Diagnosis};
    use serde_json::json;

    fn diagnosis(cause: Cause, details: serde_json::Value) -> Diagnosis {
        Diagnosis {
            cause,
            summary: "The 412 Hz mode in x has moved.".into(),
            details: details.as_object().cloned().unwrap_or_default(),
            fit_before_pct: 70.0,
            fit_after_pct: 95.0,
            extended_twin: "twin_extended.json".into(),
            chi_before: 8.0,
            candidates: Vec::new(),
        }
    }

    #[test]
    fn headline_shows_the_spec_code() {
        for (cause, code) in [
            (Cause::ModeChange, "mode_change"),
            (Cause::UnmodeledMode, "unmodeled_mode"),
            (Cause::CrossCoupling, "cross_coupling"),
            (Cause::None, "none"),
        ] {
            let h = headline(&diagnosis(cause, json!({})));
            assert!(h.contains(&format!("<code>{code}</code>")), "{h}");
            assert!(!h.contains(&format!("{cause:?}")) || code == "none", "{h}");
        }
    }

    #[test]
    fn details_are_key_value_rows_not_json() {
        let d = json!({
            "freq_hz": 412.123456,
            "new_freq_hz": 398.5,
            "fit_band_hz": [370.0, 450.5],
            "axis": "x",
            "mode": 2,
            "mode_number": 3,
            "force_noise": {"fx": 0.01},
            "note": "a <b> tag"
        });
        let html = details_rows(d.as_object().unwrap());
        for raw in ["{", "}", "\":", "\",", "[", "]"] {
            assert!(!html.contains(raw), "raw JSON {raw} in {html}");
        }
        assert!(
            html.contains("<tr><th>freq_hz</th><td>412.1</td></tr>"),
            "{html}"
        );
        assert!(
            html.contains("<tr><th>fit_band_hz</th><td>370, 450.5</td></tr>"),
            "{html}"
        );
        // the mode as people count it, from 1; the 0-based index is not shown
        assert!(html.contains("<tr><th>mode</th><td>3</td></tr>"), "{html}");
        assert!(!html.contains("<td>2</td>"), "{html}");
        assert!(html.contains("a &lt;b&gt; tag"), "{html}");
    }

    #[test]
    fn the_held_out_plot_shows_the_hit_not_the_flat_tail() {
        // a hit at 1000 decaying in ~300 samples, then 8000 samples of near silence
        let m: Vec<f64> = (0..10_000)
            .map(|i| {
                if i < 1000 {
                    1e-9
                } else {
                    let t = (i - 1000) as f64;
                    (-t / 60.0).exp() * (t * 0.3).cos()
                }
            })
            .collect();
        let (lo, hi) = signal_window(&m, 500, m.len(), 4000);
        assert!((900..=1000).contains(&lo), "{lo}");
        assert!((1201..1600).contains(&hi), "{hi}");
    }
}
