//! Contact at rest: a ball placed on the floor of a scene should stay where it was put. Its
//! rotation on a plane is neutral, so anything that pushes it off centre (a centre of mass
//! off the ball's centre, a contact patch sampled unevenly) rolls it away.
//!
//! The grasp: the bundled gripper (config/scenes/grasp.yaml) closes on a soft block, lifts it
//! 0.2 m and holds it 10 s; the block should not move in the grip.
//!
//! Soft against soft (`soft_contact`): a block stacked on another and a ball dropped on a soft
//! slab, each against the FEM.

use std::sync::Arc;

use nalgebra::Vector3;
use serde::Serialize;

use super::soft_contact::{soft_contact, SoftContactRow};
use super::stats::quantile;
use crate::scene::{FieldCache, Scene, SceneFile, SceneOptions, DEFAULT_ROLLING_FRICTION};
use crate::skinning::NeuralModel;
use crate::Result;

/// Seconds the ball settles onto the floor before its motion is measured, and how long it is
/// measured (60 Hz steps).
const SETTLE_S: f64 = 0.5;
const MEASURE_S: f64 = 2.0;

/// One ball resting on the floor.
#[derive(Clone, Debug, Serialize)]
pub struct RestingBallRow {
    /// The ball's radius, m.
    pub radius_m: f64,
    /// "auto" (the scene's error budget picks) or a fixed "handles/cubature".
    pub size: String,
    /// The ball's Young's modulus, Pa.
    pub young_pa: f64,
    /// Rolling friction, m (the scene file's default unless 0 is named).
    pub rolling_friction_m: f64,
    /// The size the scene chose and why.
    pub decision: String,
    /// Largest sideways move of the ball's centroid over the measured seconds.
    pub drift_mm: f64,
    /// Median step time of the ball over the measured seconds, ms.
    pub step_ms_median: f64,
    /// 99th-percentile step time of the ball over the measured seconds, ms.
    pub step_ms_p99: f64,
}

/// The grasp: the block's centroid after the lift and its largest move in the next 10 s.
#[derive(Clone, Debug, Serialize)]
pub struct GraspRow {
    /// The scene's friction coefficient.
    pub friction: f64,
    /// How far the block rose with the fingers (0.2 m when it is held).
    pub lifted_m: f64,
    /// The block's largest move from where the lift left it, over the 10 s held, mm.
    pub drift_mm: f64,
    /// Median step time of the block over the 10 s held, ms.
    pub step_ms_median: f64,
    /// 99th-percentile step time of the block over the 10 s held, ms.
    pub step_ms_p99: f64,
}

/// The bundled grasp scene.
pub const GRASP: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/config/scenes/grasp.yaml");

/// What `bench contact` reports (serialized for `--json`): balls at rest on the
/// floor, the bundled grasp, and soft objects touching each other.
#[derive(Clone, Debug, Serialize)]
pub struct ContactReport {
    /// One row per ball, in the order [`run_contact_bench`] runs them.
    pub resting_ball: Vec<RestingBallRow>,
    /// With friction 0.5, then without.
    pub grasp: Vec<GraspRow>,
    /// The 0.1 m ball with the sizes a scene picks by itself.
    pub resting_ball_drift_mm: f64,
    /// The largest step p99 over every ball and grasp row, ms.
    pub step_ms_p99: f64,
    /// Soft against soft, one row per object: the stacked blocks, the ball on the slab, the
    /// ball on a rigid floor.
    pub soft: Vec<SoftContactRow>,
    /// The top block's sag against the FEM's, % of the FEM's.
    pub stack_sag_error_pct: Option<f64>,
    /// The ball's error on the soft slab over its error on a rigid floor at the slab's top.
    pub slab_error_ratio: Option<f64>,
    /// The block's largest move in the grip with friction 0.5 (the first grasp row), mm.
    pub grasp_drift_mm: Option<f64>,
}

