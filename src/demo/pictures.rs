//! The demo's pictures: the grid of frames (each frame's time, each object's name, its rest
//! pose ghosted behind it, the pokes since the frame before, the ground, a legend) and the plot of each shape's displacement over time, the
//! replay's against the FEM's.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::DMatrix;

use super::reference::ReferenceError;
use super::script::{DemoPoke, DEMO_START_NS};
use crate::io::{
    line_plot_svg, render_strip_png, weight_colors, LineSeries, Panel, StripFrame, StripMark,
    StripObject, StripStyle,
};
use crate::pipeline::SoftBody;
use crate::replay::Tick;
use crate::{Error, Result};

/// Height of each frame's scene, px.
const VIEW: u32 = 240;
/// Frames per row: two rows of three would be 2000 px wide, and a README shows the picture
/// at well under half that.
const COLUMNS: u32 = 2;
/// One colour per shape in the plot (the replay's line and the FEM's share it).
const COLORS: [&str; 5] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];

/// How one body looks in every frame: its name, its points' colours, its rest pose.
struct Look {
    label: String,
    colors: Vec<[f64; 3]>,
    /// x, y, z per point.
    rest: Vec<f32>,
    /// Handles, the constant one included, for the legend.
    handles: usize,
}

/// One frame of the strip.
struct Frame {
    /// Seconds since the recording's start.
    time_s: f64,
    /// Each body's id and deformed points.
    bodies: Vec<(u32, Vec<f32>)>,
    /// The pokes since the frame before: where the poked point is now, and the force.
    marks: Vec<([f32; 3], [f32; 3])>,
}

/// The strip's frames, captured during the replay at the times due.
pub(crate) struct Capture {
    /// Log times still to capture, ns, earliest first.
    due: Vec<i64>,
    /// The script's name of each frame's shape, where it has one.
    names: BTreeMap<String, String>,
    looks: BTreeMap<u32, Look>,
    frames: Vec<Frame>,
    /// The script's pokes, marked in the first frame after each starts.
    pokes: Vec<DemoPoke>,
}

impl Capture {
    /// Captures at the log times `due` (ns, earliest first); `names` gives the script's name of
    /// a frame's shape (frame -> name).
    pub(crate) fn new(
        due: Vec<i64>,
        names: BTreeMap<String, String>,
        pokes: Vec<DemoPoke>,
    ) -> Self {
        Self {
            due,
            names,
            looks: BTreeMap::new(),
            frames: Vec::new(),
            pokes,
        }
    }

    /// After a tick of the replay: captures a frame if one is due.
    pub(crate) fn observe(&mut self, tick: &Tick) {
        if self.due.first().is_none_or(|&d| tick.time_ns < d - 1) {
            return;
        }
        self.due.remove(0);
        let mut bodies = Vec::new();
        let time_s = (tick.time_ns - DEMO_START_NS) as f64 * 1e-9;
        let since = self.frames.last().map_or(f64::NEG_INFINITY, |f| f.time_s);
        let mut marks = Vec::new();
        for b in tick.stage.bodies() {
            let label = self.label(&b.frame);
            let look = self
                .looks
                .entry(b.id)
                .or_insert_with(|| look(label, &b.body));
            let deformed = b.body.deformed();
            for poke in self.pokes.iter().filter(|p| p.frame == b.frame) {
                if poke.at_s > since && poke.at_s <= time_s {
                    let at = nearest(&look.rest, &poke.point.cast::<f32>().into());
                    let now = [deformed[3 * at], deformed[3 * at + 1], deformed[3 * at + 2]];
                    marks.push((now, poke.force.cast::<f32>().into()));
                }
            }
            bodies.push((b.id, deformed.to_vec()));
        }
        self.frames.push(Frame {
            time_s,
            bodies,
            marks,
        });
    }

    /// Writes the strip of the captured frames to `path` (PNG).
    pub(crate) fn write_strip(&self, path: &Path) -> Result<()> {
        let frames: Vec<StripFrame> = self
            .frames
            .iter()
            .map(|f| StripFrame {
                time_s: f.time_s,
                objects: f
                    .bodies
                    .iter()
                    .map(|(id, positions)| {
                        let look = &self.looks[id];
                        StripObject {
                            label: look.label.as_str(),
                            positions: positions.as_slice(),
                            colors: look.colors.as_slice(),
                            rest: Some(look.rest.as_slice()),
                        }
                    })
                    .collect(),
                marks: (f.marks.iter())
                    .map(|&(at, direction)| StripMark { at, direction })
                    .collect(),
            })
            .collect();
        // The objects stand on their pinned bottoms: the ground is the lowest rest point.
        let floor_z = (self.looks.values())
            .flat_map(|l| l.rest.chunks_exact(3).map(|p| p[2] as f64))
            .fold(f64::INFINITY, f64::min);
        let legend = self.legend();
        let style = StripStyle {
            view: VIEW,
            columns: COLUMNS,
            floor_z: floor_z.is_finite().then_some(floor_z),
            legend: &legend,
        };
        let mut file = create(path)?;
        render_strip_png(&frames, &style, &mut file)
            .map_err(|e| Error::Geometry(format!("demo picture: {e}")))
    }

