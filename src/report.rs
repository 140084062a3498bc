//! Self-contained HTML reports with SVG plots (plotters' SVG backend; no fonts, no
//! scripts, no network).

use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// One line of a plot.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// x values.
    pub x: &'a [f64],
    /// y values.
    pub y: &'a [f64],
    /// Colour index (0 = measured/black, 1 = model/red, 2 = blue, 3 = green).
    pub color: usize,
    /// Draw points instead of a line.
    pub points: bool,
}

fn color(i: usize) -> RGBColor {
    match i % 5 {
        0 => RGBColor(20, 20, 20),
        1 => RGBColor(214, 39, 40),
        2 => RGBColor(31, 119, 180),
        3 => RGBColor(44, 160, 44),
        _ => RGBColor(148, 103, 189),
    }
}

/// Axis scaling of a plot.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Lin,
    /// Logarithmic axis (values ≤ 0 are dropped).
    Log,
}

/// Tick label in engineering form: `1k`, `2.5k`, `500`, `0.02`, `3µ`; at most three
/// significant digits, no trailing zeros, so a tick reads as a person writes it.
pub fn eng(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { v.to_string() };
    }
    let a = v.abs();
    let (x, prefix) = match a {
        a if a >= 1e9 => (v / 1e9, "G"),
        a if a >= 1e6 => (v / 1e6, "M"),
        a if a >= 1e4 => (v / 1e3, "k"),
        // 1000..9999: `1k`, `2.5k`
        a if a >= 1e3 => (v / 1e3, "k"),
        a if a >= 1e-3 => (v, ""),
        a if a >= 1e-6 => (v * 1e6, "µ"),
        a if a >= 1e-9 => (v * 1e9, "n"),
        _ => (v * 1e12, "p"),
    };
    let decimals = (2 - x.abs().log10().floor() as i32).clamp(0, 6) as usize;
    let mut t = format!("{x:.decimals$}");
    if t.contains('.') {
        t = t.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if t == "-0" {
        t = "0".into();
    }
    format!("{t}{prefix}")
}

/// One panel of a [`Figure`]: its y axis and lines; panels share the x axis.
pub struct Panel<'a> {
    /// y-axis label with its unit.
    pub ylabel: &'a str,
    /// y scaling.
    pub yscale: Scale,
    /// The lines and points.
    pub series: &'a [Series<'a>],
    /// Fixed y range (`None`: from the data).
    pub yrange: Option<(f64, f64)>,
    /// Height in pixels.
    pub height: u32,
    /// A region shaded from the bottom of the panel up to this curve (x, y, label).
    pub shade: Option<(&'a [f64], &'a [f64], &'a str)>,
    /// Where the legend goes (upper right unless said).
    pub legend: SeriesLabelPosition,
}

impl<'a> Panel<'a> {
    /// A panel of `height` pixels with the y range from the data and no shading.
    pub fn new(ylabel: &'a str, yscale: Scale, series: &'a [Series<'a>], height: u32) -> Self {
        Panel {
            ylabel,
            yscale,
            series,
            yrange: None,
            height,
            shade: None,
            legend: SeriesLabelPosition::UpperRight,
        }
    }
}

/// Panels stacked over one shared x axis (e.g. magnitude, phase and coherence of an
/// FRF), with a title and an optional note under the title.
pub struct Figure<'a> {
    /// Title.
    pub title: &'a str,
    /// x-axis label with its unit.
    pub xlabel: &'a str,
    /// x scaling (log for FRFs that span decades).
    pub xscale: Scale,
    /// Fixed x range (`None`: from the data).
    pub xrange: Option<(f64, f64)>,
    /// Width in pixels.
    pub width: u32,
    /// The panels, top first.
    pub panels: &'a [Panel<'a>],
}