/// The resting balls: 0.1 m and 0.05 m radius, sizes from the budget and the largest, soft
/// and stiff.
pub fn run_contact_bench(log: impl Fn(&str)) -> Result<ContactReport> {
    let model = Arc::new(NeuralModel::bundled()?);
    let cache = FieldCache::default();
    let mut rows = Vec::new();
    let rolling = DEFAULT_ROLLING_FRICTION;
    for (radius, size, young, rolling) in [
        (0.1, "auto", 1e5, rolling),
        (0.1, "auto", 1e5, 0.0),
        // MuJoCo's default rolling coefficient.
        (0.1, "auto", 1e5, 1e-4),
        (0.1, "17/256", 1e5, rolling),
        (0.1, "17/256", 1e5, 0.0),
        (0.1, "auto", 1e7, rolling),
        (0.05, "auto", 1e5, rolling),
    ] {
        let row = resting_ball(&model, &cache, radius, size, young, rolling)?;
        log(&format!(
            "ball r {radius} m, {size}, E {young:.0e}, rolling friction {rolling} m: moved {:.3} \
             mm, step p99 {:.3} ms",
            row.drift_mm, row.step_ms_p99
        ));
        rows.push(row);
    }
    let mut grasps = Vec::new();
    for friction in [0.5, 0.0] {
        let row = grasp(&model, &cache, friction)?;
        log(&format!(
            "grasp, friction {friction}: lifted {:.4} m, then moved {:.3} mm in 10 s",
            row.lifted_m, row.drift_mm
        ));
        grasps.push(row);
    }
    let (soft, sag_error, slab_ratio) = soft_contact(&model, &cache)?;
    for r in &soft {
        log(&format!(
            "{}: {} {:.3} % against the FEM, sag {:.2} mm (FEM {:.2} mm); step p99 {:.3} ms",
            r.scene, r.object, r.error_pct, r.sag_mm, r.fem_sag_mm, r.step_ms_p99
        ));
    }
    let p99 = rows
        .iter()
        .map(|r| r.step_ms_p99)
        .chain(grasps.iter().map(|g| g.step_ms_p99))
        .chain(soft.iter().map(|s| s.step_ms_p99))
        .fold(0.0, f64::max);
    Ok(ContactReport {
        resting_ball_drift_mm: rows[0].drift_mm,
        step_ms_p99: p99,
        resting_ball: rows,
        grasp_drift_mm: Some(grasps[0].drift_mm),
        grasp: grasps,
        soft,
        stack_sag_error_pct: Some(sag_error),
        slab_error_ratio: Some(slab_ratio),
    })
}

fn resting_ball(
    model: &Arc<NeuralModel>,
    cache: &FieldCache,
    radius: f64,
    size: &str,
    young: f64,
    rolling: f64,
) -> Result<RestingBallRow> {
    let sizes = match size.split_once('/') {
        Some((handles, cubature)) => format!("    handles: {handles}\n    cubature: {cubature}\n"),
        None => String::new(),
    };
    // Sleeping off: a sleeping ball is held still, which would hide the drift.
    let yaml = format!(
        "floor: 0\nsleep: null\nrolling_friction: {rolling}\nobjects:\n  - name: ball\n    shape: {{sphere: {radius}}}\n    \
         position: [0, 0, {radius}]\n    material: {{young: {young}}}\n{sizes}"
    );
    let file = SceneFile::parse(&yaml).map_err(|reason| crate::Error::InvalidParameter {
        name: "contact bench scene",
        reason,
    })?;
    let mut scene = Scene::build(&file, model, cache, &SceneOptions::default())?;
    run_for(&mut scene, SETTLE_S);
    // A ball rolls along the floor: its move in the floor's plane.
    let (drift, step_ms) = watch(&mut scene, "ball", MEASURE_S, |moved| moved.xy().norm());
    let decision = scene
        .body("ball")
        .map(|b| b.decision().to_string())
        .unwrap_or_default();
    Ok(RestingBallRow {
        radius_m: radius,
        size: size.to_string(),
        young_pa: young,
        rolling_friction_m: rolling,
        decision,
        drift_mm: drift * 1e3,
        step_ms_median: quantile(&step_ms, 0.5),
        step_ms_p99: quantile(&step_ms, 0.99),
    })
}

/// The grasp scene with `friction`: 2.5 s to close and lift, then 10 s held.
fn grasp(model: &Arc<NeuralModel>, cache: &FieldCache, friction: f64) -> Result<GraspRow> {
    let mut file = SceneFile::load(std::path::Path::new(GRASP))?;
    file.friction = friction;
    let mut scene = Scene::build(&file, model, cache, &SceneOptions::default())?;
    let start = centroid(&scene, "block");
    run_for(&mut scene, 2.5);
    let lifted = centroid(&scene, "block");
    let (drift, step_ms) = watch(&mut scene, "block", 10.0, |moved| moved.norm());
    Ok(GraspRow {
        friction,
        lifted_m: lifted.z - start.z,
        drift_mm: drift * 1e3,
        step_ms_median: quantile(&step_ms, 0.5),
        step_ms_p99: quantile(&step_ms, 0.99),
    })
}

/// Steps `scene` for `seconds`.
fn run_for(scene: &mut Scene, seconds: f64) {
    for _ in 0..(seconds / scene.dt()).round() as usize {
        scene.step();
    }
}

/// Steps `scene` for `seconds`, watching object `name`: the largest `distance` of its centroid
/// from where it was at the start (m), and each step's time (ms).
fn watch(
    scene: &mut Scene,
    name: &str,
    seconds: f64,
    distance: impl Fn(Vector3<f64>) -> f64,
) -> (f64, Vec<f64>) {
    let start = centroid(scene, name);
    let mut largest: f64 = 0.0;
    let mut step_ms = Vec::new();
    for _ in 0..(seconds / scene.dt()).round() as usize {
        scene.step();
        largest = largest.max(distance(centroid(scene, name) - start));
        if let Some(report) = scene.body(name).and_then(|b| b.last_step()) {
            step_ms.push(report.seconds * 1e3);
        }
    }
    (largest, step_ms)
}

fn centroid(scene: &Scene, name: &str) -> Vector3<f64> {
    let points = scene.points(name).unwrap_or_default();
    let n = (points.len() / 3).max(1) as f64;
    points
        .chunks(3)
        .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .sum::<Vector3<f64>>()
        / n
}
