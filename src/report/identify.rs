//! The HTML report of `mtwin identify`: the identified modes (frequency, damping, modal
//! stiffness and mass per channel), the fit explained, every pose's FRF (magnitude, phase,
//! coherence; measured vs model) with its stabilization diagram over the FRF sum, small
//! multiples of all poses, the modes across the workspace and leave-one-pose-out accuracy.
//! Modes and poses are numbered from 1.

use crate::report::{
    esc, figure, legend_html, page, phase_breaks, stabilization_figure, thin, Figure, Panel, Scale,
    Series,
};
use identify::axis::PoseText;
use identify::frf::FrfChannel;
use identify::model::{ModalModel, Mode, ModeNum};
use identify::stabilization::StabilizationDiagram;
use identify::twin::{ChannelFit, PoseModel, Twin};
use num_complex::Complex64;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Most points drawn per line (the FRF is thinned to the extremes of log-spaced buckets,
/// so no resonance peak is lost).
const MAX_POINTS: usize = 300;

/// Modal constant `A` of one mode in one channel (m/N·rad²/s²; for a real mode the
/// numerator `b0`): the magnitude of `b1 p + b0` at the pole, signed by its real part.
/// Modal mass `1/A`, modal stiffness `ωn²/A` (the single-degree-of-freedom equivalent
/// seen in that channel; negative = the channel responds in antiphase).
fn modal_constant(mode: &Mode, num: &ModeNum) -> f64 {
    let a = mode.pole() * num.b1 + num.b0;
    a.norm() * if a.re < 0.0 { -1.0 } else { 1.0 }
}

/// A channel whose modal constant is below this share of the mode's largest one hardly
/// sees the mode: its stiffness and mass there are not shown (they would be huge and
/// carry the fit's noise).
const WEAK_SHARE: f64 = 0.05;

/// The largest |modal constant| of mode `k` over the model's channels.
fn largest_constant(model: &ModalModel, k: usize) -> f64 {
    model
        .channels
        .iter()
        .filter_map(|c| c.num.get(k))
        .map(|n| modal_constant(&model.modes[k], n).abs())
        .fold(0.0, f64::max)
}

fn stiffness_text(mode: &Mode, num: &ModeNum, largest: f64) -> (String, String) {
    let a = modal_constant(mode, num);
    if a == 0.0 || !a.is_finite() || a.abs() < WEAK_SHARE * largest {
        return ("—".into(), "—".into());
    }
    let k = mode.wn * mode.wn / a;
    (sig4(k * 1e-6), sig4(1.0 / a))
}

/// Four significant digits (the fit carries no more): `68.47`, `14243`, `0.5120`.
fn sig4(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{v:.decimals$}")
}

/// A channel's fit: against the measured FRF, what the noise allows, and the estimate
/// against the noise-free FRF.
fn fit_text(f: &ChannelFit) -> String {
    let opt = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.1} %"));
    format!(
        "<b>{}</b> {:.1} % <small>(noise allows {}; noise-free est. {})</small>",
        f.channel,
        f.fit_pct,
        opt(f.noise_limit_pct),
        opt(f.noise_free_fit_pct)
    )
}