fn data_range<'a>(vals: impl Iterator<Item = &'a f64>, scale: Scale) -> Option<(f64, f64)> {
    let (lo, hi) = vals
        .copied()
        .filter(|v| v.is_finite() && (scale == Scale::Lin || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    (lo <= hi).then_some((lo, hi))
}

fn padded(r: (f64, f64), scale: Scale) -> (f64, f64) {
    let (mut lo, mut hi) = r;
    match scale {
        Scale::Log => {
            if hi <= lo * 1.01 {
                lo /= 2.0;
                hi *= 2.0;
            }
            (lo / 1.25, hi * 1.25)
        }
        Scale::Lin => {
            if hi == lo {
                let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
                lo -= d;
                hi += d;
            }
            let pad = 0.05 * (hi - lo);
            (lo - pad, hi + pad)
        }
    }
}

/// The tick formatter of an axis spanning `span`: engineering labels; ticks within a
/// billionth of the span of zero read `0`; on a log axis only the 1, 2 and 5 of each
/// decade are labelled (the other grid lines stay, unlabelled).
fn tick_formatter(span: f64, log: bool) -> impl Fn(&f64) -> String {
    // a log axis lists a decade's end and the next one's start: label it once
    let last = std::cell::RefCell::new(String::new());
    move |v: &f64| {
        if log {
            let e = v.abs().log10();
            let m = *v / 10f64.powf(e.round());
            let m = if (m - 1.0).abs() < 1e-6 {
                1.0
            } else {
                *v / 10f64.powf(e.floor())
            };
            if ![1.0, 2.0, 5.0].iter().any(|k| (m - k).abs() < 1e-6) {
                return String::new();
            }
            let t = eng(*v);
            if *last.borrow() == t {
                return String::new();
            }
            last.replace(t.clone());
            return t;
        } else if v.abs() < 1e-9 * span.abs() {
            return "0".into();
        }
        eng(*v)
    }
}

type Area<'b> = DrawingArea<SVGBackend<'b>, plotters::coord::Shift>;

/// Where a panel sits in its figure.
struct Place<'a> {
    xlabel: &'a str,
    /// The figure's title, on the top panel.
    caption: Option<&'a str>,
    /// The bottom panel carries the x label.
    bottom: bool,
    xlog: bool,
    ylog: bool,
}

fn draw_panel<'b, X, Y>(area: &Area<'b>, xr: X, yr: Y, panel: &Panel<'_>, place: Place<'_>)
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let Place {
        xlabel,
        caption,
        bottom,
        xlog,
        ylog,
    } = place;
    let (ylo, yhi) = (yr.range().start, yr.range().end);
    let xr_span = xr.range().end - xr.range().start;
    let mut cb = ChartBuilder::on(area);
    cb.margin_left(8)
        .margin_right(16)
        .margin_top(if caption.is_some() { 4 } else { 6 })
        .margin_bottom(2)
        .x_label_area_size(if bottom { 36 } else { 18 })
        .y_label_area_size(64);
    if let Some(c) = caption {
        cb.caption(c, ("sans-serif", 16));
    }
    let Ok(mut chart) = cb.build_cartesian_2d(xr, yr) else {
        return;
    };
    let xfmt = tick_formatter(xr_span, xlog);
    let yfmt = tick_formatter(yhi - ylo, ylog);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(panel.ylabel)
        .x_label_formatter(&xfmt)
        .y_label_formatter(&yfmt)
        .y_labels((panel.height as usize / 32).clamp(3, 10))
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .label_style(("sans-serif", 12));
    if xlog {
        mesh.x_labels(40).x_max_light_lines(0);
    }
    if ylog {
        mesh.y_labels(40).y_max_light_lines(0);
    }
    if bottom {
        mesh.x_desc(xlabel);
    }
    let _ = mesh.draw();
    let finite = |x: f64, y: f64| x.is_finite() && y.is_finite();
    if let Some((sx, sy, label)) = panel.shade {
        let mut pts: Vec<(f64, f64)> = sx
            .iter()
            .zip(sy)
            .filter(|(x, y)| finite(**x, **y))
            .map(|(x, y)| (*x, y.clamp(ylo, yhi)))
            .collect();
        if let (Some(first), Some(last)) = (pts.first().copied(), pts.last().copied()) {
            pts.push((last.0, ylo));
            pts.push((first.0, ylo));
            let c = RGBColor(200, 235, 200);
            let _ = chart
                .draw_series(std::iter::once(Polygon::new(pts, c.filled())))
                .map(|a| {
                    a.label(label).legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.filled())
                    })
                });
        }
    }
    let ok = |v: f64| v.is_finite() && (panel.yscale == Scale::Lin || v > 0.0);
    for s in panel.series {
        let c = color(s.color);
        let pts: Vec<(f64, f64)> =
            s.x.iter()
                .zip(s.y)
                .filter(|(x, y)| x.is_finite() && ok(**y))
                .map(|(x, y)| (*x, *y))
                .collect();
        if s.points {
            let _ = chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 2, c.filled())))
                .map(|a| {
                    a.label(s.label)
                        .legend(move |(x, y)| Circle::new((x + 10, y), 3, c.filled()))
                });
        } else {
            // a break in the data (a NaN or a value off a log axis) breaks the line
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for (x, y) in s.x.iter().zip(s.y) {
                if x.is_finite() && ok(*y) {
                    if let Some(r) = runs.last_mut() {
                        r.push((*x, y.clamp(ylo, yhi)));
                    }
                } else if runs.last().is_some_and(|r| !r.is_empty()) {
                    runs.push(Vec::new());
                }
            }
            let mut first = true;
            for run in runs.into_iter().filter(|r| !r.is_empty()) {
                let drawn = chart.draw_series(LineSeries::new(run, c.stroke_width(1)));
                if first {
                    let _ = drawn.map(|a| {
                        a.label(s.label).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                        })
                    });
                }
                first = false;
            }
        }
    }
    if panel.series.iter().any(|s| !s.label.is_empty()) || panel.shade.is_some() {
        let _ = chart
            .configure_series_labels()
            .position(panel.legend.clone())
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(150, 150, 150))
            .label_font(("sans-serif", 12))
            .draw();
    }
}

