//! The HTML report of `mtwin refit`: the drift check, the operating FRF points against
//! the twin before and after, the measured vs simulated response before and after, the
//! modes that changed, how the change spread over the poses, and the whole history with
//! the mode frequencies over the machine's life.

use crate::report::{
    esc, figure, legend_html, page, phase_breaks, plot, Figure, Panel, Scale, Series,
};
use identify::axis::PoseText;
use identify::model::ModalModel;
use identify::refit::{mode_numbers, RefitReport};
use identify::timeseries::TimeSeries;
use identify::twin::Twin;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Longest time window shown in the response plots \[samples\].
const MAX_SAMPLES_SHOWN: usize = 2000;

/// Builds the report page.
pub fn refit_report(old: &Twin, new: &Twin, rep: &RefitReport, series: &[TimeSeries]) -> String {
    let mut b = String::new();
    let _ = writeln!(
        b,
        "<p>Refit of <code>{}</code> from {} at pose {} \
         with the <b>{}</b> method. Modes are numbered from 1 (mode 1 = the lowest).</p>",
        esc(&new.name),
        identify::axis::count(series.len(), "operating record"),
        PoseText(rep.pose),
        format!("{:?}", rep.method).to_lowercase()
    );
    let _ = writeln!(
        b,
        "<h2>Drift check</h2><table><tr><th>simulated response fit before</th>\
         <th>operating FRF misfit</th><th>decision</th><th>fit after</th><th>lines used</th></tr>\
         <tr><td>{:.2} %</td><td>{:.1} σ</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td></tr></table>",
        rep.drift_fit_pct,
        rep.drift_chi,
        if rep.updated || rep.held_out.is_some() {
            "bad"
        } else {
            "ok"
        },
        if rep.updated {
            "drift: twin updated"
        } else if rep.held_out.is_some() {
            "drift, but no validated update: modes kept"
        } else {
            "within tolerance: no change"
        },
        if rep.updated {
            format!("{:.2} %", rep.fit_after_pct)
        } else {
            "—".into()
        },
        rep.lines_hz.len()
    );
    if let Some(h) = &rep.held_out {
        let disc = h
            .discrepancy
            .iter()
            .map(|(c, e)| format!("{c} {:.2} %", 100.0 * e))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            b,
            "<h2>Held-out check</h2><p>{}. Split: {}. Modes the data excite: {}; refused at an \
             identity bound: {}. Twin's relative discrepancy per channel (added to the \
             standard errors): {}.</p>",
            esc(&h.note),
            esc(&h.split),
            mode_numbers(&h.candidates),
            mode_numbers(&h.refused_at_bound),
            esc(&disc)
        );
    }
    if let Some(oe) = &rep.output_error {
        let _ = writeln!(
            b,
            "<h2>Output-error stage</h2><p>The modes the cross-spectra moved were refined on the \
             records themselves (no Welch window): output residual {:.2} % → {:.2} % of the response \
             RMS in {}; the first {:.2} s of each record (the start-up transient) were not \
             fitted; estimated force noise floor {} of the force's median spectral level (the fit \
             regresses on the force's conditional expectation, so sensor noise on the force does not \
             bias the damping).</p>",
            100.0 * oe.rel_rms_before,
            100.0 * oe.rel_rms_after,
            identify::axis::count(oe.iterations, "iteration"),
            oe.skipped_s,
            oe.force_noise_text()
        );
    }
    if !rep.modes.is_empty() {
        let _ = writeln!(
            b,
            "<h2>Modes updated</h2><table><tr><th>mode</th><th>f before [Hz]</th>\
             <th>f after [Hz]</th><th>change</th><th>ζ before</th><th>ζ after</th></tr>"
        );
        for m in &rep.modes {
            let _ = writeln!(
                b,
                "<tr><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{:+.2} %</td><td>{:.2} %</td>\
                 <td>{:.2} %</td></tr>",
                m.mode + 1,
                m.freq_before_hz,
                m.freq_after_hz,
                100.0 * (m.freq_after_hz / m.freq_before_hz - 1.0),
                100.0 * m.zeta_before,
                100.0 * m.zeta_after
            );
        }
        let _ = writeln!(b, "</table>");
    }
    frf_section(&mut b, old, new, rep);
    response_section(&mut b, rep, series);
    if !rep.pose_weights.is_empty() {
        let _ = writeln!(
            b,
            "<h2>Spread over the poses</h2><p>Share of the measured change applied at each \
             measured pose (1 = in full).</p><table><tr><th>pose [m]</th><th>weight</th></tr>"
        );
        for (p, w) in &rep.pose_weights {
            let _ = writeln!(b, "<tr><td>{}</td><td>{w:.3}</td></tr>", PoseText(*p));
        }
        let _ = writeln!(b, "</table>");
    }
    history_section(&mut b, new, rep.pose);
    page("mtwin refit", &b)
}