/// What a reader should know about mode `k` of a pose fitted in `band` \[Hz\]: a pole pair
/// outside the band or damped beyond any resonance stands for the modes outside it (a
/// residual term, not a mode of the structure in the band); two modes within their
/// half-power bandwidths of each other may be one mode fitted twice. Empty when nothing
/// is to be said.
fn mode_note(model: &ModalModel, k: usize, band: [f64; 2]) -> String {
    let m = &model.modes[k];
    let f = m.freq_hz();
    let residual = |o: &Mode| o.freq_hz() < band[0] || o.freq_hz() > band[1] || o.zeta >= 0.3;
    let mut notes = Vec::new();
    if f < band[0] || f > band[1] {
        notes.push(format!(
            "outside the fitted band {:.0}–{:.0} Hz: a residual term for the modes {}",
            band[0],
            band[1],
            if f < band[0] { "below" } else { "above" }
        ));
    } else if m.zeta >= 0.3 {
        notes.push(format!(
            "damping {:.0} %: no resonance, a residual term",
            100.0 * m.zeta
        ));
    }
    // half-power bandwidths 2ζf: closer than the sum of the half widths, the two peaks
    // are one in the FRF. Two modes of one peak that pull a direct channel in opposite
    // directions are one resonance fitted twice (the data fix only their sum); two close
    // modes of one sign in every direct channel are a real pair (an x and a y mode).
    let constant = |j: usize, ci: usize| {
        model.channels[ci]
            .num
            .get(j)
            .map_or(0.0, |n| modal_constant(&model.modes[j], n))
    };
    let direct: Vec<usize> = (0..model.channels.len())
        .filter(|&ci| model.channels[ci].channel.output == model.channels[ci].channel.input)
        .collect();
    let near: Vec<usize> = model
        .modes
        .iter()
        .enumerate()
        .filter(|&(j, o)| {
            j != k
                && !residual(o)
                && (o.freq_hz() - f).abs() < m.zeta * f + o.zeta * o.freq_hz()
                && direct
                    .iter()
                    .any(|&ci| constant(k, ci) * constant(j, ci) < 0.0)
        })
        .map(|(j, _)| j)
        .collect();
    if !near.is_empty() && !residual(m) {
        notes.push(format!(
            "within the half-power bandwidth of {}, of opposite sign in a direct channel: \
             one peak fitted twice (the data fix only their sum)",
            identify::refit::modes_named(&near)
        ));
    }
    notes.join("; ")
}

/// The modes of one pose fitted in `band` \[Hz\]: frequency, damping, modal stiffness and
/// mass per channel, and a note where a mode is not what it seems ([`mode_note`]).
fn modes_table(model: &ModalModel, band: [f64; 2]) -> String {
    let mut b = String::from("<table><tr><th>mode</th><th>f [Hz]</th><th>ζ [%]</th>");
    for c in &model.channels {
        let _ = write!(
            b,
            "<th>k<sub>{0}</sub> [N/µm]</th><th>m<sub>{0}</sub> [kg]</th>",
            c.channel
        );
    }
    let notes: Vec<String> = (0..model.modes.len())
        .map(|k| mode_note(model, k, band))
        .collect();
    let any_note = notes.iter().any(|n| !n.is_empty());
    if any_note {
        b.push_str("<th style=\"text-align:left\">note</th>");
    }
    b.push_str("</tr>");
    for (k, m) in model.modes.iter().enumerate() {
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{:.1}</td><td>{:.2}</td>",
            k + 1,
            m.freq_hz(),
            100.0 * m.zeta
        );
        let largest = largest_constant(model, k);
        for c in &model.channels {
            let (ks, ms) = c.num.get(k).map_or(("—".into(), "—".into()), |n| {
                stiffness_text(m, n, largest)
            });
            let _ = write!(b, "<td>{ks}</td><td>{ms}</td>");
        }
        if any_note {
            let _ = write!(
                b,
                "<td style=\"text-align:left\"><small>{}</small></td>",
                esc(&notes[k])
            );
        }
        b.push_str("</tr>");
    }
    b.push_str("</table>");
    b
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Modes over all poses: median and range of frequency and damping, median modal
/// stiffness of the direct channels.
fn modes_summary(twin: &Twin) -> String {
    let n_modes = twin
        .poses
        .iter()
        .map(|p| p.model.modes.len())
        .max()
        .unwrap_or(0);
    let direct: Vec<_> = twin
        .channels
        .iter()
        .filter(|c| c.output == c.input)
        .copied()
        .collect();
    let mut b = String::from(
        "<table><tr><th>mode</th><th>f [Hz] median</th><th>f range over the poses [Hz]</th>\
         <th>ζ [%] median</th><th>ζ range [%]</th>",
    );
    for c in &direct {
        let _ = write!(b, "<th>k<sub>{c}</sub> median [N/µm]</th>");
    }
    b.push_str("</tr>");
    for k in 0..n_modes {
        let ms: Vec<&Mode> = twin
            .poses
            .iter()
            .filter_map(|p| p.model.modes.get(k))
            .collect();
        let mut f: Vec<f64> = ms.iter().map(|m| m.freq_hz()).collect();
        let mut z: Vec<f64> = ms.iter().map(|m| 100.0 * m.zeta).collect();
        let (fmed, zmed) = (median(&mut f), median(&mut z));
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{fmed:.1}</td><td>{:.1} – {:.1}</td><td>{zmed:.2}</td>\
             <td>{:.2} – {:.2}</td>",
            k + 1,
            f.first().copied().unwrap_or(f64::NAN),
            f.last().copied().unwrap_or(f64::NAN),
            z.first().copied().unwrap_or(f64::NAN),
            z.last().copied().unwrap_or(f64::NAN),
        );
        for c in &direct {
            let mut ks: Vec<f64> = twin
                .poses
                .iter()
                .filter_map(|p| {
                    let m = p.model.modes.get(k)?;
                    let n = p.model.channel(*c)?.num.get(k)?;
                    let a = modal_constant(m, n);
                    let weak = a.abs() < WEAK_SHARE * largest_constant(&p.model, k);
                    (a != 0.0 && !weak).then(|| m.wn * m.wn / a * 1e-6)
                })
                .collect();
            // shown where the mode is seen in this channel at most poses
            if 2 * ks.len() > twin.poses.len() {
                let _ = write!(b, "<td>{}</td>", sig4(median(&mut ks)));
            } else {
                b.push_str("<td>—</td>");
            }
        }
        b.push_str("</tr>");
    }
    b.push_str("</table>");
    b
}

