//! Self-contained HTML reports with SVG plots (plotters' SVG backend; no fonts, no
//! scripts, no network).

pub mod diagnose;
pub mod identify;
pub mod refit;

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

/// Twenty-one distinguishable colours: black, the ten of matplotlib's `tab10` with red
/// first, then ten darker or purer hues unlike those (navy, maroon, teal, olive, magenta,
/// lime, gold, pure blue, periwinkle, dark green), so twenty tracked modes get twenty colours.
fn color(i: usize) -> RGBColor {
    match i % 21 {
        0 => RGBColor(20, 20, 20),
        1 => RGBColor(214, 39, 40),
        2 => RGBColor(31, 119, 180),
        3 => RGBColor(44, 160, 44),
        4 => RGBColor(148, 103, 189),
        5 => RGBColor(255, 127, 14),
        6 => RGBColor(140, 86, 75),
        7 => RGBColor(227, 119, 194),
        8 => RGBColor(188, 189, 34),
        9 => RGBColor(23, 190, 207),
        10 => RGBColor(127, 127, 127),
        11 => RGBColor(0, 0, 128),
        12 => RGBColor(128, 0, 0),
        13 => RGBColor(0, 128, 128),
        14 => RGBColor(128, 128, 0),
        15 => RGBColor(255, 0, 255),
        16 => RGBColor(0, 210, 0),
        17 => RGBColor(255, 215, 0),
        18 => RGBColor(0, 0, 255),
        19 => RGBColor(96, 96, 255),
        _ => RGBColor(0, 90, 0),
    }
}

/// Axis scaling of a plot.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Lin,
    /// Logarithmic axis (values ≤ 0 are dropped).
    Log,
    /// A phase in degrees: linear, ticks at the multiples of 90°, grid at 45°.
    Phase,
    /// Counting numbers (pose, history entry): linear, ticks only at whole numbers.
    Index,
}

/// A linear axis with ticks at the multiples of a step: for counting numbers (pose,
/// history entry) every 1, 2, 5, 10, ... as room allows; for a phase in degrees every
/// 90° (bold, labelled) with light lines every 45°.
struct StepCoord {
    r: RangedCoordf64,
    phase: bool,
}

impl StepCoord {
    /// Counting numbers: ticks only at whole numbers.
    fn index(r: RangedCoordf64) -> Self {
        StepCoord { r, phase: false }
    }

    /// A phase in degrees.
    fn phase(r: RangedCoordf64) -> Self {
        StepCoord { r, phase: true }
    }
}

