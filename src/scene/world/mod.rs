//! A scene running: robots moved by joint states (or their scripted motion), deformable
//! objects stepped in parallel, static and rigid objects only colliding.

mod objects;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use parry3d::shape::SharedShape;
use rayon::prelude::*;

use self::objects::{deformable_object, kinematic_object, world_shape};
use super::budget::Choice;
use super::file::{Keyframe, ObjectKind, ObjectSpec, Region, SceneFile};
use super::robot::Robot;
use super::urdf_geometry::to_parry;
use super::SceneError;
use crate::geometry::Shape;
use crate::physics::{Obstacle, SimParams};
use crate::pipeline::{contact_hulls, BodyOptions, SoftBody, Support};
use crate::skinning::{NeuralModel, RefineBudget, SkinningField};
use crate::Result;

/// Attachments to robot links move pin group 1.
const ATTACHMENT_GROUP: u32 = 1;

/// How a scene is built.
#[derive(Clone, Debug)]
pub struct SceneOptions {
    /// Apply the scene's decisions: sizes from the error budget, sleeping. Without them every
    /// deformable object gets all handles and 256 cubature points and steps every tick (the
    /// baseline `bench scene` compares against); fixed sizes in the file are kept either way.
    pub decisions: bool,
    /// Build only the objects with these names; every object when empty.
    pub only: Vec<String>,
    /// Robots follow the scene file's `motion`. The node turns this off: its robots follow
    /// their joint-state topics.
    pub scripted: bool,
    /// How a deformable object's field is refined toward the skinning eigenmodes when the
    /// object keeps all its handles (a field cut to fewer stays the network's). Default
    /// `SCENE_REFINE_ITERATIONS` iterations: a count, not a time, so that a scene builds the
    /// same bodies on any machine.
    pub refine: RefineBudget,
}

/// Refinement iterations of a scene object's field by default (the eigenmodes' error is
/// reached in about as many on the evaluation shapes, `eval --json`'s refine_iterations).
pub const SCENE_REFINE_ITERATIONS: u32 = 8;

impl Default for SceneOptions {
    fn default() -> Self {
        Self {
            decisions: true,
            only: Vec::new(),
            scripted: true,
            refine: RefineBudget::Iterations(SCENE_REFINE_ITERATIONS),
        }
    }
}

/// A cut or refined field's key: geometry hash, handles, refinement budget.
type TruncatedKey = (u64, usize, RefineBudget);

/// Inferred fields and budget choices by geometry content, shared by every scene and build of
/// a process: identical geometry (the same file twice, or the same primitive at two places) is
/// inferred once.
#[derive(Default)]
pub struct FieldCache {
    fields: Mutex<HashMap<u64, Arc<dyn SkinningField>>>,
    /// Fields cut to a handle count, or refined when they keep all their handles, by
    /// (geometry, handles, refinement budget): scenes built with other budgets share the cache.
    truncated: Mutex<HashMap<TruncatedKey, Arc<dyn SkinningField>>>,
    choices: Mutex<HashMap<u64, Choice>>,
    /// Inferences saved and done.
    pub hits: std::sync::atomic::AtomicUsize,
    /// Inferences done (geometry not seen before).
    pub misses: std::sync::atomic::AtomicUsize,
}

impl FieldCache {
    /// The field of `shape` (whose local geometry hashes to `key`), inferred on a miss.
    pub fn field(
        &self,
        key: u64,
        model: &Arc<NeuralModel>,
        shape: &Shape,
        options: &BodyOptions,
    ) -> Result<(Arc<dyn SkinningField>, bool)> {
        use std::sync::atomic::Ordering::Relaxed;
        if let Some(f) = self.fields.lock().expect("cache lock").get(&key) {
            self.hits.fetch_add(1, Relaxed);
            return Ok((f.clone(), true));
        }
        let field = SoftBody::infer(model, shape, options)?;
        self.misses.fetch_add(1, Relaxed);
        self.fields
            .lock()
            .expect("cache lock")
            .insert(key, field.clone());
        Ok((field, false))
    }
}

