//! The demo: the bundled recording `bags/demo.mcap` (three shapes arriving as a cloud, a
//! stamped mesh and a mesh, then pokes) replayed through the node's pipeline, recorded to MCAP,
//! checked against the full-space FEM, and drawn as a grid of frames beside a plot of each
//! shape's displacement against the FEM's.

mod pictures;
pub(crate) mod reference;
mod script;

use std::path::PathBuf;
use std::sync::Arc;

use serde::Serialize;

pub use script::{write_demo_bag, DemoScript, DEMO_START_NS};

use crate::bag::RecordOptions;
use crate::replay::{replay, ReplayOptions, ReplaySummary, ShapeSummary, Tick};
use crate::runtime::NodeParams;
use crate::skinning::NeuralModel;
use crate::{Error, Result};

/// The bundled demo recording (`bags/demo.mcap`), compiled into the binary so that a moved or
/// installed binary still has its demo.
pub const DEMO_BAG: &[u8] = include_bytes!("../../bags/demo.mcap");

/// What the demo reads and writes.
#[derive(Clone, Debug)]
pub struct DemoOptions {
    /// The input recording. Default (None) the bundled `bags/demo.mcap`, [`DEMO_BAG`].
    pub input: Option<PathBuf>,
    /// The output recording (inputs and every output topic). Default target/demo/demo_out.mcap.
    pub out: PathBuf,
    /// The grid of frames. Default target/demo/demo.png.
    pub picture: PathBuf,
    /// Frames in the picture. Default 6.
    pub frames: usize,
    /// Run the FEM reference (only meaningful for the bundled recording). Default true.
    pub reference: bool,
    /// None: as fast as possible; Some(r): r times real time.
    pub pace: Option<f64>,
}

impl Default for DemoOptions {
    fn default() -> Self {
        Self {
            input: None,
            out: "target/demo/demo_out.mcap".into(),
            picture: "target/demo/demo.png".into(),
            frames: 6,
            reference: true,
            pace: None,
        }
    }
}

/// One shape of the demo: the replay's figures and the FEM's.
#[derive(Clone, Debug, Serialize)]
pub struct DemoShapeRow {
    /// The replay's figures for the shape, flattened into this object.
    #[serde(flatten)]
    pub replay: ShapeSummary,
    /// Vertices of the FEM reference mesh (0 without the reference).
    pub fem_vertices: usize,
    /// Median step of the FEM reference, ms (NaN without the reference).
    pub fem_step_ms: f64,
    /// RMS distance to the FEM over the reference mesh's vertices and all steps, % of the
    /// shape's bounding diagonal (NaN without the reference).
    pub error_pct: f64,
}

/// What the demo did (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    /// One row per object the replay built.
    pub shapes: Vec<DemoShapeRow>,
    /// The replay's summary.
    pub replay: ReplaySummary,
    /// The output recording written.
    pub output: PathBuf,
    /// The grid of frames written.
    pub picture: PathBuf,
    /// Each shape's displacement over time against the FEM's (SVG beside the picture, named
    /// from it); None without the FEM reference.
    pub displacement_plot: Option<PathBuf>,
}

/// Runs the demo.
pub fn run_demo(options: &DemoOptions, model: &Arc<NeuralModel>) -> Result<DemoSummary> {
    let (bytes, name) = match &options.input {
        Some(path) => {
            let bytes = std::fs::read(path).map_err(|e| Error::Io {
                path: path.clone(),
                source: e,
            })?;
            (std::borrow::Cow::Owned(bytes), path.display().to_string())
        }
        None => (DEMO_BAG.into(), "bags/demo.mcap (bundled)".to_string()),
    };
    let params = NodeParams::default();
    let script = DemoScript::new();
    let mut trajectories = if options.reference {
        script
            .shapes
            .iter()
            .map(reference::Trajectory::new)
            .collect::<Result<Vec<_>>>()?
    } else {
        Vec::new()
    };
    // Frames of the picture: evenly spaced over the script's span and the replay's tail.
    let replay_options = ReplayOptions {
        params: params.clone(),
        record: Some(RecordOptions {
            path: options.out.clone(),
            ..Default::default()
        }),
        pace: options.pace,
        ..Default::default()
    };
    let last_input = script
        .pokes
        .iter()
        .map(|p| p.at_s)
        .chain(script.shapes.iter().map(|s| s.at_s))
        .fold(0.0, f64::max);
    let span_ns = ((last_input + replay_options.tail_s) * 1e9) as i64;
    let frames = options.frames.max(1);
    let due: Vec<i64> = (0..frames)
        .map(|i| DEMO_START_NS + span_ns * (2 * i as i64 + 1) / (2 * frames as i64))
        .collect();
    let names = script
        .shapes
        .iter()
        .map(|s| (s.frame.to_string(), s.name.to_string()))
        .collect();
    let mut capture = pictures::Capture::new(due, names, script.pokes.clone());
    let mut observe = |tick: &Tick| {
        for t in &mut trajectories {
            if let Some(b) = tick.stage.bodies().iter().find(|b| b.frame == t.frame) {
                t.record(tick.time_ns, &b.body);
            }
        }
        capture.observe(tick);
    };
    let summary = replay(&bytes, &name, model, &replay_options, &mut observe)?;

    let errors = if options.reference {
        let period = (1e9 / params.rate_hz) as i64;
        reference::reference_errors(&trajectories, &script, &params.sim_params(), period)?
    } else {
        Vec::new()
    };
    let shapes = summary
        .shapes
        .iter()
        .map(|s| {
            let fem = errors.iter().find(|e| e.frame == s.frame);
            DemoShapeRow {
                replay: s.clone(),
                fem_vertices: fem.map_or(0, |e| e.vertices),
                fem_step_ms: fem.map_or(f64::NAN, |e| e.fem_step_ms),
                error_pct: fem.map_or(f64::NAN, |e| e.error_pct),
            }
        })
        .collect();

    capture.write_strip(&options.picture)?;
    // Only the FEM reference has the displacement series the plot draws.
    let displacement_plot = if options.reference {
        let path = pictures::displacement_path(&options.picture);
        pictures::write_displacement_plot(&errors, &path)?;
        Some(path)
    } else {
        None
    };
    Ok(DemoSummary {
        shapes,
        replay: summary,
        output: options.out.clone(),
        picture: options.picture.clone(),
        displacement_plot,
    })
}
