//! A scene on the stage: its deformable objects stepped with the other bodies under shape ids
//! of their own, its robots moved by their joint-state topics, its steps published in its
//! frame.

use std::collections::HashSet;

use super::markers::MarkerSurface;
use super::outputs::{DeformedCloud, Outputs};
use crate::msg::{JointState, Status};
use crate::physics::Obstacle;
use crate::pipeline::SoftBody;
use crate::scene::Scene;

/// A scene's objects and robots, stepped with the other bodies.
pub(crate) struct SceneOnStage {
    scene: Scene,
    first_id: u32,
    frame: String,
    /// Its last step is computed but not yet published.
    unpublished: bool,
    /// Joint-state problems already reported (each once, not at the topic's rate).
    reported: HashSet<String>,
    /// Each object's surface for its markers (empty when markers are off).
    surfaces: Vec<MarkerSurface>,
}

impl SceneOnStage {
    /// `scene` with shape ids from `first_id`, published in `frame` (with surface markers when
    /// `markers`); its objects are announced with their weights and what was decided for each.
    pub fn new(
        scene: Scene,
        first_id: u32,
        frame: String,
        markers: bool,
        outputs: &Outputs,
    ) -> Self {
        let mut s = Self {
            scene,
            first_id,
            frame,
            unpublished: false,
            reported: HashSet::new(),
            surfaces: Vec::new(),
        };
        if markers {
            // The boundary of each object's solid, as for a cloud: a scene's shapes may be
            // primitives or meshes of many triangles.
            s.surfaces = s
                .bodies()
                .map(|(_, _, b)| MarkerSurface::of(b, &[]))
                .collect();
        }
        for (id, name, body) in s.bodies() {
            // Before any step the deformed points are the rest points the weights belong to.
            let rest = body.deformed().to_vec();
            outputs.publish_weights(id, &s.frame, &rest, body.weights(), body.handles());
            let decided = format!("scene object `{name}`: {}", body.decision());
            outputs.report(Status::INFO, id, "shape_ready", decided);
        }
        s
    }

    /// (shape id, name, body) of each deformable object.
    pub fn bodies(&self) -> impl Iterator<Item = (u32, &str, &SoftBody)> {
        let first = self.first_id;
        self.scene
            .bodies_named()
            .enumerate()
            .map(move |(i, (name, body))| (first + i as u32, name, body))
    }

    /// (shape id, frame, body) of each deformable object, to act on.
    pub fn bodies_mut(&mut self) -> impl Iterator<Item = (u32, &str, &mut SoftBody)> {
        let (first, frame) = (self.first_id, self.frame.as_str());
        self.scene
            .bodies_named_mut()
            .enumerate()
            .map(move |(i, (_, body))| (first + i as u32, frame, body))
    }

    /// The frame its objects are simulated and published in.
    pub fn frame(&self) -> &str {
        &self.frame
    }

    /// Colliders from outside the scene (the described robot's links) for its next steps.
    pub fn set_external_colliders(&mut self, colliders: Vec<Obstacle>) {
        self.scene.set_external_colliders(colliders);
    }

    /// Steps every object; the step waits to be published.
    pub fn step(&mut self) {
        self.scene.step();
        self.unpublished = true;
    }

    /// What the next step would begin with.
    pub fn prepare(&mut self) {
        self.scene.prepare();
    }

    /// The scene robots named move; a problem is reported once.
    pub fn set_joints(&mut self, robots: &[String], state: &JointState, outputs: &Outputs) {
        if robots.is_empty() {
            return;
        }
        let set = self
            .scene
            .set_joint_positions(robots, &state.name, &state.position);
        if let Err(problem) = set {
            if self.reported.insert(problem.clone()) {
                outputs.report(Status::WARN, 0, "joint_state_ignored", problem);
            }
        }
    }

    /// Publishes the last step if it was not yet, with the surface markers when they are due; a
    /// sleeping object only as it falls asleep.
    pub fn publish_pending(&mut self, cloud_due: bool, markers_due: bool, outputs: &Outputs) {
        if !std::mem::take(&mut self.unpublished) {
            return;
        }
        let cloud = if cloud_due {
            DeformedCloud::XyzOnly
        } else {
            DeformedCloud::Skip
        };
        let first = self.first_id;
        let mut surfaces = self.surfaces.iter_mut().filter(|_| markers_due);
        for (i, (name, body)) in self.scene.bodies_named().enumerate() {
            let surface = surfaces.next().map(|s| (s, name));
            if !body.is_sleeping() || body.fell_asleep() {
                let id = first + i as u32;
                outputs.publish_step_reported(id, &self.frame, body, surface, cloud, None);
            }
        }
    }
}
