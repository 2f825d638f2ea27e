//! A small SVG scatter plot (log-scaled x), so the bench needs no plotting dependency.

use std::fmt::Write;

pub struct Series<'a> {
    pub label: &'a str,
    pub color: &'a str,
    pub points: Vec<(f64, f64)>,
}

/// Step time (x, ms, log scale) against error (y, %), one colour per series.
pub fn scatter_svg(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    let (width, height, margin) = (760.0, 480.0, 70.0);
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|(x, y)| x.is_finite() && *x > 0.0 && y.is_finite())
        .collect();
    let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y_hi = 0.0f64;
    for (x, y) in &all {
        x_lo = x_lo.min(x.log10());
        x_hi = x_hi.max(x.log10());
        y_hi = y_hi.max(*y);
    }
    if !x_lo.is_finite() {
        (x_lo, x_hi) = (0.0, 1.0);
    }
    let (x_lo, x_hi) = (x_lo.floor(), x_hi.ceil().max(x_lo.floor() + 1.0));
    let y_hi = if y_hi > 0.0 { y_hi * 1.1 } else { 1.0 };
    let px = |x: f64| margin + (x.log10() - x_lo) / (x_hi - x_lo) * (width - 2.0 * margin);
    let py = |y: f64| height - margin - y / y_hi * (height - 2.0 * margin);
    let mut svg = crate::io::svg_header(width, height, 24.0, title);
    let (x0, y0) = (margin, height - margin);
    let _ = writeln!(
        svg,
        r#"<path d="M{x0} {} V{y0} H{}" stroke="black" fill="none"/>"#,
        margin,
        width - margin
    );
    for decade in (x_lo as i32)..=(x_hi as i32) {
        let x = px(10f64.powi(decade));
        let _ = writeln!(
            svg,
            r##"<line x1="{x}" y1="{margin}" x2="{x}" y2="{y0}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{}</text>"##,
            y0 + 18.0,
            10f64.powi(decade)
        );
    }
    for tick in 0..=5 {
        let y = y_hi * tick as f64 / 5.0;
        let _ = writeln!(
            svg,
            r##"<line x1="{x0}" y1="{py}" x2="{}" y2="{py}" stroke="#eee"/><text x="{}" y="{}" text-anchor="end">{:.2}</text>"##,
            width - margin,
            x0 - 6.0,
            py(y) + 4.0,
            y,
            py = py(y)
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">{x_label}</text>"#,
        width / 2.0,
        height - 24.0
    );
    let _ = writeln!(
        svg,
        r#"<text transform="translate(20 {}) rotate(-90)" text-anchor="middle">{y_label}</text>"#,
        height / 2.0
    );
    for (i, s) in series.iter().enumerate() {
        for (x, y) in s
            .points
            .iter()
            .filter(|(x, y)| *x > 0.0 && x.is_finite() && y.is_finite())
        {
            let _ = writeln!(
                svg,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}" fill-opacity="0.7"/>"#,
                px(*x),
                py(*y),
                s.color
            );
        }
        let ly = margin + 16.0 * i as f64;
        let _ = writeln!(
            svg,
            r#"<circle cx="{}" cy="{ly}" r="5" fill="{}"/><text x="{}" y="{}">{}</text>"#,
            width - margin - 230.0,
            s.color,
            width - margin - 220.0,
            ly + 4.0,
            s.label
        );
    }
    svg.push_str("</svg>\n");
    svg
}
