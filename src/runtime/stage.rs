//! The running objects: one per input frame (or label), and a scene's. The stepper thread
//! ticks the stage on the clock; a replay ticks it on the log's time. Objects are reset,
//! removed on request or when their input stops, and their surfaces drawn as markers.

use std::sync::{Arc, RwLock};

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use super::builder::{BuiltRegistry, ObjectKey, ReadyBody, RefinedField};
use super::inputs::JointReaders;
use super::outputs::{DeformedCloud, Outputs};
use super::params::NodeParams;
use super::robot_on_stage::RobotOnStage;
use super::scene_on_stage::SceneOnStage;
use super::tf::TfBuffer;
use super::tracking::{Observation, TrackingWindow, Verdict};
use crate::msg::{Interaction, JointState, Status};
use crate::physics::Obstacle;
use crate::pipeline::{contact_hulls, SoftBody};
use crate::scene::{Robot, Scene};

/// How a stage treats its objects beyond stepping them.
#[derive(Clone, Default)]
pub struct StageOptions {
    /// The frame objects are simulated in ("" : each in its input's frame).
    pub fixed_frame: String,
    /// Transforms for interactions named in other frames.
    pub tf: Option<Arc<RwLock<TfBuffer>>>,
    /// An object whose input frame sent nothing for this long is removed, ns; 0: never.
    pub object_timeout_ns: i64,
    /// Surface markers go out every this many ticks; 0: never.
    pub marker_every: u64,
    /// Deformed clouds go out every this many ticks (0 and 1: every tick).
    pub cloud_every: u64,
    /// Forgotten when objects go, so that their geometry builds again when it comes back.
    pub registry: Option<BuiltRegistry>,
    /// The robot from `robot_description` places the links /tf knows by /tf.
    pub robot_links_from_tf: bool,
}

impl StageOptions {
    /// The options `p` gives, with the transforms and the registry of built objects the stage
    /// shares with its builder.
    pub fn from_params(
        p: &NodeParams,
        tf: Option<Arc<RwLock<TfBuffer>>>,
        registry: Option<BuiltRegistry>,
    ) -> Self {
        Self {
            fixed_frame: p.fixed_frame.clone(),
            tf,
            object_timeout_ns: (p.object_timeout_s * 1e9) as i64,
            marker_every: ticks_per(p.rate_hz, p.markers.rate_hz),
            cloud_every: ticks_per(p.rate_hz, p.publish.rate_hz),
            registry,
            robot_links_from_tf: p.robot.links_from_tf,
        }
    }
}

/// Ticks of a `step_hz` clock between events at `rate_hz` (0: none), at least 1.
fn ticks_per(step_hz: f64, rate_hz: f64) -> u64 {
    if rate_hz <= 0.0 {
        0
    } else {
        (step_hz / rate_hz).round().max(1.0) as u64
    }
}

/// The running objects.
#[derive(Default)]
pub struct Stage {
    bodies: Vec<ReadyBody>,
    /// Per body: its last step is computed but not yet published (on-the-beat mode).
    unpublished: Vec<bool>,
    /// Per body: when its frame last sent geometry, ns of the node's clock.
    last_seen: Vec<i64>,
    on_the_beat: bool,
    scene: Option<SceneOnStage>,
    /// The robot from `robot_description`: its links collide with the fixed frame's objects.
    robot: Option<RobotOnStage>,
    options: StageOptions,
    ticks: u64,
    /// The bodies' contact hulls at the last tick, by shape id: what the others collided with.
    hulls: Vec<(u32, Obstacle)>,
    /// What the streams' frames did since the last `take_tracking`.
    tracking: TrackingWindow,
}

impl Stage {
    /// A stage that publishes on the beat: each tick first publishes the steps computed in the
    /// previous one, then computes the next. Publication then happens at the tick, whatever a
    /// step costs (one period of added delay); the node runs this way.
    pub fn on_the_beat(options: StageOptions) -> Self {
        Self {
            on_the_beat: true,
            options,
            ..Self::default()
        }
    }

    /// A stage that publishes each step as soon as it is computed (a replay).
    pub fn immediate(options: StageOptions) -> Self {
        Self {
            options,
            ..Self::default()
        }
    }