/// An SVG figure: panels over a shared x axis (linear or log), engineering tick labels.
pub fn figure(f: &Figure<'_>) -> String {
    let Some(xr) = f.xrange.or_else(|| {
        data_range(
            f.panels
                .iter()
                .flat_map(|p| p.series.iter().flat_map(|s| s.x.iter())),
            f.xscale,
        )
    }) else {
        return format!("<p>(no data for “{}”)</p>", esc(f.title));
    };
    let xr = if xr.1 > xr.0 {
        xr
    } else {
        padded(xr, f.xscale)
    };
    let height: u32 = f.panels.iter().map(|p| p.height).sum::<u32>() + 30;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (f.width, height)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let mut rest = root.clone();
        let n = f.panels.len();
        for (i, p) in f.panels.iter().enumerate() {
            let h = p.height + if i == 0 { 30 } else { 0 };
            let (area, below) = rest.split_vertically(h);
            rest = below;
            let yr = p.yrange.or_else(|| {
                data_range(p.series.iter().flat_map(|s| s.y.iter()), p.yscale)
                    .map(|r| padded(r, p.yscale))
            });
            let Some(yr) = yr else { continue };
            let caption = (i == 0).then_some(f.title);
            let bottom = i + 1 == n;
            match (f.xscale, p.yscale) {
                (Scale::Log, Scale::Log) => draw_panel(
                    &area,
                    LogCoord::from((xr.0..xr.1).log_scale()),
                    LogCoord::from((yr.0..yr.1).log_scale()),
                    p,
                    Place {
                        xlabel: f.xlabel,
                        caption,
                        bottom,
                        xlog: true,
                        ylog: true,
                    },
                ),
                (Scale::Log, Scale::Lin) => draw_panel(
                    &area,
                    LogCoord::from((xr.0..xr.1).log_scale()),
                    RangedCoordf64::from(yr.0..yr.1),
                    p,
                    Place {
                        xlabel: f.xlabel,
                        caption,
                        bottom,
                        xlog: true,
                        ylog: false,
                    },
                ),
                (Scale::Lin, Scale::Log) => draw_panel(
                    &area,
                    RangedCoordf64::from(xr.0..xr.1),
                    LogCoord::from((yr.0..yr.1).log_scale()),
                    p,
                    Place {
                        xlabel: f.xlabel,
                        caption,
                        bottom,
                        xlog: false,
                        ylog: true,
                    },
                ),
                (Scale::Lin, Scale::Lin) => draw_panel(
                    &area,
                    RangedCoordf64::from(xr.0..xr.1),
                    RangedCoordf64::from(yr.0..yr.1),
                    p,
                    Place {
                        xlabel: f.xlabel,
                        caption,
                        bottom,
                        xlog: false,
                        ylog: false,
                    },
                ),
            }
        }
        let _ = root.present();
    }
    svg
}