/// The FRF lines of a pose within its fitted band.
fn band_lines(p: &PoseModel) -> Vec<usize> {
    let f = &p.frf.freqs_hz;
    (0..f.len())
        .filter(|&k| f[k] >= p.band_hz[0] && f[k] <= p.band_hz[1] && f[k] > 0.0)
        .collect()
}

fn xscale(band: [f64; 2]) -> Scale {
    if band[0] > 0.0 && band[1] / band[0] >= 8.0 {
        Scale::Log
    } else {
        Scale::Lin
    }
}

/// How the report draws an FRF: the reader's choice (`mtwin identify --frf-plot`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FrfView {
    /// Magnitude on a log axis and phase (the Bode form: resonances and their width).
    MagPhase,
    /// Real and imaginary parts (the co-/quad-spectrum form: a mode's imaginary peak and
    /// its real part's zero crossing, the signs of the modal constants).
    ReIm,
    /// Both, with a switch at the top of the poses (about twice the size).
    Both,
}

/// The FRF of every channel of a pose, measured vs model, with the coherence: magnitude
/// \[µm/N\] and phase, or real and imaginary parts, or both (`view`).
fn pose_frfs(b: &mut String, i: usize, p: &PoseModel, view: FrfView) {
    let keep = band_lines(p);
    for ch in &p.frf.channels {
        let Some(ci) = p.model.channel_index(ch.channel) else {
            continue;
        };
        let fit = p
            .fit
            .iter()
            .find(|x| x.channel == ch.channel)
            .map_or(0.0, |x| x.fit_pct);
        let model = |f: f64| p.model.eval_hz(ci, f);
        channel_figures(
            b,
            &ChannelPlot {
                head: &format!("Pose {}: {} receptance", i + 1, ch.channel),
                fit_pct: Some(fit),
                freqs: &p.frf.freqs_hz,
                keep: &keep,
                ch,
                model: Some(&model),
                band: p.band_hz,
                view,
            },
        );
    }
}