    /// Steps every object once and publishes its outputs. Objects step in parallel, each
    /// against the contact hulls the others of its frame had at the start of the tick (soft
    /// against soft), and publish one after another in a fixed order.
    pub fn tick(&mut self, outputs: &Outputs) {
        self.remove_stale(outputs);
        if self.on_the_beat {
            self.publish_pending(outputs);
        }
        let mut colliders = self.touch_each_other();
        self.add_robot_links(&mut colliders);
        let alone = self.one_to_step();
        let (bodies, scene) = (&mut self.bodies, &mut self.scene);
        if alone {
            bodies.iter_mut().zip(colliders).for_each(step_body);
            scene.iter_mut().for_each(SceneOnStage::step);
        } else {
            rayon::join(
                || bodies.par_iter_mut().zip(colliders).for_each(step_body),
                || scene.iter_mut().for_each(SceneOnStage::step),
            );
        }
        self.ticks += 1;
        self.track_after_step(outputs);
        self.unpublished.iter_mut().for_each(|u| *u = true);
        if !self.on_the_beat {
            self.publish_pending(outputs);
        }
        self.prepare_next();
    }

    /// Whether one thing (a body, or a scene) steps: it steps on this thread, where a large
    /// body's evaluations split with the solver's helper thread, which wakes faster than
    /// rayon's pool.
    fn one_to_step(&self) -> bool {
        self.bodies.len() + usize::from(self.scene.is_some()) <= 1
    }

    /// What the next tick's steps would begin with (a held Hessian's refresh), done once this
    /// tick's outputs are out (on the beat they go out at the next tick, long after this).
    fn prepare_next(&mut self) {
        let alone = self.one_to_step();
        let (bodies, scene) = (&mut self.bodies, &mut self.scene);
        if alone {
            bodies.iter_mut().for_each(|b| b.body.prepare());
            scene.iter_mut().for_each(SceneOnStage::prepare);
        } else {
            rayon::join(
                || bodies.par_iter_mut().for_each(|b| b.body.prepare()),
                || scene.iter_mut().for_each(SceneOnStage::prepare),
            );
        }
    }

    /// Per body, the other bodies of its output frame as obstacles (their contact hulls where
    /// they are now); the hulls are kept for the next tick, where a sleeping body reuses its own.
    fn touch_each_other(&mut self) -> Vec<Vec<Obstacle>> {
        let shares_a_frame: Vec<bool> = (0..self.bodies.len())
            .map(|i| {
                let frame = &self.bodies[i].output_frame;
                (0..self.bodies.len()).any(|j| j != i && self.bodies[j].output_frame == *frame)
            })
            .collect();
        for (b, _) in self
            .bodies
            .iter_mut()
            .zip(&shares_a_frame)
            .filter(|(_, s)| **s)
        {
            // A pinned body has no contact points of its own until something can touch it.
            b.body.enable_contacts();
        }
        let bodies: Vec<Option<&SoftBody>> = self.bodies.iter().map(|b| Some(&b.body)).collect();
        let kept: Vec<Option<&Obstacle>> = self
            .bodies
            .iter()
            .map(|b| {
                self.hulls
                    .iter()
                    .find(|(id, _)| *id == b.id)
                    .map(|(_, h)| h)
            })
            .collect();
        let hulls = contact_hulls(&bodies, &kept);
        let colliders = (0..self.bodies.len())
            .map(|i| {
                let frame = &self.bodies[i].output_frame;
                (0..self.bodies.len())
                    .filter(|&j| j != i && self.bodies[j].output_frame == *frame)
                    .filter_map(|j| hulls[j].clone())
                    .collect()
            })
            .collect();
        self.hulls = self
            .bodies
            .iter()
            .zip(hulls)
            .filter_map(|(b, h)| Some((b.id, h?)))
            .collect();
        colliders
    }

    /// The described robot's links, where they are now, among the colliders of every body in
    /// the fixed frame (their contact points enabled: a pinned body has none until something
    /// can touch it) and of a scene simulated there.
    fn add_robot_links(&mut self, colliders: &mut [Vec<Obstacle>]) {
        let Some(robot) = &self.robot else {
            return;
        };
        let tf = self.options.tf.as_ref().and_then(|t| t.read().ok());
        let links = robot.colliders(tf.as_deref());
        let fixed = &self.options.fixed_frame;
        if let Some(s) = self.scene.as_mut().filter(|s| s.frame() == fixed) {
            s.set_external_colliders(links.clone());
        }
        for (b, c) in self.bodies.iter_mut().zip(colliders) {
            if b.output_frame == *fixed {
                b.body.enable_contacts();
                c.extend(links.iter().cloned());
            }
        }
    }