impl Ranged for StepCoord {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;
    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        self.r.map(v, limit)
    }
    fn key_points<H: plotters::coord::ranged1d::KeyPointHint>(&self, hint: H) -> Vec<f64> {
        let r = self.r.range();
        let step = if self.phase {
            if hint.max_num_points() > 12 {
                45.0
            } else {
                90.0
            }
        } else {
            let n = hint.max_num_points().max(1) as f64;
            [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
                .into_iter()
                .find(|s| (r.end - r.start) / s <= n)
                .unwrap_or(200.0)
        };
        let mut v = (r.start / step).ceil() * step;
        let mut out = Vec::new();
        while v <= r.end + 1e-9 {
            out.push(v);
            v += step;
        }
        out
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.r.range()
    }
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

/// `m·10ⁿ` with a superscript exponent (`10⁻⁴` when `m` is 1).
fn pow10(m: f64, n: i32) -> String {
    let sup: String = n
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect();
    if (m - 1.0).abs() < 1e-6 {
        format!("10{sup}")
    } else {
        format!("{}·10{sup}", m.round())
    }
}

/// A phase curve (degrees) with a break where it wraps (a jump of more than 180°
/// between neighbours), so no vertical line joins +180° and −180°.
pub fn phase_breaks(x: &[f64], ph: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut bx, mut by) = (Vec::with_capacity(x.len()), Vec::with_capacity(x.len()));
    for (i, (&xi, &yi)) in x.iter().zip(ph).enumerate() {
        if i > 0 && (yi - ph[i - 1]).abs() > 180.0 {
            bx.push(0.5 * (xi + x[i - 1]));
            by.push(f64::NAN);
        }
        bx.push(xi);
        by.push(yi);
    }
    (bx, by)
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
        .filter(|v| v.is_finite() && (scale != Scale::Log || *v > 0.0))
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
        Scale::Lin | Scale::Phase | Scale::Index => {
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
            let (m, n) = if (m - 1.0).abs() < 1e-6 {
                (1.0, e.round())
            } else {
                (*v / 10f64.powf(e.floor()), e.floor())
            };
            if ![1.0, 2.0, 5.0].iter().any(|k| (m - k).abs() < 1e-6) {
                return String::new();
            }
            let t = if *v < 1e-3 {
                // `2·10⁻⁴`, not `200µ`: the unit (µm/N) has its prefix already
                pow10(m, n as i32)
            } else {
                eng(*v)
            };
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

/// A polyline with breaks (`None`) cut to the y range `[lo, hi]`: each segment that
/// leaves the range ends at the frame (found on the axes' own scales, so the cut point
/// lies on the drawn segment) and the line resumes where it comes back; a line never
/// runs flat along the frame as if the data were there.
fn clip_to_y(
    pts: &[Option<(f64, f64)>],
    (lo, hi): (f64, f64),
    xlog: bool,
    ylog: bool,
) -> Vec<Vec<(f64, f64)>> {
    let fwd = |v: f64, log: bool| if log { v.ln() } else { v };
    let back = |v: f64, log: bool| if log { v.exp() } else { v };
    let (tlo, thi) = (fwd(lo, ylog), fwd(hi, ylog));
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    let push = |runs: &mut Vec<Vec<(f64, f64)>>, p: (f64, f64)| {
        if let Some(r) = runs.last_mut() {
            if r.last() != Some(&p) {
                r.push(p);
            }
        }
    };
    let brk = |runs: &mut Vec<Vec<(f64, f64)>>| {
        if runs.last().is_some_and(|r| !r.is_empty()) {
            runs.push(Vec::new());
        }
    };
    let mut prev: Option<(f64, f64)> = None;
    for p in pts {
        let Some((x1, y1)) = *p else {
            brk(&mut runs);
            prev = None;
            continue;
        };
        let (tx1, ty1) = (fwd(x1, xlog), fwd(y1, ylog));
        match prev {
            None => {
                if (tlo..=thi).contains(&ty1) {
                    push(&mut runs, (x1, y1));
                }
            }
            Some((tx0, ty0)) => {
                // the part of the segment inside [tlo, thi] (Liang–Barsky in y)
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let dy = ty1 - ty0;
                let mut inside = true;
                for (q, r) in [(-dy, ty0 - tlo), (dy, thi - ty0)] {
                    if q == 0.0 {
                        if r < 0.0 {
                            inside = false;
                        }
                    } else {
                        let t = r / q;
                        if q < 0.0 {
                            t0 = t0.max(t);
                        } else {
                            t1 = t1.min(t);
                        }
                    }
                }
                if inside && t0 <= t1 {
                    let at = |t: f64| {
                        (
                            back(tx0 + t * (tx1 - tx0), xlog),
                            back(ty0 + t * dy, ylog).clamp(lo, hi),
                        )
                    };
                    if t0 > 0.0 {
                        brk(&mut runs);
                    }
                    push(&mut runs, at(t0));
                    push(&mut runs, if t1 < 1.0 { at(t1) } else { (x1, y1) });
                    if t1 < 1.0 {
                        brk(&mut runs);
                    }
                } else {
                    brk(&mut runs);
                }
            }
        }
        prev = Some((tx1, ty1));
    }
    runs.retain(|r| !r.is_empty());
    runs
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
        cb.caption(c, ("sans-serif", 18));
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
        .label_style(("sans-serif", 14));
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
            let c = SHADE;
            let _ = chart
                .draw_series(std::iter::once(Polygon::new(pts, c.filled())))
                .map(|a| {
                    a.label(label).legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.filled())
                    })
                });
        }
    }
    let ok = |v: f64| v.is_finite() && (panel.yscale != Scale::Log || v > 0.0);
    for s in panel.series {
        let c = color(s.color);
        let pts: Vec<(f64, f64)> =
            s.x.iter()
                .zip(s.y)
                .filter(|(x, y)| x.is_finite() && ok(**y))
                .map(|(x, y)| (*x, *y))
                .collect();
        if s.points {
            let drawn = chart.draw_series(pts.iter().map(|p| Circle::new(*p, 2, c.filled())));
            if !s.label.is_empty() {
                let _ = drawn.map(|a| {
                    a.label(s.label)
                        .legend(move |(x, y)| Circle::new((x + 10, y), 3, c.filled()))
                });
            }
        } else {
            // a break in the data (a NaN or a value off a log axis) breaks the line; a
            // line that leaves the y range is cut at the frame
            let pts: Vec<Option<(f64, f64)>> =
                s.x.iter()
                    .zip(s.y)
                    .map(|(x, y)| (x.is_finite() && ok(*y)).then_some((*x, *y)))
                    .collect();
            let runs = clip_to_y(&pts, (ylo, yhi), xlog, ylog);
            let mut first = true;
            for run in runs.into_iter().filter(|r| !r.is_empty()) {
                let drawn = chart.draw_series(LineSeries::new(run, c.stroke_width(1)));
                if first && !s.label.is_empty() {
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
}

/// Draws a panel on the x axis `xr` with the y axis its scale asks for.
fn panel_with_y<X>(area: &Area<'_>, xr: X, yr: (f64, f64), p: &Panel<'_>, place: Place<'_>)
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    match p.yscale {
        Scale::Log => draw_panel(area, xr, LogCoord::from((yr.0..yr.1).log_scale()), p, place),
        Scale::Lin => draw_panel(area, xr, RangedCoordf64::from(yr.0..yr.1), p, place),
        Scale::Index => draw_panel(
            area,
            xr,
            StepCoord::index(RangedCoordf64::from(yr.0..yr.1)),
            p,
            place,
        ),
        Scale::Phase => draw_panel(
            area,
            xr,
            StepCoord::phase(RangedCoordf64::from(yr.0..yr.1)),
            p,
            place,
        ),
    }
}

/// An SVG figure: panels over a shared x axis (linear or log), engineering tick labels,
/// the legend in rows under the plot (inside a panel it would cover data).
pub fn figure(f: &Figure<'_>) -> String {
    draw_figure(f)
}

/// The legend entries of a figure's panels: shading first, then the labelled lines, each
/// label once (a line in the magnitude and the phase panel is one entry).
fn legend_entries<'a>(f: &'a Figure<'a>) -> Vec<(&'a str, LegendMark)> {
    let mut out: Vec<(&'a str, LegendMark)> = Vec::new();
    for p in f.panels {
        if let Some((_, _, label)) = p.shade {
            out.push((label, LegendMark::Shade));
        }
        for s in p.series.iter().filter(|s| !s.label.is_empty()) {
            if out.iter().any(|(l, _)| *l == s.label) {
                continue;
            }
            out.push((
                s.label,
                if s.points {
                    LegendMark::Dot(s.color)
                } else {
                    LegendMark::Line(s.color)
                },
            ));
        }
    }
    out
}

#[derive(Clone, Copy)]
enum LegendMark {
    Shade,
    Line(usize),
    Dot(usize),
}

/// The shading colour of a panel's region.
const SHADE: RGBColor = RGBColor(200, 235, 200);

fn draw_figure(f: &Figure<'_>) -> String {
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
    // the legend's rows: entries left to right, a new row where the next would pass the
    // right edge (14 px sans-serif: ~7 px a letter)
    let entries = legend_entries(f);
    let mut placed: Vec<(i32, u32)> = Vec::new();
    let (mut x, mut row) = (80i32, 0u32);
    for (label, _) in &entries {
        let w = 26 + (label.chars().count() as f64 * 6.8) as i32 + 28;
        if x + w > f.width as i32 - 8 && x > 80 {
            (x, row) = (80, row + 1);
        }
        placed.push((x, row));
        x += w;
    }
    let legend_h: u32 = if entries.is_empty() {
        0
    } else {
        22 * (row + 1) + 4
    };
    let height: u32 = f.panels.iter().map(|p| p.height).sum::<u32>() + 30 + legend_h;
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
            let place = Place {
                xlabel: f.xlabel,
                caption,
                bottom,
                xlog: f.xscale == Scale::Log,
                ylog: p.yscale == Scale::Log,
            };
            match f.xscale {
                Scale::Log => {
                    let xr = LogCoord::from((xr.0..xr.1).log_scale());
                    panel_with_y(&area, xr, yr, p, place)
                }
                Scale::Index => {
                    let xr = StepCoord::index(RangedCoordf64::from(xr.0..xr.1));
                    panel_with_y(&area, xr, yr, p, place)
                }
                _ => panel_with_y(&area, RangedCoordf64::from(xr.0..xr.1), yr, p, place),
            }
        }
        let top = (height - legend_h) as i32;
        for ((label, mark), (x, row)) in entries.iter().zip(&placed) {
            let y = top + 13 + 22 * *row as i32;
            let x = *x;
            match *mark {
                LegendMark::Shade => {
                    let _ = root.draw(&Rectangle::new(
                        [(x, y - 6), (x + 20, y + 6)],
                        SHADE.filled(),
                    ));
                }
                LegendMark::Line(c) => {
                    let _ = root.draw(&PathElement::new(
                        vec![(x, y), (x + 20, y)],
                        color(c).stroke_width(2),
                    ));
                }
                LegendMark::Dot(c) => {
                    let _ = root.draw(&Circle::new((x + 10, y), 3, color(c).filled()));
                }
            }
            let style = ("sans-serif", 14).into_font().color(&BLACK);
            let _ = root.draw(&Text::new(label.to_string(), (x + 26, y - 8), style));
        }
        let _ = root.present();
    }
    compact_svg(&svg)
}

/// A stabilization diagram: the poles of each model order (points, left axis) over the
/// sum of the FRF magnitudes (grey line, right log axis), frequency on a log axis. The
/// last set of `poles` (the modes chosen) is drawn as larger triangles.
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
            .caption(title, ("sans-serif", 18))
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
            .label_style(("sans-serif", 14))
            .draw();
        let _ = chart
            .configure_secondary_axes()
            .y_desc(frf_ylabel)
            .y_labels(40)
            .y_label_formatter(&tick_formatter(mr.1 - mr.0, true))
            .label_style(("sans-serif", 14))
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
        for (k, s) in poles.iter().enumerate() {
            let c = color(s.color);
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(s.y)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (*x, *y))
                    .collect();
            // the last set (the modes chosen) as larger triangles over the columns
            let size = if k + 1 == poles.len() { 5 } else { 2 };
            let _ = if size > 2 {
                chart.draw_series(
                    pts.iter()
                        .map(|p| TriangleMarker::new(*p, size, c.filled())),
                )
            } else {
                chart.draw_series(pts.iter().map(|p| Circle::new(*p, size, c.filled())))
            };
        }
        let _ = root.present();
    }
    // the legend under the plot: inside, it would hide poles
    let mut legend = format!("<span style=\"color:#8c8c8c\">━</span> {} ", esc(frf_label));
    for (k, s) in poles.iter().enumerate() {
        let RGBColor(r, g, b) = color(s.color);
        legend.push_str(&format!(
            "&nbsp; <span style=\"color:#{r:02x}{g:02x}{b:02x}\">{}</span> {}",
            if k + 1 == poles.len() { "▲" } else { "●" },
            esc(s.label)
        ));
    }
    format!("{}<p class=\"legend\">{legend}</p>", compact_svg(&svg))
}