impl FieldCache {
    /// The field of `key` cut to `handles` once per geometry; a field that keeps all its
    /// handles is refined within `refine`. A cut field stays the network's: on a 0.3 m block
    /// cut to 9 handles and pressed 5 cm by a plate, the refined field (cut before or after
    /// refining, 1 to all iterations) held the middle of the top at 0.282 m against 0.255 m
    /// for the network's, the plate at 0.25 m (tests/scene.rs, the rigid plate); with all 17
    /// handles the refined field gave 0.249 m and the network's 0.253 m.
    fn truncated(
        &self,
        key: u64,
        field: Arc<dyn SkinningField>,
        shape: &Shape,
        options: &BodyOptions,
        handles: usize,
        refine: RefineBudget,
    ) -> Result<Arc<dyn SkinningField>> {
        if let Some(f) = self
            .truncated
            .lock()
            .expect("cache lock")
            .get(&(key, handles, refine))
        {
            return Ok(f.clone());
        }
        let cut = if handles >= field.handle_count() {
            SoftBody::refined_field(field, shape, options, refine)?
        } else {
            SoftBody::truncated_field(field, shape, options, handles)?
        };
        self.truncated
            .lock()
            .expect("cache lock")
            .insert((key, handles, refine), cut.clone());
        Ok(cut)
    }

    /// The budget choice stored under `key`, made by `choose` on a miss. The lock is not held
    /// while choosing, which runs the probe simulations.
    fn choice(&self, key: u64, choose: impl FnOnce() -> Result<Choice>) -> Result<Choice> {
        let known = self.choices.lock().expect("cache lock").get(&key).cloned();
        match known {
            Some(c) => Ok(c),
            None => {
                let c = choose()?;
                self.choices
                    .lock()
                    .expect("cache lock")
                    .insert(key, c.clone());
                Ok(c)
            }
        }
    }
}

/// A scene: its robots and objects, at one time.
pub struct Scene {
    dt: f64,
    time: f64,
    scripted: bool,
    robots: Vec<SceneRobot>,
    pub(crate) objects: Vec<SceneObject>,
    /// The deformable objects' contact hulls the last step collided with, by object index.
    pub(crate) soft_hulls: Vec<(usize, Obstacle)>,
    /// What moves in the scene's frame without being in its file (the node's robot from
    /// `robot_description`), after the file's own colliders.
    external: Vec<Obstacle>,
}

struct SceneRobot {
    name: String,
    robot: Robot,
    motion: Vec<Keyframe>,
    joint_states: String,
    poses: Vec<Isometry3<f64>>,
    /// Link poses when the scene was built: attachments hold what they held then.
    start: Vec<Isometry3<f64>>,
}

/// How a deformable object is set up, kept so that a reference can set up the same.
#[derive(Clone)]
pub(crate) struct Setup {
    pub shape: Shape,
    pub sim: SimParams,
    pub support: Support,
    pub floor: Option<f64>,
    pub pins: Vec<Region>,
    pub attach: Option<Region>,
    pub obstacles: Vec<Obstacle>,
}

pub(crate) struct SceneObject {
    pub name: String,
    pub kind: ObjectKind,
    pub body: Option<SoftBody>,
    pub setup: Option<Setup>,
    /// Robot and link that carry it.
    held: Option<(usize, usize)>,
    /// Static and rigid objects: their convex hull at rest.
    hull: Option<SharedShape>,
    /// Rest points (world) of static and rigid objects.
    rest: Vec<Vector3<f64>>,
    decision: String,
}

/// One object's state, for tables and the log.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ObjectReport {
    /// The object's name.
    pub name: String,
    /// Deformable, static or rigid.
    pub kind: ObjectKind,
    /// Handles of its body, the constant one included; 0 when it is not simulated.
    pub handles: usize,
    /// Cubature points of its body; 0 when it is not simulated.
    pub cubature: usize,
    /// Whether its body sleeps (false when it is not simulated).
    pub sleeping: bool,
    /// What was chosen for it and why.
    pub decision: String,
}