    /// (objects, awake objects), scene objects included.
    pub fn counts(&self) -> (usize, usize) {
        let scene: Vec<bool> = self
            .scene_bodies()
            .map(|(_, _, b)| b.is_sleeping())
            .collect();
        let asleep = scene.iter().filter(|s| **s).count();
        let all = self.bodies.len() + scene.len();
        (all, all - asleep)
    }

    fn publish_pending(&mut self, outputs: &Outputs) {
        // The tick whose step is published: on the beat, the previous one.
        let due = |every: u64| every > 0 && self.ticks % every == u64::from(self.on_the_beat);
        let markers_due = due(self.options.marker_every);
        let cloud_due = self.options.cloud_every <= 1 || due(self.options.cloud_every);
        for (b, unpublished) in self.bodies.iter_mut().zip(&mut self.unpublished) {
            if std::mem::take(unpublished) {
                publish_last_step(b, outputs, markers_due, cloud_due);
            }
        }
        if let Some(s) = &mut self.scene {
            s.publish_pending(cloud_due, markers_due, outputs);
        }
    }

    /// A scene joins (or replaces the scene on) the stage: its objects are announced with
    /// their weights and what was decided for each.
    pub fn set_scene(&mut self, scene: Scene, first_id: u32, frame: String, outputs: &Outputs) {
        let markers = self.options.marker_every > 0;
        self.scene = Some(SceneOnStage::new(scene, first_id, frame, markers, outputs));
    }

    /// Robots' joints move (a JointState from their topic): the scene robots it names and the
    /// described robot when it reads the topic.
    pub fn set_joints(&mut self, readers: &JointReaders, state: &JointState, outputs: &Outputs) {
        if let (true, Some(robot)) = (readers.described, &mut self.robot) {
            robot.set_joints(state, outputs);
        }
        if let Some(s) = self.scene.as_mut() {
            s.set_joints(&readers.scene_robots, state, outputs);
        }
    }

    /// A robot from `robot_description` joins the stage, replacing the one before; `notes`
    /// name links that stand in with their visual box.
    pub fn set_robot(&mut self, robot: Robot, notes: &[String], outputs: &Outputs) {
        let (frame, from_tf) = (&self.options.fixed_frame, self.options.robot_links_from_tf);
        self.robot = RobotOnStage::new(robot, notes, frame, from_tf, outputs);
    }

    /// The bodies built from inputs, in the order they joined (a scene's are not among them).
    pub fn bodies(&self) -> &[ReadyBody] {
        &self.bodies
    }

    /// The scene's deformable objects: (shape id, name, body).
    pub fn scene_bodies(&self) -> impl Iterator<Item = (u32, &str, &SoftBody)> {
        self.scene.iter().flat_map(|s| s.bodies())
    }

    /// A new body replaces the one of its key. With `step_now` it makes its first step at
    /// once and publishes it, so its first deformed cloud does not wait for the next tick. On
    /// the beat without `step_now` (the tick is near), the step is still made now, and goes out
    /// first thing at the tick: waiting for the tick to compute it would hold the cloud back
    /// until the tick after.
    pub fn add(&mut self, mut ready: ReadyBody, outputs: &Outputs, step_now: bool) {
        let early = self.on_the_beat && !step_now;
        if step_now || early {
            ready.body.step();
        }
        if step_now {
            publish_last_step(&mut ready, outputs, true, true);
        }
        if step_now || early {
            ready.body.prepare();
        }
        let now = outputs.clock.now_nanos().unwrap_or(0);
        if let Some(i) = self.bodies.iter().position(|b| b.key == ready.key) {
            self.bodies[i] = ready;
            self.unpublished[i] = early;
            self.last_seen[i] = now;
        } else {
            self.bodies.push(ready);
            self.unpublished.push(early);
            self.last_seen.push(now);
        }
    }