fn model_at(twin: &Twin, pose: [f64; 3]) -> Option<ModalModel> {
    twin.model_at(pose).ok()
}

/// Operating H1 at the lines used vs the twin's FRF before and after.
fn frf_section(b: &mut String, old: &Twin, new: &Twin, rep: &RefitReport) {
    let (Some(m_old), Some(m_new)) = (model_at(old, rep.pose), model_at(new, rep.pose)) else {
        return;
    };
    // the spectra the refit itself used
    let Some(sp) = rep.spectra.as_ref() else {
        return;
    };
    let hi = m_old
        .modes
        .iter()
        .map(|m| m.freq_hz())
        .fold(0.0, f64::max)
        .max(rep.lines_hz.iter().copied().fold(0.0, f64::max))
        * 1.3;
    let hi = hi.min(*sp.freqs_hz.last().unwrap_or(&hi));
    // from half the lowest mode: a log axis, as FRFs are read
    let lo = 0.5
        * m_old
            .modes
            .iter()
            .map(|m| m.freq_hz())
            .fold(f64::INFINITY, f64::min)
            .min(hi / 20.0);
    let n = 800;
    let f: Vec<f64> = (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect();
    let _ = writeln!(
        b,
        "<h2>Operating FRF vs the twin</h2><p>Receptance at the operating pose: the \
         operating H1 (cross-spectra of the milling forces and the response, phase kept) at \
         the lines the refit used, the twin before and after.</p>"
    );
    for (ch, h) in &sp.h {
        let (Some(ci_old), Some(ci_new)) = (m_old.channel_index(*ch), m_new.channel_index(*ch))
        else {
            continue;
        };
        let idx: Vec<usize> = rep
            .lines_hz
            .iter()
            .filter(|&&lf| lf >= lo && lf <= hi)
            .filter_map(|lf| {
                sp.freqs_hz
                    .iter()
                    .position(|x| (x - lf).abs() <= 1e-6 * lf.abs().max(1.0))
            })
            .collect();
        let fx: Vec<f64> = idx.iter().map(|&k| sp.freqs_hz[k]).collect();
        let mag_pts: Vec<f64> = idx.iter().map(|&k| h[k].norm() * 1e6).collect();
        let ph_pts: Vec<f64> = idx.iter().map(|&k| h[k].arg() * 180.0 / PI).collect();
        let before: Vec<_> = f.iter().map(|&x| m_old.eval_hz(ci_old, x)).collect();
        let after: Vec<_> = f.iter().map(|&x| m_new.eval_hz(ci_new, x)).collect();
        let mag =
            |v: &[num_complex::Complex64]| v.iter().map(|c| c.norm() * 1e6).collect::<Vec<_>>();
        let ph = |v: &[num_complex::Complex64]| {
            v.iter().map(|c| c.arg() * 180.0 / PI).collect::<Vec<_>>()
        };
        let (mb, ma) = (mag(&before), mag(&after));
        let ((fb, pb), (fa, pa)) = (
            phase_breaks(&f, &ph(&before)),
            phase_breaks(&f, &ph(&after)),
        );
        let name = ch.name();
        let mags = [
            Series {
                label: "operating H1 (lines used)",
                x: &fx,
                y: &mag_pts,
                color: 0,
                points: true,
            },
            Series {
                label: "twin before",
                x: &f,
                y: &mb,
                color: 2,
                points: false,
            },
            Series {
                label: "twin after",
                x: &f,
                y: &ma,
                color: 1,
                points: false,
            },
        ];
        let phs = [
            Series {
                label: "",
                x: &fx,
                y: &ph_pts,
                color: 0,
                points: true,
            },
            Series {
                label: "",
                x: &fb,
                y: &pb,
                color: 2,
                points: false,
            },
            Series {
                label: "",
                x: &fa,
                y: &pa,
                color: 1,
                points: false,
            },
        ];
        b.push_str(&figure(&Figure {
            title: &format!("{name}: operating FRF vs the twin"),
            xlabel: "frequency [Hz]",
            xscale: Scale::Log,
            xrange: Some((lo, hi)),
            width: 760,
            panels: &[
                Panel::new("|H| [µm/N]", Scale::Log, &mags, 260),
                Panel {
                    yrange: Some((-190.0, 190.0)),
                    ..Panel::new("phase [°]", Scale::Phase, &phs, 140)
                },
            ],
        }));
    }
}

/// Measured vs simulated response (first record), before and after.
fn response_section(b: &mut String, rep: &RefitReport, series: &[TimeSeries]) {
    let Some(ts) = series.first() else { return };
    // the responses the refit simulated to score itself
    let Some((before, after)) = rep.responses.as_ref() else {
        return;
    };
    let _ = writeln!(
        b,
        "<h2>Measured vs simulated response</h2><p>{}: the twin driven by the measured \
         forces and axis positions (first {} samples shown).</p>",
        esc(&ts.source),
        ts.len().min(MAX_SAMPLES_SHOWN)
    );
    let unit = if ts.response_kind == Some(identify::timeseries::ResponseKind::Acceleration) {
        "acceleration [m/s²]"
    } else {
        "displacement [m]"
    };
    for ((axis, meas, sb), (_, _, sa)) in before.iter().zip(after.iter()) {
        let n = meas.len().min(MAX_SAMPLES_SHOWN);
        let t: Vec<f64> = (0..n).map(|i| i as f64 * ts.dt).collect();
        let eb: Vec<f64> = (0..n).map(|i| meas[i] - sb[i]).collect();
        let ea: Vec<f64> = (0..n).map(|i| meas[i] - sa[i]).collect();
        b.push_str(&plot(
            &format!("response {axis}: measured and twin after the refit"),
            "time [s]",
            unit,
            &[
                Series {
                    label: "measured",
                    x: &t,
                    y: &meas[..n],
                    color: 0,
                    points: false,
                },
                Series {
                    label: "twin after",
                    x: &t,
                    y: &sa[..n],
                    color: 1,
                    points: false,
                },
            ],
            Scale::Lin,
        ));
        b.push_str(&plot(
            &format!("response {axis}: residual (measured − twin)"),
            "time [s]",
            unit,
            &[
                Series {
                    label: "before",
                    x: &t,
                    y: &eb,
                    color: 2,
                    points: false,
                },
                Series {
                    label: "after",
                    x: &t,
                    y: &ea,
                    color: 1,
                    points: false,
                },
            ],
            Scale::Lin,
        ));
    }
}

/// `YYYY-MM-DD HH:MM` (UTC) of a Unix time.
fn utc(t: u64) -> String {
    let iso = mtwin_fmu::resources::utc_iso(t);
    format!("{} {}", &iso[..10], &iso[11..16])
}

/// The files of a history entry: up to three by name; more as their number and common
/// folder, the names folded away.
fn files_cell(files: &[String]) -> String {
    if files.len() <= 3 {
        return esc(&files.join(", "));
    }
    let dir = |f: &str| {
        std::path::Path::new(f)
            .parent()
            .map(|p| p.display().to_string())
            .unwrap_or_default()
    };
    let first = dir(&files[0]);
    let common = files.iter().all(|f| dir(f) == first);
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            if common {
                std::path::Path::new(f)
                    .file_name()
                    .map_or(f.clone(), |n| n.to_string_lossy().into_owned())
            } else {
                f.clone()
            }
        })
        .collect();
    format!(
        "<details><summary>{}{}</summary>{}</details>",
        identify::axis::count(files.len(), "file"),
        if common {
            format!(" in <code>{}</code>", esc(&first))
        } else {
            String::new()
        },
        esc(&names.join(", "))
    )
}

