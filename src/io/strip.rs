//! Frames of a scene in a grid, row by row: every object's points seen from the front (x to
//! the right, z up), coloured per point, on the same scale in every frame, its rest pose
//! ghosted behind it, the floor drawn and the pushes of each frame marked. Words make it
//! readable on its own: each frame's time above it, each object's name under it, and a legend
//! along the bottom.

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

/// A push, drawn as an arrow onto the point it pushes (a ring where it pushes into the page).
pub struct StripMark {
    /// The pushed point, x, y, z.
    pub at: [f32; 3],
    /// The push's direction (any length).
    pub direction: [f32; 3],
}

/// One frame of the strip: when it was, and what it shows.
pub struct StripFrame<'a> {
    /// Seconds since the recording's start, written above the frame.
    pub time_s: f64,
    /// The objects drawn in the frame.
    pub objects: Vec<StripObject<'a>>,
    /// Pushes to mark in the frame.
    pub marks: Vec<StripMark>,
}

/// How the frames are laid out and what goes with them.
pub struct StripStyle<'a> {
    /// Each frame's scene, px high.
    pub view: u32,
    /// Frames per row.
    pub columns: u32,
    /// The floor's height, m, drawn as a line under the objects; None: no floor.
    pub floor_z: Option<f64>,
    /// Lines of the legend along the bottom.
    pub legend: &'a [String],
}

/// The ghost of a rest pose: light enough that every coloured point stands out against it.
const GHOST: [u8; 3] = [214, 214, 214];
/// Text: dark grey rather than black, which looks heavy at 2x scale.
const INK: [u8; 3] = [40, 40, 40];
/// Lines between frames and above the legend.
const RULE: [u8; 3] = [160, 160, 160];
/// The floor: darker than the rules, lighter than the text.
const FLOOR: [u8; 3] = [110, 110, 110];
/// Pushes: a red no weight colour uses at full strength.
const PUSH: [u8; 3] = [220, 0, 0];
/// Length of a push's arrow, px.
const ARROW: f64 = 36.0;
/// Blank pixels above and below a line of text.
const PAD: u32 = 6;
/// Rows of names under the scenes: a second row takes names that would overlap the first.
const NAME_ROWS: u32 = 2;

/// Renders `frames` row by row, `style.columns` to a row, each scene `style.view` pixels high,
/// with its time above and its names below, and the legend's lines along the bottom.
pub fn render_strip_png(
    frames: &[StripFrame],
    style: &StripStyle,
    out: &mut impl Write,
) -> Result<(), RenderError> {
    let (lo, hi) = bounds(frames, style.floor_z)?;
    let count = frames.len() as u32;
    let mut layout = Layout::new(lo, hi, style.view, count.min(style.columns.max(1)));
    let rows = count.div_ceil(layout.columns);
    let legend_top = rows * layout.cell_height;
    layout.height = legend_top + style.legend.len() as u32 * layout.line + PAD;
    let mut canvas = Canvas::new(layout.width, layout.height);
    for (f, frame) in frames.iter().enumerate() {
        let cell = layout.cell(f as u32);
        draw_floor(&mut canvas, &layout, style.floor_z, cell);
        draw_scene(&mut canvas, &layout, frame, cell);
        draw_marks(&mut canvas, &layout, frame, cell);
        draw_frame_text(&mut canvas, &layout, frame, cell);
        let (left, top) = cell;
        for y in top..top + layout.cell_height {
            canvas.set(left as i64, y as i64, RULE);
        }
        for x in left..left + layout.frame_width {
            canvas.set(x as i64, top as i64, RULE);
        }
    }
    for x in 0..layout.width {
        canvas.set(x as i64, legend_top as i64, RULE);
    }
    // The legend at the frames' text size where every line fits, else at the smallest.
    let fits = |scale| {
        style
            .legend
            .iter()
            .all(|l| text_width(l, scale) + 2 * PAD <= layout.width)
    };
    let scale = if fits(layout.scale) { layout.scale } else { 1 };
    for (i, line) in style.legend.iter().enumerate() {
        let y = legend_top + PAD + i as u32 * layout.line;
        canvas.text(PAD as i64, y as i64, line, scale);
    }
    write_rgb_png(layout.width, layout.height, &canvas.rgb, out)
}