    /// The object `refined.key` continues on its refined field, its weights published anew
    /// (from a thread of their own: a 10k-point object's weights are over a megabyte, too much
    /// to write between two ticks); one that was rebuilt or removed since keeps what it runs.
    pub fn switch(&mut self, refined: RefinedField, outputs: &Arc<Outputs>) {
        let RefinedField { id, key, prepared } = refined;
        let Some(b) = self.bodies.iter_mut().find(|b| b.key == key && b.id == id) else {
            return;
        };
        let refine = prepared.refine.clone().unwrap_or_default();
        let ms = prepared.prepare_ms;
        let started = std::time::Instant::now();
        let report = match b.body.switch_to(prepared) {
            Ok(report) => report,
            Err(e) => {
                let message = format!("{key}: the refined field was not used: {e}");
                outputs.report(Status::INFO, id, "refine_skipped", message);
                return;
            }
        };
        b.tracking.rebased();
        if let Some(surface) = &mut b.surface {
            surface.rebase(&b.body);
        }
        let rest: Vec<f32> = (b.body.lifter().rest_points().iter())
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        let (weights, frame) = (b.body.weights().to_vec(), b.output_frame.clone());
        let publisher = outputs.clone();
        std::thread::spawn(move || {
            super::builder::yield_to_stepping();
            publisher.publish_weights(id, &frame, &rest, &weights, report.handles);
        });
        let switch_ms = started.elapsed().as_secs_f64() * 1e3;
        let message = format!(
            "{key}: field refined toward the eigenmodes ({} iterations{}, {ms:.1} ms), switched \
             to in {switch_ms:.2} ms; largest jump at the switch {:.3} mm",
            refine.iterations,
            if refine.converged { ", converged" } else { "" },
            report.max_jump_m * 1e3
        );
        outputs.report(Status::INFO, id, "field_refined", message);
    }

    /// A later frame of a running object corrects it. Frames that stop explaining it replace
    /// it (`object_replaced`, then the object goes): the next cloud builds a new one. A frame
    /// of an object replaced or removed since it was sent is dropped.
    pub fn observe(&mut self, frame: Observation, outputs: &Outputs) {
        let found = self
            .bodies
            .iter()
            .position(|b| b.key == frame.key && b.id == frame.id);
        let Some(i) = found else {
            return;
        };
        // Its cloud already marked it seen (`seen`, before the builder took the cloud).
        let now = outputs.clock.now_nanos().unwrap_or(0);
        let b = &mut self.bodies[i];
        let verdict = b.tracking.observe(&mut b.body, &frame, now);
        if let Some(fit) = &b.tracking.last {
            self.tracking.take(fit);
        }
        match verdict {
            Verdict::Used {
                resumed: Some(stopped),
            } => {
                let message = format!(
                    "{}: frames again after {stopped:.2} s; corrected from where the physics \
                     carried it",
                    b.key
                );
                outputs.report(Status::INFO, b.id, "tracking_resumed", message);
            }
            Verdict::Used { .. } | Verdict::Skipped => {}
            Verdict::Replace(why) => {
                let message = format!("{}: {why}; the next cloud builds a new object", b.key);
                outputs.report(Status::WARN, b.id, "object_replaced", message);
                self.remove_at(i, outputs, "replaced by what its frames show now");
            }
        }
    }

    /// After a step: observations whose hold ran out stop pulling, and objects whose frames
    /// stopped run on physics alone (`tracking_paused`).
    fn track_after_step(&mut self, outputs: &Outputs) {
        let now = outputs.clock.now_nanos().unwrap_or(0);
        for b in &mut self.bodies {
            b.tracking.stepped(&mut b.body);
            if let Some(stopped) = b.tracking.pause_if_stopped(&mut b.body, now) {
                let message = format!(
                    "{}: no frame for {stopped:.2} s (the view blocked, or the object out of \
                     view): it runs on physics alone until frames return",
                    b.key
                );
                outputs.report(Status::INFO, b.id, "tracking_paused", message);
            }
        }
    }

    /// What the streams' frames did since the last call, with the objects tracked now.
    pub fn take_tracking(&mut self) -> TrackingWindow {
        let mut window = std::mem::take(&mut self.tracking);
        window.tracked = self
            .bodies
            .iter()
            .filter(|b| b.tracking.is_tracking())
            .count();
        window
    }