/// A stabilization diagram: the poles of each model order (points, left axis) over the
/// sum of the FRF magnitudes (grey line, right log axis), frequency on a log axis.
pub fn stabilization_figure(
    title: &str,
    poles: &[Series<'_>],
    frf: (&[f64], &[f64]),
    frf_label: &str,
    frf_ylabel: &str,
    xrange: (f64, f64),
) -> String {
    let top = poles
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .filter(|v| v.is_finite())
        .fold(1.0_f64, f64::max);
    let top = top * 1.05 + 2.0;
    let Some(mr) = data_range(frf.1.iter(), Scale::Log) else {
        return format!("<p>(no data for “{}”)</p>", esc(title));
    };
    let mr = padded(mr, Scale::Log);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 360)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let Ok(chart) = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .right_y_label_area_size(64)
            .build_cartesian_2d(
                LogCoord::from((xrange.0..xrange.1).log_scale()),
                RangedCoordf64::from(0.0..top),
            )
        else {
            return String::new();
        };
        let mut chart = chart.set_secondary_coord(
            LogCoord::from((xrange.0..xrange.1).log_scale()),
            LogCoord::from((mr.0..mr.1).log_scale()),
        );
        let _ = chart
            .configure_mesh()
            .x_desc("frequency [Hz]")
            .y_desc("model order")
            .x_label_formatter(&tick_formatter(xrange.1 - xrange.0, true))
            .y_label_formatter(&|v: &f64| eng(*v))
            .x_labels(40)
            .x_max_light_lines(0)
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215))
            .label_style(("sans-serif", 12))
            .draw();
        let _ = chart
            .configure_secondary_axes()
            .y_desc(frf_ylabel)
            .y_labels(40)
            .y_label_formatter(&tick_formatter(mr.1 - mr.0, true))
            .label_style(("sans-serif", 12))
            .draw();
        let grey = RGBColor(140, 140, 140);
        let line: Vec<(f64, f64)> = frf
            .0
            .iter()
            .zip(frf.1)
            .filter(|(x, y)| x.is_finite() && **y > 0.0)
            .map(|(x, y)| (*x, *y))
            .collect();
        let _ = chart
            .draw_secondary_series(LineSeries::new(line, grey.stroke_width(1)))
            .map(|a| {
                a.label(frf_label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey))
            });
        for s in poles {
            let c = color(s.color);
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(s.y)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (*x, *y))
                    .collect();
            let _ = chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 2, c.filled())))
                .map(|a| {
                    a.label(s.label)
                        .legend(move |(x, y)| Circle::new((x + 10, y), 3, c.filled()))
                });
        }
        let _ = root.present();
    }
    // the legend under the plot: inside, it would hide poles
    let mut legend = format!("<span style=\"color:#8c8c8c\">━</span> {} ", esc(frf_label));
    for s in poles {
        let RGBColor(r, g, b) = color(s.color);
        legend.push_str(&format!(
            "&nbsp; <span style=\"color:#{r:02x}{g:02x}{b:02x}\">●</span> {}",
            esc(s.label)
        ));
    }
    format!("{svg}<p class=\"legend\">{legend}</p>")
}