/// A legend under a figure, as HTML: a coloured line and the label per entry (label,
/// colour index as in [`Series::color`]). For plots whose lines fill the whole area.
pub fn legend_html(items: &[(&str, usize)]) -> String {
    let mut legend = String::from("<p class=\"legend\">");
    for (i, (label, c)) in items.iter().enumerate() {
        let RGBColor(r, g, b) = color(*c);
        if i > 0 {
            legend.push_str(" &nbsp; ");
        }
        legend.push_str(&format!(
            "<span style=\"color:#{r:02x}{g:02x}{b:02x}\">━●</span> {}",
            esc(label)
        ));
    }
    legend.push_str("</p>");
    legend
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

/// The attributes of one SVG tag, in order.
fn attrs(tag: &str) -> Vec<(&str, &str)> {
    let mut out = Vec::new();
    // past the tag's name
    let mut rest = tag.split_once(char::is_whitespace).map_or("", |(_, r)| r);
    while let Some(eq) = rest.find("=\"") {
        let name = rest[..eq].trim();
        let Some(end) = rest[eq + 2..].find('"') else {
            break;
        };
        out.push((name, &rest[eq + 2..eq + 2 + end]));
        rest = &rest[eq + 3 + end..];
    }
    out
}

fn attr<'a>(a: &[(&str, &'a str)], name: &str) -> &'a str {
    a.iter().find(|(n, _)| *n == name).map_or("", |(_, v)| v)
}