impl Scene {
    /// Builds every object of `file` that has geometry (objects that arrive on a topic are the
    /// node's to build) and places the robots at their first pose.
    pub fn build(
        file: &SceneFile,
        model: &Arc<NeuralModel>,
        cache: &FieldCache,
        options: &SceneOptions,
    ) -> Result<Self> {
        let dt = 1.0 / file.rate_hz;
        let mut robots = Vec::new();
        for spec in &file.robots {
            let base = Isometry3::from_parts(
                Translation3::from(Vector3::from(spec.base.xyz)),
                UnitQuaternion::from_euler_angles(
                    spec.base.rpy[0],
                    spec.base.rpy[1],
                    spec.base.rpy[2],
                ),
            );
            let mut robot = Robot::from_urdf(&spec.urdf, base)?;
            if let Some(first) = spec.motion.first() {
                apply_keyframe(&mut robot, first, &spec.name)?;
            }
            let poses = robot.link_poses();
            robots.push(SceneRobot {
                name: spec.name.clone(),
                robot,
                motion: spec.motion.clone(),
                joint_states: spec.joint_states.clone(),
                start: poses.clone(),
                poses,
            });
        }
        let wanted = |o: &ObjectSpec| options.only.is_empty() || options.only.contains(&o.name);
        let mut objects = Vec::new();
        // Static and rigid objects first: deformable ones collide with them.
        for spec in file.objects.iter().filter(|o| wanted(o)) {
            if spec.kind == ObjectKind::Deformable {
                continue;
            }
            let Some((shape, _)) = world_shape(spec)? else {
                continue;
            };
            objects.push(kinematic_object(spec, shape, &robots)?);
        }
        let fixed_obstacles: Vec<Obstacle> = objects
            .iter()
            .filter(|o| o.kind == ObjectKind::Static || o.held.is_none())
            .filter_map(|o| o.hull.clone())
            .map(|shape| Obstacle::Shape {
                shape,
                pose: to_parry(&Isometry3::identity()),
            })
            .collect();
        let collides = !robots.is_empty() || !objects.is_empty();
        for spec in file.objects.iter().filter(|o| wanted(o)) {
            if spec.kind != ObjectKind::Deformable {
                continue;
            }
            let Some((shape, key)) = world_shape(spec)? else {
                continue;
            };
            let object = deformable_object(
                spec,
                shape,
                key,
                file,
                model,
                cache,
                options,
                &robots,
                collides.then_some(&fixed_obstacles),
            )
            .map_err(|e| SceneError::Object {
                object: spec.name.clone(),
                reason: e.to_string(),
            })?;
            objects.push(object);
        }
        Ok(Self {
            dt,
            time: 0.0,
            scripted: options.scripted,
            robots,
            objects,
            soft_hulls: Vec::new(),
            external: Vec::new(),
        })
    }

    /// Colliders from outside the scene file, where they are now (the node's described robot):
    /// every deformable object collides with them from the next step on.
    pub fn set_external_colliders(&mut self, colliders: Vec<Obstacle>) {
        self.external = colliders;
    }

    /// Simulated time since the motion's start, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The time step, s (1 / `rate_hz`).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Steps with the robots held at their first pose until every deformable object sleeps,
    /// or `max_steps`; returns the steps taken. The scene clock stays at 0: motion starts after.
    pub fn settle(&mut self, max_steps: usize) -> usize {
        for taken in 0..max_steps {
            if self.bodies().all(|b| b.is_sleeping()) {
                return taken;
            }
            self.step_objects();
        }
        max_steps
    }

    /// Advances one step: robots to their scripted pose at the new time (when they have a
    /// motion), then every awake deformable object, in parallel.
    pub fn step(&mut self) {
        self.time += self.dt;
        let time = self.time;
        for r in self.robots.iter_mut().filter(|_| self.scripted) {
            if !r.motion.is_empty() {
                let frame = interpolate(&r.motion, time);
                // Names come from the file and were checked when the scene was built.
                let _ = apply_keyframe(&mut r.robot, &frame, &r.name);
                r.poses = r.robot.link_poses();
            }
        }
        self.step_objects();
    }

    /// Does now, for every deformable object, the work its next step would begin with (see
    /// `SoftBody::prepare`): call it once a step's outputs are out.
    pub fn prepare(&mut self) {
        self.objects
            .par_iter_mut()
            .filter_map(|o| o.body.as_mut())
            .for_each(SoftBody::prepare);
    }

    fn step_objects(&mut self) {
        let colliders = self.colliders();
        let hulls = self.contact_hulls();
        let motions: Vec<Option<Isometry3<f64>>> = self
            .objects
            .iter()
            .map(|o| o.held.map(|(r, l)| self.link_motion(r, l)))
            .collect();
        self.objects
            .par_iter_mut()
            .enumerate()
            .zip(motions)
            .for_each(|((index, o), motion)| {
                if let Some(body) = &mut o.body {
                    body.set_colliders(with_others(&colliders, &hulls, index));
                    if let Some(m) = motion {
                        body.move_attachment(ATTACHMENT_GROUP, &m);
                    }
                    body.step();
                }
            });
        self.soft_hulls = hulls;
    }