/// An SVG line plot (one panel, linear x).
pub fn plot(
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series<'_>],
    yscale: Scale,
) -> String {
    figure(&Figure {
        title,
        xlabel,
        xscale: Scale::Lin,
        xrange: None,
        width: 760,
        panels: &[Panel::new(ylabel, yscale, series, 300)],
    })
}

/// Indices of at most about `n` points of a curve that keep its shape: the x range cut
/// into `n / 2` buckets (log-spaced when x spans a decade or more), and in each bucket
/// the points of the lowest and highest y (so a resonance peak or an antiresonance is
/// never thinned away). All indices when the curve is short.
pub fn thin(x: &[f64], y: &[f64], n: usize) -> Vec<usize> {
    let len = x.len().min(y.len());
    if len <= n || n < 4 {
        return (0..len).collect();
    }
    let (x0, x1) = (x[0], x[len - 1]);
    let log = x0 > 0.0 && x1 / x0 >= 10.0;
    let pos = |v: f64| {
        if log {
            (v / x0).ln() / (x1 / x0).ln()
        } else {
            (v - x0) / (x1 - x0)
        }
    };
    let buckets = n / 2;
    let mut out = Vec::with_capacity(n + 2);
    let mut i = 0;
    while i < len {
        let b = ((pos(x[i]) * buckets as f64) as usize).min(buckets - 1);
        let mut j = i;
        let (mut lo, mut hi) = (i, i);
        while j < len && ((pos(x[j]) * buckets as f64) as usize).min(buckets - 1) == b {
            if y[j] < y[lo] {
                lo = j;
            }
            if y[j] > y[hi] {
                hi = j;
            }
            j += 1;
        }
        out.push(lo.min(hi));
        if lo != hi {
            out.push(lo.max(hi));
        }
        i = j;
    }
    out
}

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A complete self-contained HTML page.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\
         <style>body{{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}\
         th{{background:#f3f3f3}}code{{background:#f3f3f3;padding:1px 4px}}\
         .ok{{color:#2a7}}.bad{{color:#c33}}         .grid{{display:flex;flex-wrap:wrap;gap:4px}}.grid svg{{border:1px solid #eee}}         details{{margin:.6em 0;border-top:1px solid #ddd;padding-top:.4em}}summary{{cursor:pointer;font-size:1.05em}}         td small{{color:#666}}table.kv{{margin:0}}table.kv th,table.kv td{{text-align:left;border:none;border-bottom:1px solid #eee;padding:1px 6px}}table.kv th{{background:none;font-weight:normal;color:#555}}</style></head><body><h1>{t}</h1>\n{body}\n</body></html>\n",
        t = esc(title)
    )
}

#[cfg(test)]
mod tests {
    use super::eng;

    #[test]
    fn engineering_ticks_read_as_written() {
        assert_eq!(eng(0.0), "0");
        assert_eq!(eng(1000.0), "1k");
        assert_eq!(eng(2500.0), "2.5k");
        assert_eq!(eng(20000.0), "20k");
        assert_eq!(eng(500.0), "500");
        assert_eq!(eng(0.3000000004), "0.3");
        assert_eq!(eng(-180.0), "-180");
        assert_eq!(eng(0.01), "0.01");
        assert_eq!(eng(3e-6), "3µ");
        assert_eq!(eng(1.5e6), "1.5M");
    }

    #[test]
    fn thinning_keeps_the_peak() {
        let x: Vec<f64> = (1..=5000).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 1.0 / ((v - 1234.0).abs() + 0.1)).collect();
        let idx = super::thin(&x, &y, 300);
        assert!(idx.len() <= 302, "{}", idx.len());
        assert!(idx.contains(&1233), "the peak at x = 1234 was thinned away");
        assert!(idx.windows(2).all(|w| w[0] < w[1]));
    }
}
