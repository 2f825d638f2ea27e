//! A strip of frames of a scene, side by side: every object's points seen from the front
//! (x to the right, z up), coloured per point, on the same scale in every frame, its rest pose
//! ghosted behind it. Words make it readable on its own: each frame's time above it, each
//! object's name under it, and a legend along the bottom.

use std::io::Write;

use super::field_image::{write_rgb_png, RenderError};
use super::font::{draw_text, text_width, GLYPH_HEIGHT};

/// One object in one frame.
pub struct StripObject<'a> {
    /// Its name, written under it.
    pub label: &'a str,
    /// x, y, z per point.
    pub positions: &'a [f32],
    /// A colour per point (RGB in [0, 1]).
    pub colors: &'a [[f64; 3]],
    /// Its rest pose (x, y, z per point, the same points as `positions`), drawn in light grey
    /// behind the deformed points so that the motion shows against it.
    pub rest: Option<&'a [f32]>,
}

/// One frame of the strip: when it was, and what it shows.
pub struct StripFrame<'a> {
    /// Seconds since the recording's start, written above the frame.
    pub time_s: f64,
    /// The objects drawn in the frame.
    pub objects: Vec<StripObject<'a>>,
}

/// The ghost of a rest pose: light enough that every coloured point stands out against it.
const GHOST: [u8; 3] = [214, 214, 214];
/// Text: dark grey rather than black, which looks heavy at 2x scale.
const INK: [u8; 3] = [40, 40, 40];
/// Lines between frames and above the legend.
const RULE: [u8; 3] = [160, 160, 160];
/// Blank pixels above and below a line of text.
const PAD: u32 = 6;
/// Rows of names under the scenes: a second row takes names that would overlap the first.
const NAME_ROWS: u32 = 2;

/// Renders `frames` left to right, each scene `view` pixels high, with a band for the times
/// above, one for the names below, and `legend` written along the bottom.
pub fn render_strip_png(
    frames: &[StripFrame],
    view: u32,
    legend: &str,
    out: &mut impl Write,
) -> Result<(), RenderError> {
    let (lo, hi) = bounds(frames)?;
    let layout = Layout::new(lo, hi, view, frames.len() as u32);
    let mut canvas = Canvas::new(layout.width, layout.height);
    for (f, frame) in frames.iter().enumerate() {
        let left = f as u32 * layout.frame_width;
        draw_scene(&mut canvas, &layout, frame, left);
        draw_frame_text(&mut canvas, &layout, frame, left);
        if f > 0 {
            for y in 0..layout.legend_top {
                canvas.set(left as i64, y as i64, RULE);
            }
        }
    }
    for x in 0..layout.width {
        canvas.set(x as i64, layout.legend_top as i64, RULE);
    }
    // The legend at the frames' text size where it fits, else at the smallest.
    let scale = if text_width(legend, layout.scale) + 2 * PAD <= layout.width {
        layout.scale
    } else {
        1
    };
    let y = layout.legend_top + PAD;
    canvas.text(PAD as i64, y as i64, legend, scale);
    write_rgb_png(layout.width, layout.height, &canvas.rgb, out)
}

/// The scene's bounds over every frame, rest poses included, after checking the inputs agree.
fn bounds(frames: &[StripFrame]) -> Result<([f64; 3], [f64; 3]), RenderError> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for object in frames.iter().flat_map(|f| &f.objects) {
        let points = object.positions.len() / 3;
        if object.colors.len() * 3 != object.positions.len() {
            return Err(RenderError::Input(format!(
                "{} colours for {points} points of {}",
                object.colors.len(),
                object.label
            )));
        }
        if let Some(rest) = object.rest.filter(|r| r.len() != object.positions.len()) {
            return Err(RenderError::Input(format!(
                "{} rest points for {points} points of {}",
                rest.len() / 3,
                object.label
            )));
        }
        let rest = object.rest.unwrap_or(&[]);
        for p in object.positions.chunks_exact(3).chain(rest.chunks_exact(3)) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
    }
    if frames.is_empty() || !lo[0].is_finite() {
        return Err(RenderError::Input("nothing to draw".into()));
    }
    Ok((lo, hi))
}

/// Where everything goes: the frames' size, the scene's scale, and the bands of text.
struct Layout {
    view: u32,
    frame_width: u32,
    /// Pixels per metre, the same in every frame.
    metres: f64,
    /// The scene's centre (x, z), drawn at each frame's centre.
    center: [f64; 2],
    /// Font pixels per glyph pixel.
    scale: u32,
    /// Height of one line of text with its padding.
    line: u32,
    /// Top of the scenes, under the band of times.
    scene_top: u32,
    /// Top of the band of names, under the scenes.
    names_top: u32,
    /// Top of the legend, under the names.
    legend_top: u32,
    width: u32,
    height: u32,
}