/// The history table and the mode frequencies at `pose` over the twin's life.
fn history_section(b: &mut String, twin: &Twin, pose: [f64; 3]) {
    let _ = writeln!(
        b,
        "<h2>History</h2><p>Every change the twin went through; each entry keeps the pose \
         models as they were before it, so no earlier model is lost. Entries are numbered \
         from 1 (entry 1: the identification).</p><table><tr><th>entry</th>\
         <th>time (UTC)</th><th>kind</th><th>files</th><th>what changed</th></tr>"
    );
    for (i, h) in twin.history.iter().enumerate() {
        let _ = writeln!(
            b,
            "<tr><td>{}</td><td style=\"white-space:nowrap\">{}</td><td>{}</td>\
             <td style=\"text-align:left\">{}</td><td style=\"text-align:left\">{}</td></tr>",
            i + 1,
            utc(h.unix_time),
            esc(&h.kind),
            files_cell(&h.files),
            esc(&h.summary)
        );
    }
    let _ = writeln!(b, "</table>");
    // the model at `pose` after each entry: entry k+1's previous_poses is the state after
    // entry k; the current twin is the state after the last entry
    // (entry number from 1, the model after it): `history[j].previous_poses` is the
    // twin after entry j (counted from 1); an entry without them leaves a gap
    let mut states: Vec<(usize, ModalModel)> = Vec::new();
    for (j, h) in twin.history.iter().enumerate().skip(1) {
        if h.previous_poses.is_empty() {
            continue;
        }
        let mut t = twin.clone();
        t.poses = h.previous_poses.clone();
        if let Some(m) = model_at(&t, pose) {
            states.push((j, m));
        }
    }
    if let Some(m) = model_at(twin, pose) {
        states.push((twin.history.len().max(1), m));
    }
    if states.len() < 2 {
        return;
    }
    let x: Vec<f64> = states.iter().map(|(j, _)| *j as f64).collect();
    let states: Vec<ModalModel> = states.into_iter().map(|(_, m)| m).collect();
    let n_modes = states.iter().map(|m| m.modes.len()).min().unwrap_or(0);
    let ys: Vec<Vec<f64>> = (0..n_modes)
        .map(|k| {
            states
                .iter()
                .map(|m| 100.0 * (m.modes[k].freq_hz() / states[0].modes[k].freq_hz() - 1.0))
                .collect()
        })
        .collect();
    let labels: Vec<String> = (0..n_modes)
        .map(|k| format!("mode {} ({:.0} Hz)", k + 1, states[0].modes[k].freq_hz()))
        .collect();
    let series: Vec<Series> = ys
        .iter()
        .zip(&labels)
        .enumerate()
        .map(|(k, (y, l))| Series {
            label: l,
            x: &x,
            y,
            // mode k in the colour identify.html's tracked modes give it (0 is black,
            // the measured data's)
            color: k + 1,
            points: false,
        })
        .collect();
    // lines with a dot per entry; the legend under the plot (inside, it would hide the
    // lines' ends)
    let legend: Vec<(&str, usize)> = series.iter().map(|s| (s.label, s.color)).collect();
    let all: Vec<Series> = series
        .iter()
        .flat_map(|s| {
            [false, true].map(|points| Series {
                label: "",
                points,
                ..*s
            })
        })
        .collect();
    b.push_str(&figure(&Figure {
        title: "natural frequencies at the operating pose over the twin's life",
        xlabel: "after history entry (1 = identified, then each refit)",
        xscale: Scale::Index,
        xrange: Some((x[0] - 0.2, x[x.len() - 1] + 0.2)),
        width: 760,
        panels: &[Panel::new(
            "change from the identified twin [%]",
            Scale::Lin,
            &all,
            300,
        )],
    }));
    b.push_str(&legend_html(&legend));
}

#[cfg(test)]
mod tests {
    use super::utc;

    #[test]
    fn utc_formats_known_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00");
        assert_eq!(utc(1_795_392_000 + 3_660), "2026-11-23 01:01");
    }
}