/// The scene's bounds over every frame, rest poses included, after checking the inputs agree.
fn bounds(
    frames: &[StripFrame],
    floor_z: Option<f64>,
) -> Result<([f64; 3], [f64; 3]), RenderError> {
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
    if let Some(z) = floor_z {
        lo[2] = lo[2].min(z);
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
    /// Height of a frame with its time and names.
    cell_height: u32,
    /// Frames per row.
    columns: u32,
    width: u32,
    height: u32,
}

impl Layout {
    fn new(lo: [f64; 3], hi: [f64; 3], view: u32, columns: u32) -> Self {
        // One scale for all frames, with a margin of 5% around the scene.
        let (sx, sz) = ((hi[0] - lo[0]).max(1e-9), (hi[2] - lo[2]).max(1e-9));
        let aspect = (sx / sz).clamp(0.5, 4.0);
        let frame_width = (view as f64 * aspect) as u32;
        // Large text where a frame has room for a name or two, small in narrow frames.
        let scale = if frame_width >= 160 { 2 } else { 1 };
        let line = GLYPH_HEIGHT * scale + 2 * PAD;
        let scene_top = line;
        let names_top = scene_top + view;
        let cell_height = names_top + NAME_ROWS * line;
        Self {
            view,
            frame_width,
            metres: (frame_width as f64 / (sx * 1.1)).min(view as f64 / (sz * 1.1)),
            center: [(lo[0] + hi[0]) / 2.0, (lo[2] + hi[2]) / 2.0],
            scale,
            line,
            scene_top,
            names_top,
            cell_height,
            columns,
            width: frame_width * columns,
            height: cell_height,
        }
    }

    /// The left and top edges of frame `f`.
    fn cell(&self, f: u32) -> (u32, u32) {
        (
            (f % self.columns) * self.frame_width,
            (f / self.columns) * self.cell_height,
        )
    }

    /// The pixel of a point (x, z) in the frame whose left and top edges are `cell`.
    fn pixel(&self, p: &[f32], (left, top): (u32, u32)) -> (f64, f64) {
        let x = left as f64 + self.frame_width as f64 / 2.0;
        let y = (top + self.scene_top) as f64 + self.view as f64 / 2.0;
        (
            x + (p[0] as f64 - self.center[0]) * self.metres,
            y - (p[2] as f64 - self.center[1]) * self.metres,
        )
    }
}

/// Draws one frame's objects: every rest pose first, then the deformed points over them.
fn draw_scene(canvas: &mut Canvas, layout: &Layout, frame: &StripFrame, cell: (u32, u32)) {
    let clip = layout.clip(cell);
    let radius =
        |count: usize| ((layout.view as f64) * 0.9 / (count.max(1) as f64).sqrt()).clamp(1.0, 3.0);
    // Ghosts leave the depth buffer alone: any deformed point drawn later covers them.
    for object in &frame.objects {
        let r = radius(object.colors.len());
        for p in object.rest.unwrap_or(&[]).chunks_exact(3) {
            canvas.disk(layout.pixel(p, cell), r, &clip, None, GHOST);
        }
    }
    for object in &frame.objects {
        let r = radius(object.colors.len());
        for (p, color) in object.positions.chunks_exact(3).zip(object.colors) {
            let rgb = color.map(|c| (c * 255.0).clamp(0.0, 255.0) as u8);
            // Nearer to the viewer (smaller y) wins.
            canvas.disk(layout.pixel(p, cell), r, &clip, Some(p[1]), rgb);
        }
    }
}

impl Layout {
    /// The scene's rectangle in the frame at `cell`.
    fn clip(&self, (left, top): (u32, u32)) -> Clip {
        Clip {
            x: (left as i64, (left + self.frame_width) as i64),
            y: ((top + self.scene_top) as i64, (top + self.names_top) as i64),
        }
    }
}

/// The floor: a line at its height with short hatches under it, as drawings mark the ground.
fn draw_floor(canvas: &mut Canvas, layout: &Layout, floor_z: Option<f64>, cell: (u32, u32)) {
    let Some(z) = floor_z else { return };
    let clip = layout.clip(cell);
    let (_, y) = layout.pixel(&[layout.center[0] as f32, 0.0, z as f32], cell);
    let y = y.round() as i64;
    for x in clip.x.0 + 1..clip.x.1 {
        for dy in 0..2 {
            canvas.disk((x as f64, (y + dy) as f64), 0.0, &clip, None, FLOOR);
        }
        // Hatches every 10 px, slanting down to the right.
        let phase = (x - clip.x.0) % 10;
        if phase < 6 {
            canvas.disk((x as f64, (y + 2 + phase) as f64), 0.0, &clip, None, FLOOR);
        }
    }
}

/// Each push: an arrow along its direction (as the page shows it) ending on the pushed point,
/// or a ring around the point where it pushes mostly into or out of the page.
fn draw_marks(canvas: &mut Canvas, layout: &Layout, frame: &StripFrame, cell: (u32, u32)) {
    let clip = layout.clip(cell);
    for mark in &frame.marks {
        let tip = layout.pixel(&mark.at, cell);
        let [dx, dy, dz] = mark.direction.map(f64::from);
        let (across, norm) = (
            (dx * dx + dz * dz).sqrt(),
            (dx * dx + dy * dy + dz * dz).sqrt(),
        );
        if norm == 0.0 {
            continue;
        }
        if across < 0.3 * norm {
            for i in 0..48 {
                let a = i as f64 * std::f64::consts::TAU / 48.0;
                let p = (tip.0 + 8.0 * a.cos(), tip.1 + 8.0 * a.sin());
                canvas.disk(p, 1.0, &clip, None, PUSH);
            }
            canvas.disk(tip, 2.0, &clip, None, PUSH);
            continue;
        }
        // Screen direction: x to the right, z up (pixels grow downwards).
        let (ux, uy) = (dx / across, -dz / across);
        for i in 0..=(ARROW as i64) {
            let t = i as f64;
            canvas.disk((tip.0 - ux * t, tip.1 - uy * t), 1.5, &clip, None, PUSH);
        }
        // The head: two strokes back from the tip, 30 degrees either side.
        let (c, s) = (0.866, 0.5);
        for (hx, hy) in [
            (ux * c - uy * s, uy * c + ux * s),
            (ux * c + uy * s, uy * c - ux * s),
        ] {
            for i in 0..10 {
                let t = i as f64;
                canvas.disk((tip.0 - hx * t, tip.1 - hy * t), 1.5, &clip, None, PUSH);
            }
        }
    }
}

/// Writes the frame's time centred above it and each object's name under its x centre.
fn draw_frame_text(canvas: &mut Canvas, layout: &Layout, frame: &StripFrame, cell: (u32, u32)) {
    let (left, top) = cell;
    let time = format!("t = {:.2} s", frame.time_s);
    let width = text_width(&time, layout.scale);
    let x = left as i64 + (layout.frame_width as i64 - width as i64) / 2;
    canvas.text(x, (top + PAD) as i64, &time, layout.scale);
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
                layout.pixel(&middle, cell).0,
                text_width(o.label, layout.scale),
            )
        })
        .collect();
    let span = (left as i64, (left + layout.frame_width) as i64);
    for (object, (x, row)) in frame.objects.iter().zip(place_names(&names, span)) {
        let y = top + layout.names_top + PAD + row * layout.line;
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
            marks: Vec::new(),
        }
    }

    fn decode(bytes: Vec<u8>) -> (usize, usize, Vec<u8>) {
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buffer).unwrap();
        (info.width as usize, info.height as usize, buffer)
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
        let legend = ["grey: rest pose".to_string()];
        let style = StripStyle {
            view: 160,
            columns: 4,
            floor_z: None,
            legend: &legend,
        };
        render_strip_png(&frames, &style, &mut bytes).unwrap();
        let (width, height, buffer) = decode(bytes);
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
        assert!(render_strip_png(&bad, &style, &mut Vec::new()).is_err());
    }

    #[test]
    fn frames_fill_rows_with_the_floor_and_the_pushes_drawn() {
        let rest = ring(0.0, 1.0);
        let colors = vec![[0.0, 0.0, 1.0]; 200];
        let mut frames: Vec<StripFrame> = (0..3)
            .map(|i| frame(i as f64, &rest, &rest, &colors))
            .collect();
        // Pushed sideways at the top, and into the page at the bottom.
        frames[1].marks = vec![
            StripMark {
                at: [0.0, 0.0, 1.0],
                direction: [1.0, 0.0, 0.0],
            },
            StripMark {
                at: [0.0, 0.0, -1.0],
                direction: [0.0, 1.0, 0.0],
            },
        ];
        let legend = ["one".to_string(), "two".to_string()];
        let style = StripStyle {
            view: 160,
            columns: 2,
            floor_z: Some(-1.0),
            legend: &legend,
        };
        let mut bytes = Vec::new();
        render_strip_png(&frames, &style, &mut bytes).unwrap();
        let (width, height, buffer) = decode(bytes);
        let line = (GLYPH_HEIGHT * 2 + 2 * PAD) as usize;
        let cell = line + 160 + 2 * line;
        assert_eq!(
            height,
            2 * cell + 2 * line + PAD as usize,
            "two rows, two lines of legend"
        );
        let frame_width = width / 2;
        let pixels: Vec<&[u8]> = buffer.chunks_exact(3).collect();
        let count = |xs: std::ops::Range<usize>, ys: std::ops::Range<usize>, color: [u8; 3]| {
            ys.flat_map(|y| xs.clone().map(move |x| y * width + x))
                .filter(|&i| pixels[i] == &color[..])
                .count()
        };
        assert_eq!(
            count(0..frame_width, 0..cell, PUSH),
            0,
            "no push in the first frame"
        );
        assert!(
            count(frame_width..width, 0..cell, PUSH) > 60,
            "arrow and ring in the second"
        );
        assert!(
            count(0..frame_width, cell..2 * cell, FLOOR) > frame_width,
            "the third's floor"
        );
        assert!(count(0..width, 2 * cell..height, INK) > 0, "the legend");
    }

    #[test]
    fn crowded_names_take_the_second_row_and_stay_in_the_frame() {
        let placed = place_names(&[(50.0, 40), (60.0, 40), (195.0, 40)], (0, 200));
        assert_eq!(placed[0], (30, 0));
        assert_eq!(placed[1].1, 1, "overlaps the first");
        assert_eq!(placed[2], (158, 0), "pushed back inside the frame");
    }
}