impl Layout {
    fn new(lo: [f64; 3], hi: [f64; 3], view: u32, frames: u32) -> Self {
        // One scale for all frames, with a margin of 5% around the scene.
        let (sx, sz) = ((hi[0] - lo[0]).max(1e-9), (hi[2] - lo[2]).max(1e-9));
        let aspect = (sx / sz).clamp(0.5, 4.0);
        let frame_width = (view as f64 * aspect) as u32;
        // Large text where a frame has room for a name or two, small in narrow frames.
        let scale = if frame_width >= 160 { 2 } else { 1 };
        let line = GLYPH_HEIGHT * scale + 2 * PAD;
        let scene_top = line;
        let names_top = scene_top + view;
        let legend_top = names_top + NAME_ROWS * line;
        Self {
            view,
            frame_width,
            metres: (frame_width as f64 / (sx * 1.1)).min(view as f64 / (sz * 1.1)),
            center: [(lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0],
            scale,
            line,
            scene_top,
            names_top,
            legend_top,
            width: frame_width * frames,
            height: legend_top + line + PAD,
        }
    }

    /// The pixel of a point (x, z) in the frame whose left edge is `left`.
    fn pixel(&self, p: &[f32], left: u32) -> (f64, f64) {
        let x = left as f64 + self.frame_width as f64 / 2.0;
        let y = self.scene_top as f64 + self.view as f64 / 2.0;
        (
            x + (p[0] as f64 - self.center[0]) * self.metres,
            y - (p[2] as f64 - self.center[1]) * self.metres,
        )
    }
}

/// Draws one frame's objects: every rest pose first, then the deformed points over them.
fn draw_scene(canvas: &mut Canvas, layout: &Layout, frame: &StripFrame, left: u32) {
    let clip = Clip {
        x: (left as i64, (left + layout.frame_width) as i64),
        y: (layout.scene_top as i64, layout.names_top as i64),
    };
    let radius =
        |count: usize| ((layout.view as f64) * 0.9 / (count.max(1) as f64).sqrt()).clamp(1.0, 3.0);
    // Ghosts leave the depth buffer alone: any deformed point drawn later covers them.
    for object in &frame.objects {
        let r = radius(object.colors.len());
        for p in object.rest.unwrap_or(&[]).chunks_exact(3) {
            canvas.disk(layout.pixel(p, left), r, &clip, None, GHOST);
        }
    }
    for object in &frame.objects {
        let r = radius(object.colors.len());
        for (p, color) in object.positions.chunks_exact(3).zip(object.colors) {
            let rgb = color.map(|c| (c * 255.0).clamp(0.0, 255.0) as u8);
            // Nearer to the viewer (smaller y) wins.
            canvas.disk(layout.pixel(p, left), r, &clip, Some(p[1]), rgb);
        }
    }
}

/// Writes the frame's time centred above it and each object's name under its x centre.
fn draw_frame_text(canvas: &mut Canvas, layout: &Layout, frame: &StripFrame, left: u32) {
    let time = format!("t = {:.2} s", frame.time_s);
    let width = text_width(&time, layout.scale);
    let x = left as i64 + (layout.frame_width as i64 - width as i64) / 2;
    canvas.text(x, PAD as i64, &time, layout.scale);
    let names: Vec<(f64, u32)> = frame
        .objects
        .iter()
        .map(|o| {
            let (lo, hi) = o
                .positions
                .chunks_exact(3)
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p[0]), hi.max(p[0]))
                });
            let middle = [(lo + hi) / 2.0, 0.0, layout.center[1] as f32];
            (
                layout.pixel(&middle, left).0,
                text_width(o.label, layout.scale),
            )
        })
        .collect();
    let span = (left as i64, (left + layout.frame_width) as i64);
    for (object, (x, row)) in frame.objects.iter().zip(place_names(&names, span)) {
        let y = layout.names_top + PAD + row * layout.line;
        canvas.text(x, y as i64, object.label, layout.scale);
    }
}

/// Left edges and rows of names centred at the given x (pixels) with the given widths, kept
/// inside `span` (left, right). A name that would overlap the one before it on the first row
/// goes to the next row; past the last row it overlaps, which only very crowded frames see.
fn place_names(names: &[(f64, u32)], span: (i64, i64)) -> Vec<(i64, u32)> {
    let mut order: Vec<usize> = (0..names.len()).collect();
    order.sort_by(|&a, &b| names[a].0.total_cmp(&names[b].0));
    let mut placed = vec![(0i64, 0u32); names.len()];
    let mut row_ends = [i64::MIN; NAME_ROWS as usize];
    for i in order {
        let (centre, width) = (names[i].0, names[i].1 as i64);
        let x = (centre as i64 - width / 2)
            .min(span.1 - width - 2)
            .max(span.0 + 2);
        let row = (0..row_ends.len())
            .find(|&r| x > row_ends[r].saturating_add(PAD as i64))
            .unwrap_or(row_ends.len() - 1);
        row_ends[row] = x + width;
        placed[i] = (x, row as u32);
    }
    placed
}