/// Appends `dx dy` to a relative path command: separators only where a sign does not
/// separate the numbers already.
fn push_pair(d: &mut String, dx: i64, dy: i64, first: bool) {
    use std::fmt::Write as _;
    if !first && dx >= 0 {
        d.push(' ');
    }
    let _ = write!(d, "{dx}");
    if dy >= 0 {
        d.push(' ');
    }
    let _ = write!(d, "{dy}");
}

/// The same picture in a fraction of the bytes: plotters writes one element per grid
/// line, one `<circle>` per point and absolute polylines; runs of lines, points and
/// polylines of one style become one `<path>` each (points as round dots of the same
/// diameter, polylines in relative coordinates), default attributes and empty labels
/// go, and font sizes are rounded. An 18-pose identify report shrinks about 4×.
pub fn compact_svg(svg: &str) -> String {
    use std::fmt::Write as _;
    #[derive(PartialEq)]
    enum Kind {
        None,
        /// colour and diameter of round dots
        Dots(String, String),
        Lines(String, String),
        Poly(String, String),
    }
    let mut out = String::with_capacity(svg.len() / 3);
    let mut kind = Kind::None;
    let mut d = String::new();
    let mut last_dot: Option<(i64, i64)> = None;
    let mut texts = String::new();
    let flush = |out: &mut String, kind: &mut Kind, d: &mut String, texts: &mut String| {
        match kind {
            Kind::None => {}
            Kind::Dots(c, r) => {
                let _ = write!(
                    out,
                    "<path d=\"{d}\" stroke=\"{c}\" stroke-width=\"{r}\" \
                     stroke-linecap=\"round\" fill=\"none\"/>"
                );
            }
            Kind::Lines(c, w) | Kind::Poly(c, w) => {
                let _ = write!(
                    out,
                    "<path d=\"{d}\" stroke=\"{c}\" stroke-width=\"{w}\" fill=\"none\"/>"
                );
            }
        }
        *kind = Kind::None;
        d.clear();
        out.push_str(texts);
        texts.clear();
    };
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        let between = rest[..i].trim();
        if !between.is_empty() {
            flush(&mut out, &mut kind, &mut d, &mut texts);
            out.push_str(between);
        }
        let Some(j) = rest[i..].find('>') else {
            break;
        };
        let tag = &rest[i..i + j + 1];
        rest = &rest[i + j + 1..];
        let name = tag[1..]
            .split(|c: char| c.is_whitespace() || c == '/' || c == '>')
            .next()
            .unwrap_or("");
        let a = attrs(tag);
        let num = |n: &str| attr(&a, n).parse::<i64>().ok();
        let opaque = matches!(attr(&a, "opacity"), "" | "1");
        match name {
            "circle" if opaque && attr(&a, "stroke") == "none" => {
                let (Some(cx), Some(cy), Some(r)) = (num("cx"), num("cy"), num("r")) else {
                    out.push_str(tag);
                    continue;
                };
                let k = Kind::Dots(attr(&a, "fill").to_string(), (2 * r).to_string());
                if k != kind {
                    flush(&mut out, &mut kind, &mut d, &mut texts);
                    kind = k;
                }
                match last_dot {
                    Some((x, y)) if !d.is_empty() => {
                        d.push('m');
                        push_pair(&mut d, cx - x, cy - y, true);
                        d.push_str("h0");
                    }
                    _ => {
                        let _ = write!(d, "M{cx} {cy}h0");
                    }
                }
                last_dot = Some((cx, cy));
            }
            "line" if opaque => {
                let (Some(x1), Some(y1), Some(x2), Some(y2)) =
                    (num("x1"), num("y1"), num("x2"), num("y2"))
                else {
                    out.push_str(tag);
                    continue;
                };
                let k = Kind::Lines(
                    attr(&a, "stroke").to_string(),
                    attr(&a, "stroke-width").to_string(),
                );
                if k != kind {
                    flush(&mut out, &mut kind, &mut d, &mut texts);
                    kind = k;
                }
                let _ = write!(d, "M{x1} {y1}");
                if x1 == x2 {
                    let _ = write!(d, "V{y2}");
                } else if y1 == y2 {
                    let _ = write!(d, "H{x2}");
                } else {
                    let _ = write!(d, "L{x2} {y2}");
                }
            }
            "polyline" if opaque => {
                let pts: Vec<(i64, i64)> = attr(&a, "points")
                    .split_whitespace()
                    .filter_map(|p| {
                        let (x, y) = p.split_once(',')?;
                        Some((x.parse().ok()?, y.parse().ok()?))
                    })
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let k = Kind::Poly(
                    attr(&a, "stroke").to_string(),
                    attr(&a, "stroke-width").to_string(),
                );
                if k != kind {
                    flush(&mut out, &mut kind, &mut d, &mut texts);
                    kind = k;
                }
                let _ = write!(d, "M{} {}", pts[0].0, pts[0].1);
                let mut first = true;
                let mut last = pts[0];
                for &p in &pts[1..] {
                    if p == last {
                        continue;
                    }
                    if first {
                        d.push('l');
                    }
                    push_pair(&mut d, p.0 - last.0, p.1 - last.1, first);
                    first = false;
                    last = p;
                }
                if first {
                    // a single point: a dot as long as the line is wide
                    d.push_str("h0");
                }
            }
            "text" => {
                // a label does not break a run (plotters draws a tick, its label, the
                // next tick...): it is drawn after the run, on top
                let Some(k) = rest.find("</text>") else {
                    out.push_str(tag);
                    continue;
                };
                let content = rest[..k].trim();
                rest = &rest[k + 7..];
                if content.is_empty() {
                    continue;
                }
                let t = if kind == Kind::None {
                    &mut out
                } else {
                    &mut texts
                };
                t.push_str("<text");
                for (n, v) in &a {
                    match (*n, *v) {
                        ("opacity", "1") | ("fill", "#000000") | ("font-family", "sans-serif") => {}
                        ("font-size", v) => {
                            let size = v.parse::<f64>().unwrap_or(12.0);
                            let _ = write!(t, " font-size=\"{size:.1}\"");
                        }
                        (n, v) => {
                            let _ = write!(t, " {n}=\"{v}\"");
                        }
                    }
                }
                let _ = write!(t, ">{content}</text>");
            }
            "svg" => {
                flush(&mut out, &mut kind, &mut d, &mut texts);
                // the labels' font, said once
                out.push_str(&tag.replacen("<svg", "<svg font-family=\"sans-serif\"", 1));
            }
            _ => {
                flush(&mut out, &mut kind, &mut d, &mut texts);
                out.push_str(&tag.replace(" opacity=\"1\"", ""));
            }
        }
        if name == "svg" {
            out.push('\n');
        }
    }
    flush(&mut out, &mut kind, &mut d, &mut texts);
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
    use super::{clip_to_y, eng};

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
    fn compacted_svg_draws_the_same_elements() {
        let svg = "<svg width=\"10\" height=\"10\" xmlns=\"http://www.w3.org/2000/svg\">\n\
            <line opacity=\"1\" stroke=\"#D7D7D7\" stroke-width=\"1\" x1=\"5\" y1=\"9\" x2=\"5\" y2=\"1\"/>\n\
            <line opacity=\"1\" stroke=\"#D7D7D7\" stroke-width=\"1\" x1=\"1\" y1=\"4\" x2=\"9\" y2=\"4\"/>\n\
            <polyline fill=\"none\" opacity=\"1\" stroke=\"#000000\" stroke-width=\"1\" points=\"1,1 2,1 2,1 4,3 \"/>\n\
            <text x=\"1\" y=\"2\" font-family=\"sans-serif\" font-size=\"11.29032258\" opacity=\"1\" fill=\"#000000\">\n100\n</text>\n\
            <text x=\"1\" y=\"3\" font-size=\"11.29032258\">\n\n</text>\n\
            <polyline fill=\"none\" opacity=\"1\" stroke=\"#000000\" stroke-width=\"1\" points=\"6,6 3,8 \"/>\n\
            <circle cx=\"3\" cy=\"4\" r=\"2\" opacity=\"1\" fill=\"#141414\" stroke=\"none\" stroke-width=\"1\"/>\n\
            <circle cx=\"5\" cy=\"2\" r=\"2\" opacity=\"1\" fill=\"#141414\" stroke=\"none\" stroke-width=\"1\"/>\n\
            </svg>\n";
        let c = super::compact_svg(svg);
        assert_eq!(
            c,
            "<svg font-family=\"sans-serif\" width=\"10\" height=\"10\" \
             xmlns=\"http://www.w3.org/2000/svg\">\n\
             <path d=\"M5 9V1M1 4H9\" stroke=\"#D7D7D7\" stroke-width=\"1\" fill=\"none\"/>\
             <path d=\"M1 1l1 0 2 2M6 6l-3 2\" stroke=\"#000000\" stroke-width=\"1\" fill=\"none\"/>\
             <text x=\"1\" y=\"2\" font-size=\"11.3\">100</text>\
             <path d=\"M3 4h0m2-2h0\" stroke=\"#141414\" stroke-width=\"4\" \
             stroke-linecap=\"round\" fill=\"none\"/></svg>"
        );
    }

    #[test]
    fn phase_ticks_at_90_degrees_and_index_ticks_whole() {
        use plotters::coord::ranged1d::{BoldPoints, Ranged};
        use plotters::coord::types::RangedCoordf64;
        let ph = super::StepCoord::phase(RangedCoordf64::from(-190.0..190.0));
        assert_eq!(
            ph.key_points(BoldPoints(4)),
            vec![-180.0, -90.0, 0.0, 90.0, 180.0]
        );
        let ix = super::StepCoord::index(RangedCoordf64::from(0.5..18.5));
        let k = ix.key_points(BoldPoints(10));
        assert_eq!(k.first(), Some(&2.0));
        assert!(k.iter().all(|v| v.fract() == 0.0), "{k:?}");
        let ix = super::StepCoord::index(RangedCoordf64::from(0.8..2.2));
        assert_eq!(ix.key_points(BoldPoints(10)), vec![1.0, 2.0]);
    }

    #[test]
    fn small_log_ticks_read_as_powers_of_ten() {
        let f = super::tick_formatter(1.0, true);
        assert_eq!(f(&2e-4), "2·10⁻⁴");
        assert_eq!(f(&1e-4), "10⁻⁴");
        assert_eq!(f(&5e-5), "5·10⁻⁵");
        assert_eq!(f(&0.002), "0.002");
        assert_eq!(f(&3e-4), "", "only 1, 2 and 5 of a decade are labelled");
        assert_eq!(f(&2000.0), "2k");
    }

    #[test]
    fn a_wrapping_phase_breaks_its_line() {
        let (x, y) = super::phase_breaks(&[1.0, 2.0, 3.0, 4.0], &[-170.0, -179.0, 178.0, 170.0]);
        assert_eq!(x.len(), 5);
        assert!(y[2].is_nan() && x[2] == 2.5, "{x:?} {y:?}");
        assert_eq!(y[3], 178.0);
    }

    #[test]
    fn a_line_leaving_the_range_is_cut_at_the_frame() {
        let p = |x: f64, y: f64| Some((x, y));
        // up through the top at x = 1.5, back in at x = 3.5: two runs, cut at y = 10
        let runs = clip_to_y(
            &[
                p(0.0, 0.0),
                p(1.0, 5.0),
                p(2.0, 15.0),
                p(3.0, 15.0),
                p(4.0, 5.0),
            ],
            (0.0, 10.0),
            false,
            false,
        );
        assert_eq!(
            runs,
            vec![
                vec![(0.0, 0.0), (1.0, 5.0), (1.5, 10.0)],
                vec![(3.5, 10.0), (4.0, 5.0)]
            ]
        );
        // a break stays a break; a point alone above the range draws nothing
        let runs = clip_to_y(
            &[p(0.0, 1.0), None, p(1.0, 20.0)],
            (0.0, 10.0),
            false,
            false,
        );
        assert_eq!(runs, vec![vec![(0.0, 1.0)]]);
        // on a log y axis the cut lies on the drawn (straight in log) segment: 1 -> 100
        // leaves a range up to 10 half way
        let runs = clip_to_y(&[p(0.0, 1.0), p(2.0, 100.0)], (0.5, 10.0), false, true);
        assert_eq!(runs.len(), 1);
        let (x, y) = runs[0][1];
        assert!(
            (x - 1.0).abs() < 1e-12 && (y - 10.0).abs() < 1e-9,
            "{runs:?}"
        );
    }

    #[test]
    fn twenty_tracked_modes_get_twenty_colours() {
        // modes k = 0..20 are drawn in colour k + 1; black (0) is the measured FRF
        let c: Vec<_> = (0..=20).map(super::color).collect();
        for i in 0..c.len() {
            for j in 0..i {
                let (a, b) = (c[i], c[j]);
                let d = (a.0 as i32 - b.0 as i32).abs()
                    + (a.1 as i32 - b.1 as i32).abs()
                    + (a.2 as i32 - b.2 as i32).abs();
                assert!(d > 60, "colours {j} and {i} alike: {b:?} {a:?}");
            }
        }
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