    /// Geometry arrived for the object `key`: it is still wanted.
    pub fn seen(&mut self, key: &ObjectKey, outputs: &Outputs) {
        let now = outputs.clock.now_nanos().unwrap_or(0);
        for (b, seen) in self.bodies.iter().zip(&mut self.last_seen) {
            if &b.key == key {
                *seen = now;
            }
        }
    }

    /// Every object back to its rest state, at rest; the rest state is published at once.
    pub fn reset(&mut self, outputs: &Outputs) -> String {
        let stamp = outputs.clock.now();
        for (b, unpublished) in self.bodies.iter_mut().zip(&mut self.unpublished) {
            b.body.reset();
            *unpublished = false;
            let header = crate::msg::Header {
                stamp: stamp.clone(),
                frame_id: b.output_frame.clone(),
            };
            let cloud = DeformedCloud::of(b.template.as_ref());
            outputs.publish_step(b.id, header, &b.body, None, cloud, None);
        }
        let message = format!(
            "{} objects back at rest; their rest state is stamped {}.{:09}",
            self.bodies.len(),
            stamp.sec,
            stamp.nanosec
        );
        outputs.report(Status::INFO, 0, "reset", message.clone());
        message
    }

    /// Removes every object (a scene's stays: it is part of the node's configuration).
    pub fn clear(&mut self, outputs: &Outputs) -> String {
        let count = self.bodies.len();
        while !self.bodies.is_empty() {
            self.remove_at(0, outputs, "cleared");
        }
        format!("{count} objects removed")
    }

    /// Removes the bodies whose frame sent nothing within the object timeout.
    fn remove_stale(&mut self, outputs: &Outputs) {
        let timeout = self.options.object_timeout_ns;
        let Some(now) = outputs.clock.now_nanos().filter(|_| timeout > 0) else {
            return;
        };
        while let Some(i) = self.last_seen.iter().position(|&t| now - t > timeout) {
            let why = format!(
                "no input for {:.1} s",
                (now - self.last_seen[i]) as f64 / 1e9
            );
            self.remove_at(i, outputs, &why);
        }
    }

    fn remove_at(&mut self, i: usize, outputs: &Outputs, why: &str) {
        let b = self.bodies.remove(i);
        self.unpublished.remove(i);
        self.last_seen.remove(i);
        if let Some(registry) = &self.options.registry {
            registry.forget(Some(&b.key));
        }
        outputs.publish_removed(b.id, &b.output_frame, &b.frame);
        let message = format!("the object of {} is removed: {why}", b.key);
        outputs.report(Status::INFO, b.id, "shape_removed", message);
    }

    /// Applies an interaction (force, pin, release or REMOVE) to the objects it names, the
    /// scene's included; one that cannot be applied is reported as `interaction_ignored`.
    pub fn interact(&mut self, i: &Interaction, outputs: &Outputs) {
        if i.kind == Interaction::REMOVE {
            return self.remove_matching(i, outputs);
        }
        let acted = match self.in_simulation_frame(i) {
            Ok(acted) => acted,
            Err(problem) => {
                return outputs.report(Status::WARN, i.shape_id, "interaction_ignored", problem)
            }
        };
        let scene_bodies = self.scene.iter_mut().flat_map(|s| s.bodies_mut());
        let bodies = self
            .bodies
            .iter_mut()
            .map(|b| (b.id, b.frame.as_str(), &mut b.body))
            .chain(scene_bodies);
        interact(bodies, i, &acted, outputs)
    }

    /// REMOVE: the shape `shape_id` (0: any) of the interaction's frame (empty: any).
    fn remove_matching(&mut self, i: &Interaction, outputs: &Outputs) {
        let frame = &i.header.frame_id;
        let matches = |b: &ReadyBody| {
            (i.shape_id == 0 || b.id == i.shape_id) && (frame.is_empty() || &b.frame == frame)
        };
        let mut removed = 0;
        while let Some(at) = self.bodies.iter().position(matches) {
            self.remove_at(at, outputs, "REMOVE requested");
            removed += 1;
        }
        if removed == 0 {
            let problem = format!(
                "REMOVE: no shape matches shape_id {} in frame `{frame}`",
                i.shape_id
            );
            outputs.report(Status::WARN, i.shape_id, "interaction_ignored", problem);
        }
    }