/// One channel's FRF to draw: the measured lines `keep` of `freqs`, and the model when
/// there is one.
pub struct ChannelPlot<'a> {
    /// Start of the titles, e.g. `Pose 1: xx receptance`.
    pub head: &'a str,
    /// The model's fit to the measured FRF \[%\], said in the titles.
    pub fit_pct: Option<f64>,
    /// All frequency lines \[Hz\].
    pub freqs: &'a [f64],
    /// The lines drawn (positive frequencies within the band).
    pub keep: &'a [usize],
    /// The measured channel (receptance in m/N, coherence).
    pub ch: &'a FrfChannel,
    /// The model's receptance \[m/N\] at a frequency \[Hz\].
    pub model: Option<&'a dyn Fn(f64) -> Complex64>,
    /// The band drawn \[Hz\].
    pub band: [f64; 2],
    /// Magnitude and phase, real and imaginary parts, or both.
    pub view: FrfView,
}

/// One FRF figure (either view) into `b`: `panels`, then the coherence `coh` under them
/// when it was measured.
fn push_figure<'a>(
    b: &mut String,
    class: &str,
    title: &str,
    band: [f64; 2],
    xrange: Option<(f64, f64)>,
    mut panels: Vec<Panel<'a>>,
    coh: &'a [Series<'a>],
) {
    if coh.first().is_some_and(|s| !s.y.is_empty()) {
        panels.push(Panel {
            yrange: Some((0.0, 1.05)),
            ..Panel::new("coherence γ²", Scale::Lin, coh, 100)
        });
    }
    let svg = figure(&Figure {
        title,
        xlabel: "frequency [Hz]",
        xscale: xscale(band),
        xrange,
        width: 760,
        panels: &panels,
    });
    let _ = writeln!(b, "<div class=\"{class}\">{svg}</div>");
}

/// The figures of one channel (`c.view`), each in a `div` of class `magph` or `reim` (the
/// switch of [`FrfView::Both`] hides one class), with the coherence under the FRF.
pub fn channel_figures(b: &mut String, c: &ChannelPlot<'_>) {
    let ch = c.ch;
    let keep = c.keep;
    let fx_all: Vec<f64> = keep.iter().map(|&k| c.freqs[k]).collect();
    let xrange = |fx: &[f64]| Some((c.band[0].max(fx.first().copied().unwrap_or(1.0)), c.band[1]));
    let coherence = |sel: &[usize]| -> Vec<f64> {
        ch.coherence
            .as_ref()
            .map(|g| sel.iter().map(|&j| g[keep[j]]).collect())
            .unwrap_or_default()
    };
    // one line needs no legend
    let (lm, lf) = if c.model.is_some() {
        ("measured", "model")
    } else {
        ("", "")
    };
    let fit = c
        .fit_pct
        .map_or(String::new(), |f| format!(" (fit {f:.1} %)"));
    let eval = |fx: &[f64]| -> Vec<Complex64> {
        c.model
            .map(|m| fx.iter().map(|&x| m(x) * 1e6).collect())
            .unwrap_or_default()
    };
    if c.view != FrfView::ReIm {
        let meas_all: Vec<f64> = keep.iter().map(|&k| ch.h[k].norm() * 1e6).collect();
        let sel = thin(&fx_all, &meas_all, MAX_POINTS);
        let fx: Vec<f64> = sel.iter().map(|&j| fx_all[j]).collect();
        let meas_mag: Vec<f64> = sel.iter().map(|&j| meas_all[j]).collect();
        let meas_ph: Vec<f64> = sel
            .iter()
            .map(|&j| ch.h[keep[j]].arg() * 180.0 / PI)
            .collect();
        let model = eval(&fx);
        let mod_mag: Vec<f64> = model.iter().map(|v| v.norm()).collect();
        let mod_ph: Vec<f64> = model.iter().map(|v| v.arg() * 180.0 / PI).collect();
        let (px, mod_ph) = phase_breaks(&fx[..mod_ph.len()], &mod_ph);
        let mag = [line(lm, &fx, &meas_mag, 0), line(lf, &fx, &mod_mag, 1)];
        let ph = [
            Series {
                points: true,
                ..line("", &fx, &meas_ph, 0)
            },
            line("", &px, &mod_ph, 1),
        ];
        let coh = coherence(&sel);
        let coh_s = [line("", &fx, &coh, 2)];
        let n = if c.model.is_some() { 2 } else { 1 };
        let panels = vec![
            Panel::new("|H| [µm/N]", Scale::Log, &mag[..n], 250),
            Panel {
                yrange: Some((-190.0, 190.0)),
                ..Panel::new("phase [°]", Scale::Phase, &ph[..n], 140)
            },
        ];
        let title = if c.model.is_some() {
            format!("{}, measured vs model{fit}", c.head)
        } else {
            format!("{}, magnitude and phase", c.head)
        };
        push_figure(b, "magph", &title, c.band, xrange(&fx), panels, &coh_s);
    }
    if c.view != FrfView::MagPhase {
        // the extremes of both parts kept: a mode's imaginary peak and the real part's
        // two extremes either side of it
        let re_all: Vec<f64> = keep.iter().map(|&k| ch.h[k].re * 1e6).collect();
        let im_all: Vec<f64> = keep.iter().map(|&k| ch.h[k].im * 1e6).collect();
        let mut sel = thin(&fx_all, &re_all, MAX_POINTS / 2);
        sel.extend(thin(&fx_all, &im_all, MAX_POINTS / 2));
        sel.sort_unstable();
        sel.dedup();
        let fx: Vec<f64> = sel.iter().map(|&j| fx_all[j]).collect();
        let meas_re: Vec<f64> = sel.iter().map(|&j| re_all[j]).collect();
        let meas_im: Vec<f64> = sel.iter().map(|&j| im_all[j]).collect();
        let model = eval(&fx);
        let mod_re: Vec<f64> = model.iter().map(|v| v.re).collect();
        let mod_im: Vec<f64> = model.iter().map(|v| v.im).collect();
        let re = [line(lm, &fx, &meas_re, 0), line(lf, &fx, &mod_re, 1)];
        let im = [line("", &fx, &meas_im, 0), line("", &fx, &mod_im, 1)];
        let coh = coherence(&sel);
        let coh_s = [line("", &fx, &coh, 2)];
        let n = if c.model.is_some() { 2 } else { 1 };
        let panels = vec![
            Panel::new("Re H [µm/N]", Scale::Lin, &re[..n], 200),
            Panel::new("Im H [µm/N]", Scale::Lin, &im[..n], 200),
        ];
        let title = format!("{}, real and imaginary parts{fit}", c.head);
        push_figure(b, "reim", &title, c.band, xrange(&fx), panels, &coh_s);
    }
}

