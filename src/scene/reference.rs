//! A scene's accuracy: each recorded object again in the full-space FEM, under the same robot
//! links, attachment motion, floor, pins and obstacles, step for step. The recorded objects
//! step together and collide with each other's FEM surfaces (their hulls), as the reduced
//! objects collide with each other's contact hulls.

use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;
use serde::Serialize;

use super::world::{with_others, Scene, Setup};
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
    /// The deformable objects' hulls the reduced step collided with, by object index.
    hulls: Vec<(usize, Obstacle)>,
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
    /// How far the object's points sank on average (rest height minus height, along -z) at
    /// the last step compared, m: a resting object's sag.
    pub sag_m: f64,
    /// The same in the FEM, m.
    pub fem_sag_m: f64,
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
                hulls: scene.soft_hulls.clone(),
                motion: scene.attachment_motion(t.object),
                reduced,
            });
        }
    }
}

/// Each recorded object's error against the full-space FEM (in parallel), in recording order.
/// The FEM runs step together: each collides with the others' FEM hulls where they are, and
/// with the hulls of deformable objects that were not recorded as the reduced run had them.
pub fn reference_errors(recorder: &Recorder) -> Result<Vec<ObjectError>> {
    let mut runs: Vec<FemRun> = recorder
        .tracks
        .par_iter()
        .map(FemRun::new)
        .collect::<Result<_>>()?;
    let frames = recorder.tracks.first().map_or(0, |t| t.frames.len());
    for k in 0..frames {
        // A run's hull is for the other runs: a lone run needs none.
        let fem_hulls: Vec<(usize, Obstacle)> = if runs.len() > 1 {
            runs.par_iter()
                .filter_map(|r| Some((r.object, r.hull()?)))
                .collect()
        } else {
            Vec::new()
        };
        runs.par_iter_mut()
            .zip(&recorder.tracks)
            .try_for_each(|(run, t)| run.step(&t.frames[k], &fem_hulls))?;
    }
    Ok(runs
        .into_iter()
        .zip(&recorder.tracks)
        .map(|(run, t)| run.error(t))
        .collect())
}

/// One recorded object in the FEM, stepping frame by frame.
struct FemRun {
    object: usize,
    fem: FemSim,
    attached: Vec<usize>,
    squared: f64,
    compared: usize,
    times: Vec<f64>,
    /// Mean sag of the reduced run and the FEM at the last step compared, m.
    sag: (f64, f64),
}

impl FemRun {
    fn new(t: &Track) -> Result<Self> {
        let setup = &t.setup;
        let vertices = &t.mesh.vertices;
        let mut fem = FemSim::new(t.mesh.clone(), setup.sim.clone())?;
        let g = setup.sim.gravity;
        match setup.support {
            Support::PinBottom => fem.pin_vertices(&bottom_vertices(&t.mesh, &g)),
            Support::PinTop => fem.pin_vertices(&bottom_vertices(&t.mesh, &-g)),
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
        Ok(Self {
            object: t.object,
            fem,
            attached,
            squared: 0.0,
            compared: 0,
            sag: (f64::NAN, f64::NAN),
            times: Vec::with_capacity(t.frames.len()),
        })
    }

    /// The convex hull of the FEM surface where it is now.
    fn hull(&self) -> Option<Obstacle> {
        let x = self.fem.positions();
        let surface: Vec<Vector3<f64>> = self
            .fem
            .mesh()
            .boundary_vertices
            .iter()
            .map(|&v| {
                Vector3::new(
                    x[3 * v as usize],
                    x[3 * v as usize + 1],
                    x[3 * v as usize + 2],
                )
            })
            .collect();
        Obstacle::hull_of(&surface)
    }

    /// One step under `frame`, the recorded objects' hulls replaced by their FEM's.
    fn step(&mut self, frame: &Frame, fem_hulls: &[(usize, Obstacle)]) -> Result<()> {
        let hulls: Vec<(usize, Obstacle)> = frame
            .hulls
            .iter()
            .map(|(i, h)| {
                let fem = fem_hulls.iter().find(|(j, _)| j == i);
                (*i, fem.map_or(h, |(_, f)| f).clone())
            })
            .collect();
        self.fem
            .set_colliders(with_others(&frame.colliders, &hulls, self.object));
        if let Some(m) = &frame.motion {
            self.fem.move_pinned(&self.attached, m);
        }
        self.times.push(self.fem.step()?.seconds * 1e3);
        if let Some(reduced) = &frame.reduced {
            let fem = self.fem.positions();
            self.squared += reduced
                .iter()
                .zip(fem)
                .map(|(r, f)| (*r as f64 - f).powi(2))
                .sum::<f64>();
            self.compared += 1;
            let rest = &self.fem.mesh().vertices;
            let sag = |z: &dyn Fn(usize) -> f64| {
                rest.iter()
                    .enumerate()
                    .map(|(v, x)| x.z - z(v))
                    .sum::<f64>()
                    / rest.len() as f64
            };
            self.sag = (
                sag(&|v| reduced[3 * v + 2] as f64),
                sag(&|v| fem[3 * v + 2]),
            );
        }
        Ok(())
    }

    fn error(mut self, t: &Track) -> ObjectError {
        self.times.sort_by(f64::total_cmp);
        let vertices = t.mesh.vertices.len();
        let samples = (self.compared * vertices).max(1) as f64;
        ObjectError {
            name: t.name.clone(),
            vertices,
            steps: self.compared,
            error_pct: (self.squared / samples).sqrt() / t.diagonal * 100.0,
            fem_step_ms: self
                .times
                .get(self.times.len() / 2)
                .copied()
                .unwrap_or(f64::NAN),
            sag_m: self.sag.0,
            fem_sag_m: self.sag.1,
        }
    }
}
