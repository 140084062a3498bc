//! Self-contained HTML reports with SVG plots (plotters' SVG backend; no fonts, no
//! scripts, no network).

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

/// An SVG line plot.
pub fn plot(
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series<'_>],
    yscale: Scale,
) -> String {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 330)).into_drawing_area();
        let _ = root.fill(&WHITE);
        let ok = |v: f64| v.is_finite() && (yscale == Scale::Lin || v > 0.0);
        let xs = series
            .iter()
            .flat_map(|s| s.x.iter().copied())
            .filter(|v| v.is_finite());
        let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        let ys = series
            .iter()
            .flat_map(|s| s.y.iter().copied())
            .filter(|v| ok(*v));
        let (mut y0, mut y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if !(x0 < x1) || !(y0 <= y1) {
            return format!("<p>(no data for “{title}”)</p>");
        }
        if y0 == y1 {
            y0 -= 1.0;
            y1 += 1.0;
        }
        let mut chart_builder = ChartBuilder::on(&root);
        chart_builder
            .caption(title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(70);
        macro_rules! draw {
            ($chart:expr) => {{
                let chart = &mut $chart;
                for s in series {
                    let pts: Vec<(f64, f64)> =
                        s.x.iter()
                            .zip(s.y)
                            .filter(|(x, y)| x.is_finite() && ok(**y))
                            .map(|(x, y)| (*x, *y))
                            .collect();
                    let c = color(s.color);
                    if s.points {
                        let _ = chart
                            .draw_series(pts.iter().map(|p| Circle::new(*p, 2, c.filled())))
                            .map(|a| {
                                a.label(s.label)
                                    .legend(move |(x, y)| Circle::new((x + 10, y), 3, c.filled()))
                            });
                    } else {
                        let _ = chart
                            .draw_series(LineSeries::new(pts, c.stroke_width(1)))
                            .map(|a| {
                                a.label(s.label).legend(move |(x, y)| {
                                    PathElement::new(vec![(x, y), (x + 20, y)], c)
                                })
                            });
                    }
                }
            }};
        }
        // mesh, series and legend, the same for both axis types
        macro_rules! finish {
            ($chart:expr, $fmt:expr) => {{
                let _ = $chart
                    .configure_mesh()
                    .x_desc(xlabel)
                    .y_desc(ylabel)
                    .y_label_formatter(&$fmt)
                    .draw();
                draw!($chart);
                let _ = $chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw();
            }};
        }
        match yscale {
            Scale::Log => {
                let Ok(mut chart) =
                    chart_builder.build_cartesian_2d(x0..x1, (y0 * 0.8..y1 * 1.25).log_scale())
                else {
                    return String::new();
                };
                finish!(chart, |v: &f64| format!("{v:.1e}"));
            }
            Scale::Lin => {
                let pad = 0.05 * (y1 - y0);
                let Ok(mut chart) = chart_builder.build_cartesian_2d(x0..x1, y0 - pad..y1 + pad)
                else {
                    return String::new();
                };
                finish!(chart, |v: &f64| format!("{v:.2e}"));
            }
        }
        let _ = root.present();
    }
    svg
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
         .ok{{color:#2a7}}.bad{{color:#c33}}</style></head><body><h1>{t}</h1>\n{body}\n</body></html>\n",
        t = esc(title)
    )
}
