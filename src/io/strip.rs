//! A strip of frames of a scene, side by side: every object's points seen from the front
//! (x to the right, z up), coloured per point, on the same scale in every frame.

use std::io::Write;

use super::field_image::{write_rgb_png, RenderError};

/// One object in one frame: positions (x, y, z per point) and a colour per point.
pub struct StripObject<'a> {
    pub positions: &'a [f32],
    pub colors: &'a [[f64; 3]],
}

/// Renders `frames` (each a list of objects) left to right, each `view` pixels high.
pub fn render_strip_png(
    frames: &[Vec<StripObject>],
    view: u32,
    out: &mut impl Write,
) -> Result<(), RenderError> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for object in frames.iter().flatten() {
        if object.colors.len() * 3 != object.positions.len() {
            return Err(RenderError::Input(format!(
                "{} colours for {} points",
                object.colors.len(),
                object.positions.len() / 3
            )));
        }
        for p in object.positions.chunks_exact(3) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
    }
    if frames.is_empty() || !lo[0].is_finite() {
        return Err(RenderError::Input("nothing to draw".into()));
    }
    // One scale for all frames, with a margin of 5% around the scene.
    let (sx, sz) = ((hi[0] - lo[0]).max(1e-9), (hi[2] - lo[2]).max(1e-9));
    let aspect = (sx / sz).clamp(0.5, 4.0);
    let frame_width = (view as f64 * aspect) as u32;
    let (width, height) = (frame_width * frames.len() as u32, view);
    let scale = (frame_width as f64 / (sx * 1.1)).min(view as f64 / (sz * 1.1));
    let center = [(lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0];
    let mut image = vec![255u8; (width * height * 3) as usize];
    let mut depth = vec![f32::INFINITY; (width * height) as usize];
    for (f, objects) in frames.iter().enumerate() {
        let left = f as u32 * frame_width;
        for object in objects {
            let count = object.colors.len().max(1);
            let radius = ((view as f64) * 0.9 / (count as f64).sqrt()).clamp(1.0, 3.0);
            let r = radius.ceil() as i64;
            for (p, color) in object.positions.chunks_exact(3).zip(object.colors) {
                let cx = left as f64 + frame_width as f64 / 2.0 + (p[0] as f64 - center[0]) * scale;
                let cy = view as f64 / 2.0 - (p[2] as f64 - center[1]) * scale;
                for dy in -r..=r {
                    for dx in -r..=r {
                        if (dx * dx + dy * dy) as f64 > radius * radius {
                            continue;
                        }
                        let (x, y) = (cx as i64 + dx, cy as i64 + dy);
                        if x < left as i64
                            || x >= (left + frame_width) as i64
                            || y < 0
                            || y >= height as i64
                        {
                            continue;
                        }
                        let at = (y as u32 * width + x as u32) as usize;
                        // Nearer to the viewer (smaller y) wins.
                        if p[1] < depth[at] {
                            depth[at] = p[1];
                            for c in 0..3 {
                                image[3 * at + c] = (color[c] * 255.0).clamp(0.0, 255.0) as u8;
                            }
                        }
                    }
                }
            }
        }
        // A grey line between frames.
        if f > 0 {
            for y in 0..height {
                let at = (y * width + left) as usize;
                image[3 * at..3 * at + 3].copy_from_slice(&[160, 160, 160]);
            }
        }
    }
    write_rgb_png(width, height, &image, out)
}
