//! A scene's accuracy: each recorded object again in the full-space FEM, under the same robot
//! links, attachment motion, floor, pins and obstacles, step for step.

use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;
use serde::Serialize;

use super::world::{Scene, Setup};
use super::SceneError;
use crate::geometry::TetMesh;
use crate::geometry::{bottom_vertices, reference_mesh};
use crate::physics::{FemSim, Lifter, Obstacle};
use crate::pipeline::Support;
use crate::Result;

/// Records, step by step, what some objects of a scene did and what acted on them.
pub struct Recorder {
    tracks: Vec<Track>,
}

struct Track {
    object: usize,
    name: String,
    mesh: Arc<TetMesh>,
    diagonal: f64,
    lifter: Lifter,
    setup: Setup,
    frames: Vec<Frame>,
}

struct Frame {
    colliders: Vec<Obstacle>,
    motion: Option<Isometry3<f64>>,
    /// The reduced body at the FEM mesh's vertices, on steps that count.
    reduced: Option<Vec<f32>>,
}

/// One object's error against the FEM: RMS distance over vertices and compared steps, % of its
/// bounding diagonal.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectError {
    /// The object's name.
    pub name: String,
    /// Vertices of its FEM mesh, where the two are compared.
    pub vertices: usize,
    /// Steps compared.
    pub steps: usize,
    /// RMS distance between the reduced body and the FEM, % of its bounding diagonal.
    pub error_pct: f64,
    /// The FEM's median step time, ms.
    pub fem_step_ms: f64,
}

impl Recorder {
    /// Tracks the deformable objects named (each gets a tetrahedral mesh of its interior).
    pub fn new(scene: &Scene, names: &[String]) -> Result<Self> {
        let mut tracks = Vec::new();
        for name in names {
            let (object, o) = scene
                .objects
                .iter()
                .enumerate()
                .find(|(_, o)| o.name == *name)
                .ok_or_else(|| SceneError::Object {
                    object: name.clone(),
                    reason: "not in the scene".into(),
                })?;
            let (Some(body), Some(setup)) = (&o.body, &o.setup) else {
                return Err(SceneError::Object {
                    object: name.clone(),
                    reason: "not deformable: nothing to compare".into(),
                }
                .into());
            };
            let reference = reference_mesh(&setup.shape);
            tracks.push(Track {
                object,
                name: name.clone(),
                lifter: body.lifter_for(&reference.mesh.vertices),
                mesh: reference.mesh.clone(),
                diagonal: reference.diagonal,
                setup: setup.clone(),
                frames: Vec::new(),
            });
        }
        Ok(Self { tracks })
    }

    /// After a scene step (or a settling step): what acted on each object, and, when `compare`,
    /// where it is.
    pub fn record(&mut self, scene: &Scene, compare: bool) {
        let colliders = scene.colliders();
        for t in &mut self.tracks {
            let body = scene.objects[t.object]
                .body
                .as_ref()
                .expect("tracks are deformable");
            let reduced = compare.then(|| {
                let mut x = vec![0.0f32; 3 * t.lifter.len()];
                t.lifter.lift(body.state(), &mut x);
                x
            });
            t.frames.push(Frame {
                colliders: colliders.clone(),
                motion: scene.attachment_motion(t.object),
                reduced,
            });
        }
    }
}

/// Runs the FEM of every tracked object (in parallel) and compares.
pub fn reference_errors(recorder: &Recorder) -> Result<Vec<ObjectError>> {
    recorder.tracks.par_iter().map(fem_error).collect()
}

fn fem_error(t: &Track) -> Result<ObjectError> {
    let setup = &t.setup;
    let vertices = &t.mesh.vertices;
    let mut fem = FemSim::new(t.mesh.clone(), setup.sim.clone())?;
    let g = setup.sim.gravity;
    match setup.support {
        Support::PinBottom => fem.pin_vertices(&bottom_vertices(vertices, &g)),
        Support::PinTop => fem.pin_vertices(&bottom_vertices(vertices, &-g)),
        Support::Free | Support::Floor => {}
    }
    if let Some(z) = setup.floor {
        fem.add_obstacle(Obstacle::floor(z));
    }
    for o in &setup.obstacles {
        fem.add_obstacle(o.clone());
    }
    let within = |center: [f64; 3], radius: f64| -> Result<Vec<usize>> {
        let c = Vector3::from(center);
        let found: Vec<usize> = (0..vertices.len())
            .filter(|&i| (vertices[i] - c).norm() <= radius)
            .collect();
        if found.is_empty() {
            return Err(SceneError::Object {
                object: t.name.clone(),
                reason: format!("no FEM vertex within {radius} m of {center:?}"),
            }
            .into());
        }
        Ok(found)
    };
    for pin in &setup.pins {
        fem.pin_vertices(&within(pin.center, pin.radius)?);
    }
    let attached = match &setup.attach {
        Some(r) => within(r.center, r.radius)?,
        None => Vec::new(),
    };
    let mut squared = 0.0;
    let mut compared = 0usize;
    let mut times = Vec::with_capacity(t.frames.len());
    for frame in &t.frames {
        fem.set_colliders(frame.colliders.clone());
        if let Some(m) = &frame.motion {
            fem.move_pinned(&attached, m);
        }
        times.push(fem.step()?.seconds * 1e3);
        if let Some(reduced) = &frame.reduced {
            squared += reduced
                .iter()
                .zip(fem.positions())
                .map(|(r, f)| (*r as f64 - f).powi(2))
                .sum::<f64>();
            compared += 1;
        }
    }
    times.sort_by(f64::total_cmp);
    let samples = (compared * vertices.len()).max(1) as f64;
    Ok(ObjectError {
        name: t.name.clone(),
        vertices: vertices.len(),
        steps: compared,
        error_pct: (squared / samples).sqrt() / t.diagonal * 100.0,
        fem_step_ms: times.get(times.len() / 2).copied().unwrap_or(f64::NAN),
    })
}