/// The switch between the two kinds of FRF figure of [`FrfView::Both`], without a
/// script: the checked radio button hides the other kind in the `div.poses` after it.
pub fn view_switch() -> &'static str {
    "<style>#frf-mp:checked~.poses .reim,#frf-ri:checked~.poses .magph\
     {display:none}</style><input type=\"radio\" name=\"frf-view\" id=\"frf-mp\" \
     checked><label for=\"frf-mp\">magnitude / phase</label> \
     <input type=\"radio\" name=\"frf-view\" id=\"frf-ri\"><label for=\"frf-ri\">\
     real / imaginary</label>"
}

/// A line of a plot.
fn line<'a>(label: &'a str, x: &'a [f64], y: &'a [f64], color: usize) -> Series<'a> {
    Series {
        label,
        x,
        y,
        color,
        points: false,
    }
}

/// Small multiples: the sum of the measured |H| over the channels and the model's, at
/// every pose, each linking to the pose's section.
fn small_multiples(twin: &Twin) -> String {
    let mut b = String::from("<div class=\"grid\">");
    for (i, p) in twin.poses.iter().enumerate() {
        let keep = band_lines(p);
        let fx_all: Vec<f64> = keep.iter().map(|&k| p.frf.freqs_hz[k]).collect();
        let meas_all: Vec<f64> = keep
            .iter()
            .map(|&k| p.frf.channels.iter().map(|c| c.h[k].norm()).sum::<f64>() * 1e6)
            .collect();
        let sel = thin(&fx_all, &meas_all, 200);
        let fx: Vec<f64> = sel.iter().map(|&j| fx_all[j]).collect();
        let meas: Vec<f64> = sel.iter().map(|&j| meas_all[j]).collect();
        let model: Vec<f64> = fx
            .iter()
            .map(|&f| {
                p.frf
                    .channels
                    .iter()
                    .filter_map(|c| p.model.channel_index(c.channel))
                    .map(|ci| p.model.eval_hz(ci, f).norm())
                    .sum::<f64>()
                    * 1e6
            })
            .collect();
        let s = [
            Series {
                label: "",
                x: &fx,
                y: &meas,
                color: 0,
                points: false,
            },
            Series {
                label: "",
                x: &fx,
                y: &model,
                color: 1,
                points: false,
            },
        ];
        let title = format!("{} {}", i + 1, PoseText(p.pose));
        let svg = figure(&Figure {
            title: &title,
            xlabel: "Hz",
            xscale: xscale(p.band_hz),
            xrange: None,
            width: 320,
            panels: &[Panel::new("Σ|H| [µm/N]", Scale::Log, &s, 170)],
        });
        let _ = write!(b, "<a href=\"#pose-{}\">{svg}</a>", i + 1);
    }
    b.push_str("</div>");
    b
}