    /// Every deformable object's contact hull where it is now (soft against soft: each
    /// object's contact points are pushed out of the others' hulls within its own solve).
    fn contact_hulls(&self) -> Vec<(usize, Obstacle)> {
        let bodies: Vec<Option<&SoftBody>> = self.objects.iter().map(|o| o.body.as_ref()).collect();
        let kept: Vec<Option<&Obstacle>> = (0..self.objects.len())
            .map(|i| {
                self.soft_hulls
                    .iter()
                    .find(|(j, _)| *j == i)
                    .map(|(_, h)| h)
            })
            .collect();
        contact_hulls(&bodies, &kept)
            .into_iter()
            .enumerate()
            .filter_map(|(i, hull)| Some((i, hull?)))
            .collect()
    }

    /// Sets the joints of the robots on one joint-state topic from a JointState (names and
    /// positions): each robot takes the joints it has. Names no robot of `robots` has (or
    /// non-finite positions) are an error naming them; the rest is applied.
    pub fn set_joint_positions(
        &mut self,
        robots: &[String],
        names: &[String],
        positions: &[f64],
    ) -> std::result::Result<(), String> {
        if names.len() != positions.len() {
            return Err(format!(
                "{} joint names but {} positions",
                names.len(),
                positions.len()
            ));
        }
        let mut unclaimed: Vec<bool> = vec![true; names.len()];
        let mut problems = Vec::new();
        for r in self.robots.iter_mut().filter(|r| robots.contains(&r.name)) {
            let (mut own_names, mut own_positions) = (Vec::new(), Vec::new());
            for (i, name) in names.iter().enumerate() {
                if r.robot.has_joint(name) {
                    unclaimed[i] = false;
                    own_names.push(name.clone());
                    own_positions.push(positions[i]);
                }
            }
            if let Err(problem) = r.robot.set_joint_positions(&own_names, &own_positions) {
                problems.push(problem);
            }
            r.poses = r.robot.link_poses();
        }
        let unknown: Vec<&str> = names
            .iter()
            .zip(&unclaimed)
            .filter(|(_, u)| **u)
            .map(|(n, _)| n.as_str())
            .collect();
        if !unknown.is_empty() {
            problems.push(format!(
                "no robot among {robots:?} has joint {}",
                unknown.join(", ")
            ));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(problems.join("; "))
        }
    }

    /// A force on the material point at `rest` of a deformable object for `duration` seconds
    /// from now (it wakes the object).
    pub fn push(
        &mut self,
        name: &str,
        rest: Vector3<f64>,
        force: Vector3<f64>,
        duration: f64,
    ) -> std::result::Result<(), String> {
        let body = self
            .objects
            .iter_mut()
            .find(|o| o.name == name)
            .and_then(|o| o.body.as_mut())
            .ok_or_else(|| format!("the scene has no deformable object `{name}`"))?;
        body.push(rest, force, duration);
        Ok(())
    }

    /// (robot name, joint-state topic) of every robot.
    pub fn joint_state_topics(&self) -> Vec<(String, String)> {
        self.robots
            .iter()
            .map(|r| (r.name.clone(), r.joint_states.clone()))
            .collect()
    }

    /// The motion of a link since the scene was built.
    fn link_motion(&self, robot: usize, link: usize) -> Isometry3<f64> {
        let r = &self.robots[robot];
        r.poses[link] * r.start[link].inverse()
    }

    /// What moves now: every robot link and every rigid object carried by one, then the
    /// external colliders (last, so the file's keep their places in the list).
    pub(crate) fn colliders(&self) -> Vec<Obstacle> {
        let mut colliders: Vec<Obstacle> = self
            .robots
            .iter()
            .flat_map(|r| r.robot.colliders(&r.poses))
            .collect();
        for o in &self.objects {
            if let (Some((r, l)), Some(hull)) = (o.held, &o.hull) {
                colliders.push(Obstacle::Shape {
                    shape: hull.clone(),
                    pose: to_parry(&self.link_motion(r, l)),
                });
            }
        }
        colliders.extend(self.external.iter().cloned());
        colliders
    }

    /// The motion of an object's attachment since the scene was built, if it has one.
    pub(crate) fn attachment_motion(&self, object: usize) -> Option<Isometry3<f64>> {
        self.objects[object]
            .held
            .map(|(r, l)| self.link_motion(r, l))
    }

