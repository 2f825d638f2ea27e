//! A small SVG line plot in stacked panels, written as plain text so that the crate's charts
//! need no plotting dependency. Each panel has its own y scale (objects that move metres and
//! ones that move millimetres stay readable side by side) and all share the x axis.

use std::fmt::Write;

/// One line of a panel.
pub struct LineSeries<'a> {
    /// Its name in the panel's legend.
    pub label: &'a str,
    /// An SVG colour, e.g. "#1f77b4".
    pub color: &'a str,
    /// Dashed instead of solid.
    pub dashed: bool,
    /// (x, y) points in order; points that are not finite are left out.
    pub points: Vec<(f64, f64)>,
}

/// One panel: a title and its lines, on a y scale of their own.
pub struct Panel<'a> {
    /// Written above the panel.
    pub title: &'a str,
    /// Its lines, drawn in order.
    pub series: Vec<LineSeries<'a>>,
}

/// The figure's width and the plot area's margins inside each panel, px. The legend sits in
/// the right margin, beside the lines rather than over them.
const WIDTH: f64 = 760.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 210.0;
/// Above the first panel: the title.
const TOP: f64 = 44.0;
const PANEL_HEIGHT: f64 = 210.0;
/// Inside a panel: its title above the plot area, the x ticks' labels under it.
const PANEL_TITLE: f64 = 26.0;
const PANEL_FOOT: f64 = 38.0;
/// Under the last panel: the x axis' label.
const BOTTOM: f64 = 30.0;
/// The dash pattern of dashed lines.
const DASH: &str = "7 4";

/// Renders `panels` stacked top to bottom under `title`: a polyline per series, axes with
/// ticks labelled `x_label` (shared) and `y_label` (per panel), and a legend per panel.
pub fn line_plot_svg(title: &str, x_label: &str, y_label: &str, panels: &[Panel]) -> String {
    let height = TOP + PANEL_HEIGHT * panels.len() as f64 + BOTTOM;
    let x_range = range(
        panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| finite(&s.points).map(|(x, _)| x)),
        false,
    );
    let mut svg = svg_header(WIDTH, height, 26.0, title);
    for (i, panel) in panels.iter().enumerate() {
        let top = TOP + PANEL_HEIGHT * i as f64;
        let area = Area {
            left: LEFT,
            right: WIDTH - RIGHT,
            top: top + PANEL_TITLE,
            bottom: top + PANEL_HEIGHT - PANEL_FOOT,
        };
        draw_panel(&mut svg, panel, &area, x_range, y_label);
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        (LEFT + WIDTH - RIGHT) / 2.0,
        height - 10.0,
        escape(x_label)
    );
    svg.push_str("</svg>\n");
    svg
}

/// The plot area of a panel, px.
struct Area {
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
}

/// One panel: title, grid and ticks, a polyline per series, legend.
fn draw_panel(svg: &mut String, panel: &Panel, area: &Area, x: (f64, f64), y_label: &str) {
    let y = range(
        panel
            .series
            .iter()
            .flat_map(|s| finite(&s.points).map(|(_, y)| y)),
        true,
    );
    let px = |v: f64| area.left + (v - x.0) / (x.1 - x.0) * (area.right - area.left);
    let py = |v: f64| area.bottom - (v - y.0) / (y.1 - y.0) * (area.bottom - area.top);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" font-weight="bold">{}</text>"#,
        area.left,
        area.top - 8.0,
        escape(panel.title)
    );
    let (x_ticks, x_decimals) = ticks(x.0, x.1, 8);
    for t in x_ticks {
        let _ = writeln!(
            svg,
            r##"<line x1="{v:.1}" y1="{}" x2="{v:.1}" y2="{}" stroke="#eee"/><text x="{v:.1}" y="{}" text-anchor="middle">{t:.x_decimals$}</text>"##,
            area.top,
            area.bottom,
            area.bottom + 16.0,
            v = px(t)
        );
    }
    let (y_ticks, y_decimals) = ticks(y.0, y.1, 4);
    for t in y_ticks {
        let _ = writeln!(
            svg,
            r##"<line x1="{}" y1="{v:.1}" x2="{}" y2="{v:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{t:.y_decimals$}</text>"##,
            area.left,
            area.right,
            area.left - 6.0,
            py(t) + 4.0,
            v = py(t)
        );
    }
    let _ = writeln!(
        svg,
        r#"<path d="M{} {} V{} H{}" stroke="black" fill="none"/>"#,
        area.left, area.top, area.bottom, area.right
    );
    let _ = writeln!(
        svg,
        r#"<text transform="translate({} {}) rotate(-90)" text-anchor="middle">{}</text>"#,
        area.left - 54.0,
        (area.top + area.bottom) / 2.0,
        escape(y_label)
    );
    for (i, s) in panel.series.iter().enumerate() {
        let points: Vec<String> = finite(&s.points)
            .map(|(a, b)| format!("{:.1},{:.1}", px(a), py(b)))
            .collect();
        let dash = dash_attribute(s.dashed);
        let _ = writeln!(
            svg,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.6"{dash}/>"#,
            points.join(" "),
            s.color
        );
        let ly = area.top + 8.0 + 18.0 * i as f64;
        let lx = area.right + 16.0;
        let _ = writeln!(
            svg,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="1.6"{dash}/><text x="{}" y="{}">{}</text>"#,
            lx + 28.0,
            s.color,
            lx + 34.0,
            ly + 4.0,
            escape(s.label)
        );
    }
}

