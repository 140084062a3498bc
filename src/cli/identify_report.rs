//! The HTML report of `mtwin identify`: FRF measured vs model with coherence, the
//! stabilization diagram, modes across the workspace, leave-one-pose-out accuracy.

use crate::report::{esc, page, plot, Scale, Series};
use identify::stabilization::StabilizationDiagram;
use identify::twin::Twin;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Poses shown in full (FRF and diagram); the rest are in the tables and the map.
const MAX_POSES_SHOWN: usize = 4;

/// Builds the report page.
pub fn identify_report(twin: &Twin, diagrams: &[StabilizationDiagram]) -> String {
    let mut b = String::new();
    let _ = writeln!(
        b,
        "<p>Twin <code>{}</code>: {} pose(s), channels {}, interpolation <b>{}</b>. \
         Receptance in m/N; the model is the one stored in the twin (exponential-window \
         damping removed), the measured FRF is the estimate it was fitted to.</p>",
        esc(&twin.name),
        twin.poses.len(),
        twin.channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(", "),
        twin.interpolation.method
    );
    // summary table
    let _ = writeln!(
        b,
        "<h2>Poses</h2><table><tr><th>#</th><th>x [m]</th><th>y [m]</th><th>z [m]</th>\
         <th>modes</th><th>order</th><th>band [Hz]</th><th>fit per channel</th></tr>"
    );
    for (i, p) in twin.poses.iter().enumerate() {
        let _ = writeln!(
            b,
            "<tr><td>{i}</td><td>{:.3}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{}</td>\
             <td>{:.0}–{:.0}</td><td>{}</td></tr>",
            p.pose[0],
            p.pose[1],
            p.pose[2],
            p.order.modes,
            if p.order.automatic {
                "automatic"
            } else {
                "given"
            },
            p.band_hz[0],
            p.band_hz[1],
            p.fit
                .iter()
                .map(|f| format!("{} {:.2} %", f.channel, f.fit_pct))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(b, "</table>");
    let loo = &twin.interpolation.leave_one_out;
    if !loo.is_empty() {
        let _ = writeln!(
            b,
            "<h2>Leave-one-pose-out</h2><p>Each measured pose predicted from the others \
             by the interpolation, scored against its measured FRF.</p><table>\
             <tr><th>pose</th><th>fit per channel</th></tr>"
        );
        for e in loo {
            let _ = writeln!(
                b,
                "<tr><td>({:.3}, {:.3}, {:.3})</td><td>{}</td></tr>",
                e.pose[0],
                e.pose[1],
                e.pose[2],
                e.fit
                    .iter()
                    .map(|f| format!("{} {:.2} %", f.channel, f.fit_pct))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let _ = writeln!(b, "</table>");
    }
    // modes across the workspace
    if twin.poses.len() > 1 {
        let idx: Vec<f64> = (0..twin.poses.len()).map(|i| i as f64).collect();
        let n_modes = twin.poses[0].model.modes.len();
        let freqs: Vec<Vec<f64>> = (0..n_modes)
            .map(|k| {
                twin.poses
                    .iter()
                    .map(|p| p.model.modes.get(k).map_or(f64::NAN, |m| m.freq_hz()))
                    .collect()
            })
            .collect();
        let labels: Vec<String> = (0..n_modes).map(|k| format!("mode {}", k + 1)).collect();
        let series: Vec<Series<'_>> = (0..n_modes)
            .map(|k| Series {
                label: &labels[k],
                x: &idx,
                y: &freqs[k],
                color: k + 1,
                points: false,
            })
            .collect();
        let _ = writeln!(
            b,
            "<h2>Modes across the workspace</h2><p>Natural frequency of each tracked mode \
             at every measured pose (pose numbers as in the table).</p>{}",
            plot(
                "Tracked modes",
                "pose #",
                "natural frequency [Hz]",
                &series,
                Scale::Log
            )
        );
    }
    for (i, p) in twin.poses.iter().enumerate().take(MAX_POSES_SHOWN) {
        let _ = writeln!(
            b,
            "<h2>Pose {i}: ({:.3}, {:.3}, {:.3}) m</h2>",
            p.pose[0], p.pose[1], p.pose[2]
        );
        for ch in &p.frf.channels {
            let Some(ci) = p.model.channel_index(ch.channel) else {
                continue;
            };
            let f = &p.frf.freqs_hz;
            let keep: Vec<usize> = (0..f.len())
                .filter(|&k| f[k] >= p.band_hz[0] && f[k] <= p.band_hz[1] && f[k] > 0.0)
                .collect();
            let fx: Vec<f64> = keep.iter().map(|&k| f[k]).collect();
            let meas_mag: Vec<f64> = keep.iter().map(|&k| ch.h[k].norm()).collect();
            let meas_ph: Vec<f64> = keep.iter().map(|&k| ch.h[k].arg() * 180.0 / PI).collect();
            let model: Vec<_> = fx.iter().map(|&x| p.model.eval_hz(ci, x)).collect();
            let mod_mag: Vec<f64> = model.iter().map(|v| v.norm()).collect();
            let mod_ph: Vec<f64> = model.iter().map(|v| v.arg() * 180.0 / PI).collect();
            let title = format!("{} receptance", ch.channel);
            let _ = writeln!(
                b,
                "{}",
                plot(
                    &title,
                    "frequency [Hz]",
                    "|H| [m/N]",
                    &[
                        Series {
                            label: "measured",
                            x: &fx,
                            y: &meas_mag,
                            color: 0,
                            points: false
                        },
                        Series {
                            label: "model",
                            x: &fx,
                            y: &mod_mag,
                            color: 1,
                            points: false
                        }
                    ],
                    Scale::Log
                )
            );
            let _ = writeln!(
                b,
                "{}",
                plot(
                    &format!("{} phase", ch.channel),
                    "frequency [Hz]",
                    "phase [deg]",
                    &[
                        Series {
                            label: "measured",
                            x: &fx,
                            y: &meas_ph,
                            color: 0,
                            points: true
                        },
                        Series {
                            label: "model",
                            x: &fx,
                            y: &mod_ph,
                            color: 1,
                            points: false
                        }
                    ],
                    Scale::Lin
                )
            );
            if let Some(g) = &ch.coherence {
                let coh: Vec<f64> = keep.iter().map(|&k| g[k]).collect();
                let _ = writeln!(
                    b,
                    "{}",
                    plot(
                        &format!("{} coherence", ch.channel),
                        "frequency [Hz]",
                        "coherence",
                        &[Series {
                            label: "coherence",
                            x: &fx,
                            y: &coh,
                            color: 2,
                            points: false
                        }],
                        Scale::Lin
                    )
                );
            }
        }
        if let Some(d) = diagrams.get(i) {
            let _ = writeln!(b, "{}", diagram_plot(d, p.band_hz));
        }
    }
    if twin.poses.len() > MAX_POSES_SHOWN {
        let _ = writeln!(
            b,
            "<p>({} more poses: see the table; `mtwin eval` gives any pose's FRF.)</p>",
            twin.poses.len() - MAX_POSES_SHOWN
        );
    }
    page("mtwin identify", &b)
}

fn diagram_plot(d: &StabilizationDiagram, band: [f64; 2]) -> String {
    let (mut sx, mut sy, mut fx, mut fy, mut nx, mut ny) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for o in &d.orders {
        for p in &o.poles {
            if p.f_hz < band[0] || p.f_hz > band[1] {
                continue;
            }
            let (x, y) = if p.stable_freq && p.stable_damping {
                (&mut sx, &mut sy)
            } else if p.stable_freq {
                (&mut fx, &mut fy)
            } else {
                (&mut nx, &mut ny)
            };
            x.push(p.f_hz);
            y.push(o.order as f64);
        }
    }
    let px: Vec<f64> = d.physical.iter().map(|m| m.f_hz).collect();
    let top = d.orders.last().map_or(0.0, |o| o.order as f64) + 2.0;
    let py: Vec<f64> = vec![top; px.len()];
    format!(
        "<p>Stabilization diagram: poles per model order; \"stable\" = frequency and \
         damping agree with the previous order; the physical modes chosen are marked on \
         top.</p>{}",
        plot(
            "Stabilization diagram",
            "frequency [Hz]",
            "model order",
            &[
                Series {
                    label: "new",
                    x: &nx,
                    y: &ny,
                    color: 4,
                    points: true
                },
                Series {
                    label: "stable frequency",
                    x: &fx,
                    y: &fy,
                    color: 2,
                    points: true
                },
                Series {
                    label: "stable",
                    x: &sx,
                    y: &sy,
                    color: 3,
                    points: true
                },
                Series {
                    label: "physical modes",
                    x: &px,
                    y: &py,
                    color: 1,
                    points: true
                },
            ],
            Scale::Lin
        )
    )
}