/// A rectangle of pixels to draw in: columns `x.0..x.1`, rows `y.0..y.1`.
struct Clip {
    x: (i64, i64),
    y: (i64, i64),
}

/// An RGB image with a depth per pixel.
struct Canvas {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    depth: Vec<f32>,
}

impl Canvas {
    fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![255; (width * height * 3) as usize],
            depth: vec![f32::INFINITY; (width * height) as usize],
        }
    }

    /// One pixel, ignored outside the image.
    fn set(&mut self, x: i64, y: i64, color: [u8; 3]) {
        if x >= 0 && y >= 0 && x < self.width as i64 && y < self.height as i64 {
            let at = 3 * (y as usize * self.width as usize + x as usize);
            self.rgb[at..at + 3].copy_from_slice(&color);
        }
    }

    /// A disk inside `clip`. With a depth, only where nothing nearer is drawn yet (and it is
    /// recorded); without, everywhere, under whatever is drawn later with a depth.
    fn disk(
        &mut self,
        center: (f64, f64),
        radius: f64,
        clip: &Clip,
        depth: Option<f32>,
        color: [u8; 3],
    ) {
        let r = radius.ceil() as i64;
        for dy in -r..=r {
            for dx in -r..=r {
                if (dx * dx + dy * dy) as f64 > radius * radius {
                    continue;
                }
                let (x, y) = (center.0 as i64 + dx, center.1 as i64 + dy);
                if x < clip.x.0 || x >= clip.x.1 || y < clip.y.0 || y >= clip.y.1 {
                    continue;
                }
                if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
                    continue;
                }
                let at = y as usize * self.width as usize + x as usize;
                if let Some(z) = depth {
                    if z >= self.depth[at] {
                        continue;
                    }
                    self.depth[at] = z;
                }
                self.rgb[3 * at..3 * at + 3].copy_from_slice(&color);
            }
        }
    }

    fn text(&mut self, x: i64, y: i64, text: &str, scale: u32) {
        draw_text(
            &mut self.rgb,
            self.width,
            self.height,
            x,
            y,
            text,
            scale,
            INK,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring of points in the x-z plane around (cx, 0, 0).
    fn ring(cx: f32, radius: f32) -> Vec<f32> {
        (0..200)
            .flat_map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 200.0;
                [cx + radius * a.cos(), 0.0, radius * a.sin()]
            })
            .collect()
    }

    fn frame<'a>(
        time_s: f64,
        positions: &'a [f32],
        rest: &'a [f32],
        colors: &'a [[f64; 3]],
    ) -> StripFrame<'a> {
        StripFrame {
            time_s,
            objects: vec![StripObject {
                label: "ring",
                positions,
                colors,
                rest: Some(rest),
            }],
        }
    }

    #[test]
    fn frames_carry_times_names_ghosts_and_a_legend() {
        let rest = ring(0.0, 1.0);
        let moved = ring(0.6, 1.0);
        let colors = vec![[1.0, 0.0, 0.0]; 200];
        let frames = [
            frame(0.0, &rest, &rest, &colors),
            frame(1.17, &moved, &rest, &colors),
        ];
        let mut bytes = Vec::new();
        // 160 px scenes of this 2.6 x 2 m scene are 208 px wide: text at scale 2.
        render_strip_png(&frames, 160, "grey: rest pose", &mut bytes).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buffer).unwrap();
        let (width, height) = (info.width as usize, info.height as usize);
        let line = (GLYPH_HEIGHT * 2 + 2 * PAD) as usize;
        assert_eq!(height, line + 160 + 3 * line + PAD as usize);
        let pixels: Vec<&[u8]> = buffer.chunks_exact(3).collect();
        let count = |rows: std::ops::Range<usize>, color: [u8; 3]| {
            rows.flat_map(|y| (0..width).map(move |x| y * width + x))
                .filter(|&i| pixels[i] == &color[..])
                .count()
        };
        assert!(count(0..line, INK) > 0, "times above the frames");
        assert!(count(line..line + 160, [255, 0, 0]) > 0, "the points");
        assert!(count(line..line + 160, GHOST) > 0, "the moved ring's ghost");
        assert!(count(line + 160..height, INK) > 0, "names and legend below");

        let mut bad = frames;
        bad[1].objects[0].rest = Some(&rest[3..]);
        assert!(render_strip_png(&bad, 160, "", &mut Vec::new()).is_err());
    }

    #[test]
    fn crowded_names_take_the_second_row_and_stay_in_the_frame() {
        let placed = place_names(&[(50.0, 40), (60.0, 40), (195.0, 40)], (0, 200));
        assert_eq!(placed[0], (30, 0));
        assert_eq!(placed[1].1, 1, "overlaps the first");
        assert_eq!(placed[2], (158, 0), "pushed back inside the frame");
    }
}