    /// The interaction's point and force in the frame objects are simulated in, and the input
    /// frame it is limited to (None: any object, by shape id).
    fn in_simulation_frame(&self, i: &Interaction) -> Result<Acted, String> {
        let point = Vector3::new(i.point.x, i.point.y, i.point.z);
        let force = Vector3::new(i.force.x, i.force.y, i.force.z);
        let frame = &i.header.frame_id;
        let fixed = &self.options.fixed_frame;
        if fixed.is_empty() {
            let filter = (!frame.is_empty()).then(|| frame.clone());
            return Ok(Acted {
                filter,
                point,
                force,
            });
        }
        let names_an_object = self.bodies.iter().any(|b| &b.frame == frame);
        let filter = names_an_object.then(|| frame.clone());
        if frame.is_empty() || frame == fixed {
            return Ok(Acted {
                filter,
                point,
                force,
            });
        }
        let tf = self.options.tf.as_ref().ok_or("no tf buffer")?;
        let tf = tf.read().map_err(|_| "the tf buffer is poisoned")?;
        let t = tf.lookup(fixed, frame, 0).map_err(|e| {
            format!("no transform from `{frame}` to the fixed frame `{fixed}`: {e}")
        })?;
        Ok(Acted {
            filter,
            point: (t * Point3::from(point)).coords,
            force: t.rotation * force,
        })
    }
}

/// Publishes a body's last step, with its surface marker and deformed cloud when they are due.
fn publish_last_step(b: &mut ReadyBody, outputs: &Outputs, markers_due: bool, cloud_due: bool) {
    let surface = b.surface.as_mut().filter(|_| markers_due);
    let surface = surface.map(|s| (s, b.frame.as_str()));
    let cloud = if cloud_due {
        DeformedCloud::of(b.template.as_ref())
    } else {
        DeformedCloud::Skip
    };
    let tracked = b.tracking.last.as_ref();
    outputs.publish_step_reported(b.id, &b.output_frame, &b.body, surface, cloud, tracked);
}

/// Steps one body against the others' contact hulls (`Stage::tick`).
fn step_body((b, colliders): (&mut ReadyBody, Vec<Obstacle>)) {
    b.body.set_colliders(colliders);
    b.body.step();
}

/// Where an interaction acts, in the simulation's frame.
struct Acted {
    /// Only objects of this input frame; None: any.
    filter: Option<String>,
    point: Vector3<f64>,
    force: Vector3<f64>,
}

fn interact<'a>(
    bodies: impl Iterator<Item = (u32, &'a str, &'a mut SoftBody)>,
    i: &Interaction,
    acted: &Acted,
    outputs: &Outputs,
) {
    let (point, force) = (acted.point, acted.force);
    let frame = &i.header.frame_id;
    let finite = point.iter().chain(force.iter()).all(|c| c.is_finite())
        && i.duration.is_finite()
        && i.radius.is_finite();
    let ignored =
        |problem: String| outputs.report(Status::WARN, i.shape_id, "interaction_ignored", problem);
    if !finite {
        return ignored("non-finite point, force, duration or radius".into());
    }
    if i.kind > Interaction::REMOVE {
        return ignored(format!(
            "unknown kind {} (FORCE 0, PIN 1, RELEASE 2, REMOVE 3)",
            i.kind
        ));
    }
    let mut matched = 0;
    for (_, _, body) in bodies.filter(|(id, name, _)| {
        (i.shape_id == 0 || *id == i.shape_id) && acted.filter.as_deref().is_none_or(|f| f == *name)
    }) {
        matched += 1;
        match i.kind {
            Interaction::FORCE => body.push(point, force, i.duration.max(0.0)),
            Interaction::PIN => {
                if body.hold(&point, i.radius) == 0 {
                    ignored(format!(
                        "no material within {} m of the pin point",
                        i.radius
                    ));
                }
            }
            _ => {
                body.release(&point, i.radius);
            }
        }
    }
    if matched == 0 {
        ignored(format!(
            "no shape matches shape_id {} in frame `{frame}`",
            i.shape_id
        ));
    }
}