/// The attribute that makes a line dashed, or nothing.
fn dash_attribute(dashed: bool) -> String {
    if dashed {
        format!(r#" stroke-dasharray="{DASH}""#)
    } else {
        String::new()
    }
}

/// The points of a series that can be drawn.
fn finite(points: &[(f64, f64)]) -> impl Iterator<Item = (f64, f64)> + '_ {
    points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
}

/// The span of `values`, never empty; from zero when `from_zero` (a displacement's axis starts
/// at none), with 5% headroom at the top so the highest line clears the panel's edge.
fn range(values: impl Iterator<Item = f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if from_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0) + 0.05 * (hi - lo);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        hi = lo + 1.0;
    }
    (lo, hi)
}

/// Round tick values inside [lo, hi], 1, 2 or 5 times a power of ten apart, about `count` of
/// them, and the decimals that print them without noise.
fn ticks(lo: f64, hi: f64, count: usize) -> (Vec<f64>, usize) {
    let raw = (hi - lo) / count.max(1) as f64;
    // powi rather than powf: 10^-k comes out as the nearest double, so ticks print round.
    let power = 10f64.powi(raw.log10().floor() as i32);
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power);
    let mut values = Vec::new();
    let mut k = (lo / step).ceil();
    while k * step <= hi + 1e-9 * step {
        values.push(k * step);
        k += 1.0;
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    (values, decimals)
}

/// Text made safe to put inside an SVG element.
/// The opening of an SVG picture: its size, a white background and `title` centred at
/// `title_y`. The caller appends the drawing and the closing `</svg>`.
pub fn svg_header(width: f64, height: f64, title_y: f64, title: &str) -> String {
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{title_y}" font-size="15" text-anchor="middle">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    svg
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series<'a>(label: &'a str, color: &'a str, dashed: bool, gain: f64) -> LineSeries<'a> {
        LineSeries {
            label,
            color,
            dashed,
            points: (0..50)
                .map(|i| (i as f64 * 0.1, gain * (i as f64 * 0.3).sin().abs()))
                .chain([(5.0, f64::NAN)])
                .collect(),
        }
    }

    #[test]
    fn one_polyline_per_series_with_its_labels() {
        let panels = [
            Panel {
                title: "creature",
                series: vec![
                    series("reduced", "#1f77b4", false, 700.0),
                    series("FEM", "#1f77b4", true, 650.0),
                ],
            },
            Panel {
                title: "ball <1>",
                series: vec![
                    series("reduced", "#d62728", false, 0.05),
                    series("FEM", "#d62728", true, 0.04),
                ],
            },
        ];
        let svg = line_plot_svg("Displacement", "time (s)", "displacement (mm)", &panels);
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert_eq!(svg.matches("<polyline").count(), 4);
        assert_eq!(
            svg.matches("stroke-dasharray").count(),
            2 + 2,
            "lines and legend"
        );
        for text in [
            "Displacement",
            "time (s)",
            "displacement (mm)",
            ">creature<",
            ">ball &lt;1&gt;<",
            ">reduced<",
            ">FEM<",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert!(
            !svg.contains("NaN"),
            "points that are not finite are left out"
        );
        // The small panel has ticks of its own scale.
        assert!(svg.contains(">0.02<"), "{svg}");
    }

    #[test]
    fn ticks_are_round_and_inside_the_range() {
        fn near(values: &[f64], expected: &[f64]) -> bool {
            values.len() == expected.len()
                && values
                    .iter()
                    .zip(expected)
                    .all(|(a, b)| (a - b).abs() < 1e-12)
        }
        let (values, decimals) = ticks(0.0, 7.35, 8);
        assert!(
            near(&values, &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]),
            "{values:?}"
        );
        assert_eq!(decimals, 0);
        let (values, decimals) = ticks(0.0, 0.0525, 4);
        assert!(near(&values, &[0.0, 0.02, 0.04]), "{values:?}");
        assert_eq!(decimals, 2);
        assert_eq!(range([3.0, 3.0].into_iter(), false), (3.0, 4.0));
        assert_eq!(range(std::iter::empty(), true), (0.0, 1.0));
    }
}