    fn bodies(&self) -> impl Iterator<Item = &SoftBody> {
        self.objects.iter().filter_map(|o| o.body.as_ref())
    }

    /// The deformable objects' names and bodies, in the file's order.
    pub fn bodies_named(&self) -> impl Iterator<Item = (&str, &SoftBody)> {
        self.objects
            .iter()
            .filter_map(|o| Some((o.name.as_str(), o.body.as_ref()?)))
    }

    /// The deformable objects' names and bodies, mutable, in the file's order.
    pub fn bodies_named_mut(&mut self) -> impl Iterator<Item = (&str, &mut SoftBody)> {
        self.objects
            .iter_mut()
            .filter_map(|o| Some((o.name.as_str(), o.body.as_mut()?)))
    }

    /// Deformable objects awake now.
    pub fn awake(&self) -> usize {
        self.bodies().filter(|b| !b.is_sleeping()).count()
    }

    /// The body of a deformable object, by name.
    pub fn body(&self, name: &str) -> Option<&SoftBody> {
        self.objects
            .iter()
            .find(|o| o.name == name)
            .and_then(|o| o.body.as_ref())
    }

    /// Points of an object now (x, y, z per point): deformed for a deformable object, carried
    /// along for a rigid one, at rest for a static one.
    pub fn points(&self, name: &str) -> Option<Vec<f32>> {
        let (i, o) = self
            .objects
            .iter()
            .enumerate()
            .find(|(_, o)| o.name == name)?;
        if let Some(b) = &o.body {
            return Some(b.deformed().to_vec());
        }
        let motion = self
            .attachment_motion(i)
            .unwrap_or_else(Isometry3::identity);
        Some(
            o.rest
                .iter()
                .flat_map(|p| {
                    let q = motion.transform_point(&(*p).into());
                    [q.x as f32, q.y as f32, q.z as f32]
                })
                .collect(),
        )
    }

    /// Every object: kind, size, whether it sleeps, and why it was modelled so.
    pub fn report(&self) -> Vec<ObjectReport> {
        self.objects
            .iter()
            .map(|o| ObjectReport {
                name: o.name.clone(),
                kind: o.kind,
                handles: o.body.as_ref().map_or(0, |b| b.handles()),
                cubature: o.body.as_ref().map_or(0, |b| b.cubature_len()),
                sleeping: o.body.as_ref().is_some_and(|b| b.is_sleeping()),
                decision: o.decision.clone(),
            })
            .collect()
    }
}

/// Joint positions at `time`: linear between the keyframes around it, the last one after.
fn interpolate(motion: &[Keyframe], time: f64) -> Keyframe {
    let mut positions = std::collections::BTreeMap::new();
    for (i, k) in motion.iter().enumerate() {
        if k.at <= time {
            positions.extend(k.positions.clone());
            continue;
        }
        // Between keyframe i-1 (applied above) and i: blend the joints i names.
        if i > 0 {
            let before = &motion[i - 1];
            let s = (time - before.at) / (k.at - before.at);
            for (name, &q) in &k.positions {
                let from = positions.get(name).copied().unwrap_or(0.0);
                positions.insert(name.clone(), from + s * (q - from));
            }
        }
        break;
    }
    Keyframe {
        at: time,
        positions,
    }
}

fn apply_keyframe(robot: &mut Robot, frame: &Keyframe, name: &str) -> Result<()> {
    let names: Vec<String> = frame.positions.keys().cloned().collect();
    let positions: Vec<f64> = frame.positions.values().copied().collect();
    robot
        .set_joint_positions(&names, &positions)
        .map_err(|reason| {
            SceneError::Object {
                object: format!("robot {name}"),
                reason: format!("motion: {reason}"),
            }
            .into()
        })
}

/// `colliders` followed by the hulls of every deformable object but `object`, in object order,
/// so that a collider's index stays the same from one step to the next (friction anchors
/// refer to it).
pub(crate) fn with_others(
    colliders: &[Obstacle],
    hulls: &[(usize, Obstacle)],
    object: usize,
) -> Vec<Obstacle> {
    let others = hulls.iter().filter(|(i, _)| *i != object);
    colliders
        .iter()
        .cloned()
        .chain(others.map(|(_, h)| h.clone()))
        .collect()
}