/// Builds the report page; the FRFs drawn as `view` says.
pub fn identify_report(twin: &Twin, diagrams: &[StabilizationDiagram], view: FrfView) -> String {
    let mut b = String::new();
    let _ = writeln!(
        b,
        "<p>Twin <code>{}</code>: {}, channels {}, interpolation <b>{}</b>. \
         Receptance in µm/N; the model is the one stored in the twin (exponential-window \
         damping removed), the measured FRF is the estimate it was fitted to. Modes and \
         poses are numbered from 1.</p>",
        esc(&twin.name),
        identify::axis::count(twin.poses.len(), "pose"),
        twin.channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(", "),
        twin.interpolation.method
    );
    let _ = writeln!(
        b,
        "<p><b>Reading the fit.</b> The fit of a channel is measured against the <i>measured</i> \
         FRF, which carries the measurement noise: a model that matched the structure exactly \
         would still score below 100 %, at most what the noise allows (<i>noise allows</i>). \
         <i>noise-free est.</i> estimates the model's fit to the noise-free FRF (the misfit's \
         power less the noise's); it is the number to compare with a fit against a known \
         truth. A channel with little signal (often a cross channel, xy or yx) can fit its \
         measured FRF poorly even when the model is right: compare it with its noise limit.</p>"
    );
    if twin.poses.len() > 1 {
        let _ = writeln!(
            b,
            "<h2>Identified modes</h2><p>Over all {} poses (the modes of each pose, with modal \
             stiffness and mass per channel, are in its section below). k = ωn²/A and \
             m = 1/A, A the mode's modal constant in that channel: the single-degree-of-freedom \
             equivalent seen there; a negative value means the channel responds in antiphase; \
             — means the mode hardly moves that channel (modal constant below 5 % of the mode's \
             largest).</p>{}",
            twin.poses.len(),
            modes_summary(twin)
        );
    } else if let Some(p) = twin.poses.first() {
        let _ = writeln!(
            b,
            "<h2>Identified modes</h2>{}",
            modes_table(&p.model, p.band_hz)
        );
    }
    let _ = writeln!(
        b,
        "<h2>Poses</h2><p>Per channel: fit to the measured FRF, and under it in grey the \
         estimated fit to the noise-free FRF.</p><table><tr><th>pose</th><th>position</th>\
         <th>modes</th><th>order</th><th>band [Hz]</th>{}</tr>",
        twin.channels
            .iter()
            .map(|c| format!("<th>{c} [%]</th>"))
            .collect::<String>()
    );
    for (i, p) in twin.poses.iter().enumerate() {
        let _ = writeln!(
            b,
            "<tr><td><a href=\"#pose-{n}\">{n}</a></td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{:.0}–{:.0}</td>{}</tr>",
            PoseText(p.pose),
            p.order.modes,
            if p.order.automatic {
                "automatic"
            } else {
                "given"
            },
            p.band_hz[0],
            p.band_hz[1],
            twin.channels
                .iter()
                .map(|c| p.fit.iter().find(|f| f.channel == *c).map_or(
                    "<td>—</td>".to_string(),
                    |f| format!(
                        "<td>{:.1}<br><small>{}</small></td>",
                        f.fit_pct,
                        f.noise_free_fit_pct
                            .map_or("—".to_string(), |v| format!("{v:.1}"))
                    )
                ))
                .collect::<String>(),
            n = i + 1,
        );
    }
    let _ = writeln!(b, "</table>");
    if twin.poses.len() > 1 {
        let _ = writeln!(
            b,
            "<h2>All poses at a glance</h2><p>Sum of |H| over the channels, measured (black) and \
             model (red); click a pose for its FRFs, modes and stabilization diagram.</p>{}",
            small_multiples(twin)
        );
    }
    let loo = &twin.interpolation.leave_one_out;
    if !loo.is_empty() {
        let _ = writeln!(
            b,
            "<h2>Leave-one-pose-out</h2><p>Each measured pose predicted from the others \
             by the interpolation, scored against its measured FRF.</p><table>\
             <tr><th>pose</th><th>position</th><th>fit per channel</th></tr>"
        );
        for e in loo {
            // the pose's number as in the tables above
            let n = twin
                .poses
                .iter()
                .position(|p| p.pose == e.pose)
                .map_or("—".to_string(), |i| (i + 1).to_string());
            let _ = writeln!(
                b,
                "<tr><td>{n}</td><td>{}</td><td>{}</td></tr>",
                PoseText(e.pose),
                e.fit
                    .iter()
                    .map(|f| format!("{} {:.1} %", f.channel, f.fit_pct))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        let _ = writeln!(b, "</table>");
    }
    modes_across_workspace(&mut b, twin);
    every_pose(&mut b, twin, diagrams, view);
    page("mtwin identify", &b)
}

/// The tracked modes across the workspace (frequency, damping per pose).
fn modes_across_workspace(b: &mut String, twin: &Twin) {
    // modes across the workspace
    if twin.poses.len() > 1 {
        let idx: Vec<f64> = (1..=twin.poses.len()).map(|i| i as f64).collect();
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
        // a line and a dot per pose for each mode; the legend under the plot (inside, it
        // would hide the modes at the top)
        let series: Vec<Series<'_>> = (0..n_modes)
            .flat_map(|k| {
                [false, true].map(|points| Series {
                    label: "",
                    x: &idx,
                    y: &freqs[k],
                    color: k + 1,
                    points,
                })
            })
            .collect();
        let legend: Vec<(&str, usize)> = labels
            .iter()
            .enumerate()
            .map(|(k, l)| (l.as_str(), k + 1))
            .collect();
        let _ = writeln!(
            b,
            "<h2>Modes across the workspace</h2><p>Natural frequency of each tracked mode \
             at every measured pose (pose numbers as in the table).</p>{}",
            figure(&Figure {
                title: "Tracked modes",
                xlabel: "pose",
                xscale: Scale::Index,
                xrange: Some((0.5, twin.poses.len() as f64 + 0.5)),
                width: 760,
                panels: &[Panel::new(
                    "natural frequency [Hz]",
                    Scale::Log,
                    &series,
                    330
                )],
            }) + &legend_html(&legend)
        );
    }
}

/// Every pose in its own section: modes, FRFs with coherence, stabilization diagram.
fn every_pose(b: &mut String, twin: &Twin, diagrams: &[StabilizationDiagram], view: FrfView) {
    let _ = writeln!(
        b,
        "<h2>Every pose</h2><p>Open a pose for its modes, its FRFs with the coherence and its \
         stabilization diagram. The FRFs are drawn as {}.</p>",
        match view {
            FrfView::MagPhase =>
                "magnitude and phase (<code>--frf-plot re-im</code>: real and \
                                  imaginary parts; <code>both</code>: a switch)",
            FrfView::ReIm =>
                "real and imaginary parts (<code>--frf-plot mag-phase</code>: \
                              magnitude and phase; <code>both</code>: a switch)",
            FrfView::Both => "magnitude and phase or real and imaginary parts, as chosen here",
        }
    );
    if view == FrfView::Both {
        b.push_str(view_switch());
    }
    b.push_str("<div class=\"poses\">");
    for (i, p) in twin.poses.iter().enumerate() {
        let fits = p
            .fit
            .iter()
            .map(|f| format!("{} {:.1} %", f.channel, f.fit_pct))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            b,
            "<details id=\"pose-{n}\"{open}><summary><b>Pose {n}: {}</b> — {}; fit {}</summary>",
            PoseText(p.pose),
            identify::axis::count(p.model.modes.len(), "mode"),
            fits,
            n = i + 1,
            open = if i == 0 { " open" } else { "" }
        );
        let _ = writeln!(
            b,
            "<h3>Modes at pose {}</h3>{}<p>Fit per channel: {}.</p>",
            i + 1,
            if twin.poses.len() > 1 {
                modes_table(&p.model, p.band_hz)
            } else {
                "<p>(the table above)</p>".into()
            },
            p.fit.iter().map(fit_text).collect::<Vec<_>>().join("; ")
        );
        pose_frfs(b, i, p, view);
        if let Some(d) = diagrams.get(i) {
            let _ = writeln!(b, "{}", diagram_plot(i, d, p));
        }
        let _ = writeln!(b, "</details>");
    }
    b.push_str("</div>");
}

fn diagram_plot(i: usize, d: &StabilizationDiagram, p: &PoseModel) -> String {
    let band = p.band_hz;
    let (mut sx, mut sy, mut fx, mut fy, mut nx, mut ny) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for o in &d.orders {
        for pl in &o.poles {
            if pl.f_hz < band[0] || pl.f_hz > band[1] {
                continue;
            }
            let (x, y) = if pl.stable_freq && pl.stable_damping {
                (&mut sx, &mut sy)
            } else if pl.stable_freq {
                (&mut fx, &mut fy)
            } else {
                (&mut nx, &mut ny)
            };
            x.push(pl.f_hz);
            y.push(o.order as f64);
        }
    }
    // the modes the twin holds at this pose (the order search may add some to the
    // diagram's physical modes)
    let px: Vec<f64> = p
        .model
        .modes
        .iter()
        .map(|m| m.freq_hz())
        .filter(|f| *f >= band[0] && *f <= band[1])
        .collect();
    let top = d.orders.last().map_or(0.0, |o| o.order as f64) + 1.0;
    let py: Vec<f64> = vec![top; px.len()];
    let keep = band_lines(p);
    let f_all: Vec<f64> = keep.iter().map(|&k| p.frf.freqs_hz[k]).collect();
    let sum_all: Vec<f64> = keep
        .iter()
        .map(|&k| p.frf.channels.iter().map(|c| c.h[k].norm()).sum::<f64>() * 1e6)
        .collect();
    let sel = thin(&f_all, &sum_all, MAX_POINTS);
    let fs: Vec<f64> = sel.iter().map(|&j| f_all[j]).collect();
    let ms: Vec<f64> = sel.iter().map(|&j| sum_all[j]).collect();
    let lo = band[0].max(fs.first().copied().unwrap_or(1.0));
    format!(
        "<p>Stabilization diagram: poles per model order; \"stable\" = frequency and \
         damping agree with the previous order; the twin's modes at this pose are the \
         triangles on top; the grey line is the sum of the measured |H| over the channels.</p>{}",
        stabilization_figure(
            &format!("Pose {}: stabilization diagram over the FRF sum", i + 1),
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
                    label: "modes of the twin",
                    x: &px,
                    y: &py,
                    color: 1,
                    points: true
                },
            ],
            (&fs, &ms),
            "Σ|H| measured",
            "Σ|H| [µm/N]",
            (lo, band[1]),
        )
    )
}
