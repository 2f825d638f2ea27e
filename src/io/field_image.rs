//! A PNG of a skinning field a person can look at: the points colored by their dominant
//! handles, seen from the front, the side and the top.

use std::io::Write;

use nalgebra::Vector3;

/// What can go wrong drawing a field.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The inputs do not fit together (weight count, fewer than two handles, normals) or a
    /// weight is not finite.
    #[error("field image: {0}")]
    Input(String),
    /// The PNG encoder failed.
    #[error("field image: png encoding: {0}")]
    Png(#[from] png::EncodingError),
}

/// Renders `points` (normalized frame, about [-1, 1]^3) colored by `weights` (row-major,
/// points x handles; column 0 is the constant handle and is left out of the blend): three
/// orthographic views side by side, each `view` pixels square.
pub fn render_field_png(
    points: &[Vector3<f64>],
    normals: Option<&[Vector3<f64>]>,
    weights: &[f64],
    handles: usize,
    view: u32,
    out: &mut impl Write,
) -> Result<(), RenderError> {
    if handles < 2 || weights.len() != points.len() * handles {
        return Err(RenderError::Input(format!(
            "{} weights for {} points and {handles} handles",
            weights.len(),
            points.len()
        )));
    }
    if let Some(n) = normals {
        if n.len() != points.len() {
            return Err(RenderError::Input(format!(
                "{} normals for {} points",
                n.len(),
                points.len()
            )));
        }
    }
    if let Some(bad) = weights.iter().position(|w| !w.is_finite()) {
        return Err(RenderError::Input(format!("weight {bad} is not finite")));
    }
    let colors: Vec<[f64; 3]> = weights.chunks_exact(handles).map(blend).collect();
    let (width, height) = (3 * view, view);
    let mut image = vec![255u8; (width * height * 3) as usize];
    let mut depth = vec![f64::INFINITY; (width * height) as usize];
    // Disks large enough that neighbouring samples overlap at this point count.
    let radius = ((view as f64) * 1.6 / (points.len() as f64).sqrt()).clamp(1.0, 6.0);
    // (right, up, towards the viewer) per view: front (-y), side (+x), top (+z).
    let frames = [
        (Vector3::x(), Vector3::z(), -Vector3::y()),
        (Vector3::y(), Vector3::z(), Vector3::x()),
        (Vector3::x(), Vector3::y(), Vector3::z()),
    ];
    for (v, (right, up, toward)) in frames.iter().enumerate() {
        for (i, p) in points.iter().enumerate() {
            let shade = normals.map_or(1.0, |n| 0.35 + 0.65 * n[i].dot(toward).abs());
            let cx = (0.5 + 0.45 * p.dot(right)) * view as f64 + (v as u32 * view) as f64;
            let cy = (0.5 - 0.45 * p.dot(up)) * view as f64;
            let z = -p.dot(toward);
            let r = radius.ceil() as i64;
            for dy in -r..=r {
                for dx in -r..=r {
                    if (dx * dx + dy * dy) as f64 > radius * radius {
                        continue;
                    }
                    let (x, y) = (cx as i64 + dx, cy as i64 + dy);
                    let lo = (v as u32 * view) as i64;
                    if x < lo || x >= lo + view as i64 || y < 0 || y >= height as i64 {
                        continue;
                    }
                    let at = (y as u32 * width + x as u32) as usize;
                    if z < depth[at] {
                        depth[at] = z;
                        for c in 0..3 {
                            image[3 * at + c] =
                                (colors[i][c] * shade * 255.0).clamp(0.0, 255.0) as u8;
                        }
                    }
                }
            }
        }
    }
    write_rgb_png(width, height, &image, out)
}

/// An 8-bit RGB image, row-major, as PNG.
pub(crate) fn write_rgb_png(
    width: u32,
    height: u32,
    rgb: &[u8],
    out: &mut impl Write,
) -> Result<(), RenderError> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}

/// The colour of every point of a row-major weights matrix (points x handles).
pub(crate) fn weight_colors(weights: &[f32], handles: usize) -> Vec<[f64; 3]> {
    let mut row = vec![0.0; handles];
    weights
        .chunks_exact(handles)
        .map(|w| {
            for (r, w) in row.iter_mut().zip(w) {
                *r = *w as f64;
            }
            blend(&row)
        })
        .collect()
}

/// The colour of one point: handle colours weighted by the squared positive part of the
/// learned weights, so each region shows its dominant handles and borders blend.
fn blend(row: &[f64]) -> [f64; 3] {
    let mut total = 0.0;
    let mut color = [0.0; 3];
    for (h, w) in row.iter().enumerate().skip(1) {
        let a = w.max(0.0).powi(2);
        let c = palette(h - 1);
        for k in 0..3 {
            color[k] += a * c[k];
        }
        total += a;
    }
    if total <= 0.0 {
        return [0.6; 3];
    }
    color.map(|c| c / total)
}

/// Distinct hues, the golden angle apart.
fn palette(index: usize) -> [f64; 3] {
    let hue = (index as f64 * 137.508).rem_euclid(360.0) / 60.0;
    let x = 1.0 - (hue % 2.0 - 1.0).abs();
    let (r, g, b) = match hue as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    // Slightly darkened so light hues stand out against white.
    [0.15 + 0.75 * r, 0.15 + 0.75 * g, 0.15 + 0.75 * b]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_three_views_and_rejects_bad_input() {
        let points: Vec<Vector3<f64>> = (0..2000)
            .map(|i| {
                let t = i as f64 * 2.399;
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
                let r = (1.0 - z * z).sqrt();
                Vector3::new(r * t.cos(), r * t.sin(), z) * 0.9
            })
            .collect();
        let weights: Vec<f64> = points.iter().flat_map(|p| [1.0, p.x, p.y, p.z]).collect();
        let mut png_bytes = Vec::new();
        render_field_png(&points, Some(&points), &weights, 4, 64, &mut png_bytes).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buffer).unwrap();
        assert_eq!((info.width, info.height), (192, 64));
        assert_eq!(&buffer[..3], &[255, 255, 255], "background at the corner");
        let center = 3 * (32 * 192 + 32);
        assert_ne!(
            &buffer[center..center + 3],
            &[255, 255, 255],
            "the sphere covers the middle"
        );
        assert!(render_field_png(&points, None, &weights[1..], 4, 64, &mut Vec::new()).is_err());
        let mut nan = weights.clone();
        nan[5] = f64::NAN;
        assert!(render_field_png(&points, None, &nan, 4, 64, &mut Vec::new()).is_err());
    }
}