    /// An object's name in the strip: its frame, after the script's name when that differs (the
    /// block comes in the "world" frame).
    fn label(&self, frame: &str) -> String {
        match self.names.get(frame) {
            Some(name) if name != frame => format!("{name} ({frame})"),
            _ => frame.to_string(),
        }
    }

    /// The legend's lines: what the colours, the grey, the red and the ground mean.
    fn legend(&self) -> Vec<String> {
        let learned = self
            .looks
            .values()
            .map(|l| l.handles.saturating_sub(1))
            .max()
            .unwrap_or(0);
        // Says what weight_colors does: a hue per learned handle, blended by the squared
        // positive weights, the constant handle left out.
        vec![
            format!(
                "colour: each point's dominant skinning handles ({learned} learned, one hue \
                 each, blended by squared weight; the constant one left out)"
            ),
            "light grey: rest pose; red: a poke since the frame before (a ring: into or out of \
             the page); hatched line: the ground the objects are held on"
                .to_string(),
        ]
    }
}

/// The index of the point of `points` (x, y, z each) nearest to `p`.
fn nearest(points: &[f32], p: &[f32; 3]) -> usize {
    let d = |q: &[f32]| (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f32>();
    (points.chunks_exact(3).enumerate())
        .min_by(|a, b| d(a.1).total_cmp(&d(b.1)))
        .map_or(0, |(i, _)| i)
}

/// A body's look, taken when it first appears in a frame.
fn look(label: String, body: &SoftBody) -> Look {
    // The rest pose is the lift of the zero state: the state holds each handle's displacement
    // from the identity, so zero is every point where it arrived, before any motion.
    let state = body.state();
    let zero = DMatrix::<f64>::zeros(state.nrows(), state.ncols());
    let mut rest = vec![0.0f32; 3 * body.lifter().len()];
    body.lifter().lift(&zero, &mut rest);
    Look {
        label,
        colors: weight_colors(body.weights(), body.handles()),
        rest,
        handles: body.handles(),
    }
}

/// Where the displacement plot goes: beside the strip, named from it (`demo.png` becomes
/// `demo_displacement.svg`).
pub(crate) fn displacement_path(picture: &Path) -> PathBuf {
    let stem = picture
        .file_stem()
        .map_or_else(|| "demo".to_string(), |s| s.to_string_lossy().into_owned());
    picture.with_file_name(format!("{stem}_displacement.svg"))
}

/// Writes the plot of each shape's displacement over time to `path` (SVG): a panel per shape,
/// the replay solid and the FEM dashed, in mm.
pub(crate) fn write_displacement_plot(errors: &[ReferenceError], path: &Path) -> Result<()> {
    let panels: Vec<Panel> = errors
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let color = COLORS[i % COLORS.len()];
            let d = &e.displacement;
            Panel {
                title: e.frame.as_str(),
                series: vec![
                    LineSeries {
                        label: "reduced simulation (replay)",
                        color,
                        dashed: false,
                        points: in_mm(&d.times_s, &d.reduced_m),
                    },
                    LineSeries {
                        label: "full-space FEM",
                        color,
                        dashed: true,
                        points: in_mm(&d.times_s, &d.fem_m),
                    },
                ],
            }
        })
        .collect();
    let svg = line_plot_svg(
        "Displacement over time: reduced simulation (solid) against the full-space FEM (dashed)",
        "time since the recording's start (s)",
        "RMS displacement from rest (mm)",
        &panels,
    );
    let mut file = create(path)?;
    file.write_all(svg.as_bytes()).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })
}

/// (time, displacement in mm) points from times and displacements in m.
fn in_mm(times_s: &[f64], metres: &[f64]) -> Vec<(f64, f64)> {
    times_s
        .iter()
        .zip(metres)
        .map(|(&t, &m)| (t, m * 1e3))
        .collect()
}

/// Creates `path` (and its folder), empty.
fn create(path: &Path) -> Result<std::fs::File> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::Io {
            path: dir.into(),
            source: e,
        })?;
    }
    std::fs::File::create(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plot_is_named_from_the_picture() {
        assert_eq!(
            displacement_path(Path::new("target/demo/demo.png")),
            Path::new("target/demo/demo_displacement.svg")
        );
        assert_eq!(
            displacement_path(Path::new("strip.png")),
            Path::new("strip_displacement.svg")
        );
    }
}
