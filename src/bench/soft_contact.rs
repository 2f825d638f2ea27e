//! `bench contact`'s soft-against-soft rows: a soft block stacked on another and a ball dropped
//! on a soft slab, each against the FEM, whose objects collide with each other the same way.

use std::sync::Arc;

use serde::Serialize;

use super::scene::{run_scene, SceneRunOptions};
use crate::scene::{FieldCache, SceneFile, SceneOptions};
use crate::skinning::NeuralModel;
use crate::Result;

/// A 0.16 m block set 5 mm above a 0.2 m one on the floor.
const STACK: &str = "floor: 0\nobjects:\n  \
    - {name: bottom, shape: {box: [0.2, 0.2, 0.2]}, position: [0, 0, 0.1], material: {young: 1.0e5}, handles: 17, cubature: 256}\n  \
    - {name: top, shape: {box: [0.16, 0.16, 0.16]}, position: [0, 0, 0.285], material: {young: 1.0e5}, handles: 17, cubature: 256}\n";
/// A 5 cm ball dropped 9 cm onto a 6 cm soft slab on the floor.
const SLAB: &str = "floor: 0\nobjects:\n  \
    - {name: slab, shape: {box: [0.4, 0.4, 0.06]}, position: [0, 0, 0.03], material: {young: 3.0e4}, handles: 17, cubature: 256}\n  \
    - {name: ball, shape: {sphere: 0.05}, position: [0, 0, 0.2], material: {young: 1.0e5}, handles: 17, cubature: 256}\n";
/// The same ball dropped onto a rigid floor at the slab's top.
const RIGID: &str = "floor: 0.06\nobjects:\n  \
    - {name: ball, shape: {sphere: 0.05}, position: [0, 0, 0.2], material: {young: 1.0e5}, handles: 17, cubature: 256}\n";

/// One object of a soft-contact scene against its FEM.
#[derive(Clone, Debug, Serialize)]
pub struct SoftContactRow {
    /// Which scene: `stack`, `slab` or `rigid floor`.
    pub scene: String,
    /// The object.
    pub object: String,
    /// Its error against the FEM, % of its bounding diagonal.
    pub error_pct: f64,
    /// How far its points sank on average at the end, mm.
    pub sag_mm: f64,
    /// The same in the FEM, mm.
    pub fem_sag_mm: f64,
    /// The scene's mean step, ms.
    pub step_ms: f64,
    /// 99th percentile of the scene step, ms.
    pub step_ms_p99: f64,
}

/// The three scenes' rows, the top block's sag error (% of the FEM's sag) and the ball's
/// error on the slab over its error on the rigid floor.
pub fn soft_contact(
    model: &Arc<NeuralModel>,
    cache: &FieldCache,
) -> Result<(Vec<SoftContactRow>, f64, f64)> {
    let mut rows = run("stack", STACK, &["bottom", "top"], 1.0, 60, model, cache)?;
    rows.extend(run("slab", SLAB, &["slab", "ball"], 1.5, 0, model, cache)?);
    rows.extend(run("rigid floor", RIGID, &["ball"], 1.5, 0, model, cache)?);
    let find = |scene: &str, object: &str| {
        rows.iter()
            .find(|r| r.scene == scene && r.object == object)
            .expect("compared")
    };
    let top = find("stack", "top");
    let sag_error = (top.sag_mm - top.fem_sag_mm).abs() / top.fem_sag_mm * 100.0;
    let ratio = find("slab", "ball").error_pct / find("rigid floor", "ball").error_pct;
    Ok((rows, sag_error, ratio))
}

fn run(
    name: &str,
    yaml: &str,
    compare: &[&str],
    seconds: f64,
    settle_steps: usize,
    model: &Arc<NeuralModel>,
    cache: &FieldCache,
) -> Result<Vec<SoftContactRow>> {
    let file = SceneFile::parse(yaml).map_err(|reason| crate::Error::InvalidParameter {
        name: "soft contact bench scene",
        reason,
    })?;
    let options = SceneRunOptions {
        scene: SceneOptions::default(),
        seconds,
        settle_steps,
        settle_exactly: true,
        compare: compare.iter().map(|s| s.to_string()).collect(),
    };
    let run = run_scene(&file, model, cache, &options)?;
    Ok(run
        .errors
        .iter()
        .map(|e| SoftContactRow {
            scene: name.to_string(),
            object: e.name.clone(),
            error_pct: e.error_pct,
            sag_mm: e.sag_m * 1e3,
            fem_sag_mm: e.fem_sag_m * 1e3,
            step_ms: run.step_ms,
            step_ms_p99: run.step_ms_p99,
        })
        .collect())
}
