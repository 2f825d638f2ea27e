//! Scene files (config/scenes/*.yaml): the objects, their materials and supports, the floor,
//! gravity, robots and what they hold. Unknown keys are errors, so a typo is not ignored.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::SceneError;
use crate::pipeline::{SleepRule, Support};

/// A scene file: the objects, the robots, and what every object shares (gravity, floor,
/// damping, friction, sleeping, the error budget).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Steps per second. Default 60.
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// m/s^2. Default (0, 0, -9.81).
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Height of a floor under every object (z, solid below); none when absent.
    #[serde(default)]
    pub floor: Option<f64>,
    /// Mass-proportional damping, 1/s. Default 1.
    #[serde(default = "default_damping")]
    pub damping: f64,
    /// Coulomb friction coefficient of every contact (floor, links, static objects). Default 0.5.
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Rolling friction of every contact, m: the largest resisting torque per newton of normal
    /// force (MuJoCo's rolling coefficient). Default `DEFAULT_ROLLING_FRICTION`.
    #[serde(default = "default_rolling_friction")]
    pub rolling_friction: f64,
    /// Largest simulation error allowed to an object whose `handles` or `cubature` is `auto`,
    /// percent of its size, measured against the full-space FEM. Default 5.
    #[serde(default = "default_budget")]
    pub error_budget_pct: f64,
    /// When still objects sleep; absent: `{speed: 1e-3, after: 0.5}`. `sleep: null` never.
    #[serde(default = "default_sleep")]
    pub sleep: Option<SleepRule>,
    /// The robots, driven by joint states or their `motion`.
    #[serde(default)]
    pub robots: Vec<RobotSpec>,
    /// The objects; at least one, each with a name of its own.
    pub objects: Vec<ObjectSpec>,
}

/// A robot of the scene: its URDF, where it stands and how its joints move.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Its name, which attachments refer to.
    pub name: String,
    /// Relative to the scene file.
    pub urdf: PathBuf,
    /// sensor_msgs/msg/JointState topic the node follows. Default /joint_states.
    #[serde(default = "default_joint_states")]
    pub joint_states: String,
    /// Pose of the root link. Default the origin.
    #[serde(default)]
    pub base: PoseSpec,
    /// Joint positions over time for runs without a joint-state topic (`physskin scene`, the
    /// bench): linear between keyframes, held after the last.
    #[serde(default)]
    pub motion: Vec<Keyframe>,
}

/// Joint positions at one time of a robot's scripted motion.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// s from the start.
    pub at: f64,
    /// Joint name to position (rad or m); joints not named keep their last position.
    pub positions: BTreeMap<String, f64>,
}

/// A pose as URDF writes it: a translation and roll, pitch, yaw.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseSpec {
    /// Translation, m.
    #[serde(default)]
    pub xyz: [f64; 3],
    /// Roll, pitch, yaw (rad) about fixed x, y, z, as URDF writes them.
    #[serde(default)]
    pub rpy: [f64; 3],
}

/// An object of the scene: where its geometry comes from, what it is, its material, size and
/// support.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Its name, unique in the scene.
    pub name: String,
    /// Default deformable.
    #[serde(default)]
    pub kind: ObjectKind,
    /// A mesh or cloud file (PLY, OBJ, OFF, STL, XYZ, NPY), relative to the scene file.
    #[serde(default)]
    pub file: Option<PathBuf>,
    /// Geometry made in code: `{box: [x, y, z]}`, `{sphere: r}`, `{capsule: [length, r]}` or
    /// `{bundled: name}`.
    #[serde(default, with = "serde_yaml::with::singleton_map_recursive")]
    pub shape: Option<ShapeSpec>,
    /// The frame_id under which the geometry arrives on the node's input topics; only the
    /// node builds such an object.
    #[serde(default)]
    pub topic: Option<String>,
    /// Where the geometry is placed (a translation). Default the origin.
    #[serde(default)]
    pub position: [f64; 3],
    /// Its material. Default Young's modulus 2e5 Pa, Poisson ratio 0.45, 1000 kg/m^3.
    #[serde(default)]
    pub material: MaterialSpec,
    /// Handles, the constant one included: a number, or `auto` to take the fewest that meet the
    /// error budget. Default auto.
    #[serde(default)]
    pub handles: Resolution,
    /// Cubature points of the elastic energy: a number or `auto`. Default auto.
    #[serde(default)]
    pub cubature: Resolution,
    /// What holds it. Default the scene floor if there is one, else pin_bottom.
    #[serde(default)]
    pub support: Option<Support>,
    /// Regions pinned where they are at rest.
    #[serde(default)]
    pub pins: Vec<Region>,
    /// A region held by a robot link: it moves with the link.
    #[serde(default)]
    pub attach: Option<Attachment>,
}

/// What an object is in the simulation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// Simulated in its skinning subspace.
    #[default]
    Deformable,
    /// Never moves: not simulated, collides as its convex hull.
    Static,
    /// Moves with the link it is attached to (or stays put), undeformed: not simulated,
    /// collides as its convex hull.
    Rigid,
}

/// Where an object's geometry comes from (exactly one of `file`, `shape`, `topic`).
#[derive(Clone, Debug)]
pub enum Source<'a> {
    /// A mesh or cloud file.
    File(&'a Path),
    /// Geometry made in code.
    Shape(&'a ShapeSpec),
    /// The frame_id the geometry arrives under on the node's input topics.
    Topic(&'a str),
}

impl ObjectSpec {
    /// Where the geometry comes from (`file` first, then `shape`, then `topic`). Panics on a
    /// spec that holds none (a checked scene file never does).
    pub fn source(&self) -> Source<'_> {
        match (&self.file, &self.shape, &self.topic) {
            (Some(f), _, _) => Source::File(f),
            (_, Some(s), _) => Source::Shape(s),
            (_, _, Some(t)) => Source::Topic(t),
            _ => unreachable!("checked when the file was read"),
        }
    }
}

/// Geometry made in code, centred at the origin (then placed at the object's `position`), m.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeSpec {
    /// A box of these side lengths along x, y, z.
    Box([f64; 3]),
    /// A ball of this radius.
    Sphere(f64),
    /// A capsule along x: [length end to end, radius].
    Capsule([f64; 2]),
    /// A bundled shape by name (`plate`, `rod`, `creature`, `box`, `sphere`).
    Bundled(String),
}

/// An object's material.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus, Pa. Default 2e5.
    #[serde(default = "default_young")]
    pub young: f64,
    /// Default 0.45.
    #[serde(default = "default_poisson")]
    pub poisson: f64,
    /// kg/m^3. Default 1000.
    #[serde(default = "default_density")]
    pub density: f64,
}

impl Default for MaterialSpec {
    fn default() -> Self {
        Self {
            young: default_young(),
            poisson: default_poisson(),
            density: default_density(),
        }
    }
}

/// A number, or `auto`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resolution {
    /// This many.
    Fixed(usize),
    /// The fewest that keep the object within the scene's error budget.
    #[default]
    Auto,
}

impl Serialize for Resolution {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Resolution::Fixed(n) => s.serialize_u64(*n as u64),
            Resolution::Auto => s.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for Resolution {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match serde_yaml::Value::deserialize(d)? {
            serde_yaml::Value::Number(n) if n.as_u64().is_some() => {
                Ok(Resolution::Fixed(n.as_u64().unwrap_or_default() as usize))
            }
            serde_yaml::Value::String(w) if w == "auto" => Ok(Resolution::Auto),
            other => Err(serde::de::Error::custom(format!(
                "`handles` and `cubature` take a whole number or `auto`, got {}",
                serde_yaml::to_string(&other).unwrap_or_default().trim()
            ))),
        }
    }
}

/// A ball of material, in world coordinates at rest.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Its centre, m.
    pub center: [f64; 3],
    /// Its radius, m.
    pub radius: f64,
}

/// A region of an object held by a robot link.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Attachment {
    /// The robot's name.
    pub robot: String,
    /// The link's name in the robot's URDF.
    pub link: String,
    /// The material held (world, at rest, with the robot at its first pose). For a rigid
    /// object, ignored: all of it moves with the link.
    #[serde(flatten)]
    pub region: Option<Region>,
}

fn default_rate() -> f64 {
    60.0
}
fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}
fn default_damping() -> f64 {
    1.0
}
/// The Coulomb friction of a scene that names none, and of the node's contacts by default.
pub const DEFAULT_FRICTION: f64 = 0.5;

fn default_friction() -> f64 {
    DEFAULT_FRICTION
}
/// The rolling friction of a scene that names none, m.
pub const DEFAULT_ROLLING_FRICTION: f64 = 1e-3;

fn default_rolling_friction() -> f64 {
    DEFAULT_ROLLING_FRICTION
}
fn default_budget() -> f64 {
    5.0
}
fn default_sleep() -> Option<SleepRule> {
    Some(SleepRule::default())
}
fn default_joint_states() -> String {
    "/joint_states".into()
}
fn default_young() -> f64 {
    2e5
}
fn default_poisson() -> f64 {
    0.45
}
fn default_density() -> f64 {
    1000.0
}

impl SceneFile {
    /// Reads and checks a scene file; relative paths in it are made relative to its directory.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: path.into(),
            source,
        })?;
        let mut scene = Self::parse(&text).map_err(|reason| SceneError::Invalid {
            path: path.into(),
            reason,
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        for robot in &mut scene.robots {
            robot.urdf = dir.join(&robot.urdf);
        }
        for object in &mut scene.objects {
            if let Some(file) = &mut object.file {
                *file = dir.join(&*file);
            }
        }
        Ok(scene)
    }

    /// Parses and checks scene YAML; the error names the key and what is wrong with it.
    pub fn parse(text: &str) -> Result<Self, String> {
        let scene: Self = serde_yaml::from_str(text).map_err(|e| e.to_string())?;
        scene.check()?;
        Ok(scene)
    }

    fn check(&self) -> Result<(), String> {
        let positive = |what: String, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{what} must be a positive number, got {v}"))
            }
        };
        positive("rate_hz".into(), self.rate_hz)?;
        positive("error_budget_pct".into(), self.error_budget_pct)?;
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err("gravity must be finite".into());
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(format!("damping must be >= 0, got {}", self.damping));
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(format!("friction must be >= 0, got {}", self.friction));
        }
        if !(self.rolling_friction.is_finite() && self.rolling_friction >= 0.0) {
            return Err(format!(
                "rolling_friction must be >= 0 m, got {}",
                self.rolling_friction
            ));
        }
        if let Some(rule) = &self.sleep {
            positive("sleep.speed".into(), rule.speed)?;
            positive("sleep.after".into(), rule.after)?;
        }
        if self.objects.is_empty() {
            return Err("the scene has no objects".into());
        }
        let mut names = std::collections::HashSet::new();
        for o in &self.objects {
            let at = |key: &str| format!("object `{}`: {key}", o.name);
            if !names.insert(o.name.as_str()) {
                return Err(format!("two objects are named `{}`", o.name));
            }
            let sources = [o.file.is_some(), o.shape.is_some(), o.topic.is_some()];
            if sources.iter().filter(|s| **s).count() != 1 {
                return Err(at("needs exactly one of `file`, `shape` and `topic`"));
            }
            positive(at("material.young"), o.material.young)?;
            positive(at("material.density"), o.material.density)?;
            if !(o.material.poisson > -1.0 && o.material.poisson < 0.5) {
                return Err(format!(
                    "{} must lie in (-1, 0.5), got {}",
                    at("material.poisson"),
                    o.material.poisson
                ));
            }
            if !o.position.iter().all(|c| c.is_finite()) {
                return Err(at("position must be finite"));
            }
            if let Resolution::Fixed(n) = o.handles {
                if n < 2 {
                    return Err(format!("{} must be at least 2, got {n}", at("handles")));
                }
            }
            if let Resolution::Fixed(n) = o.cubature {
                if n < 16 {
                    return Err(format!("{} must be at least 16, got {n}", at("cubature")));
                }
            }
            let regions = o
                .pins
                .iter()
                .chain(o.attach.iter().filter_map(|a| a.region.as_ref()));
            for r in regions {
                positive(at("pin or attachment radius"), r.radius)?;
            }
            if let Some(a) = &o.attach {
                if !self.robots.iter().any(|r| r.name == a.robot) {
                    return Err(format!(
                        "{} names no robot of the scene",
                        at(&format!("attach.robot `{}`", a.robot))
                    ));
                }
                if a.region.is_none() && o.kind == ObjectKind::Deformable {
                    return Err(at(
                        "attach needs a center and radius for a deformable object",
                    ));
                }
            }
        }
        for r in &self.robots {
            for pair in r.motion.windows(2) {
                if pair[1].at.is_nan() || pair[1].at <= pair[0].at {
                    return Err(format!(
                        "robot `{}`: motion keyframes must have increasing `at`",
                        r.name
                    ));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_scene_parses_with_defaults() {
        let scene = SceneFile::parse(
            "floor: 0\nobjects:\n  - name: ball\n    shape: {sphere: 0.1}\n    position: [0, 0, 0.1]\n    handles: 9\n",
        )
        .unwrap();
        let ball = &scene.objects[0];
        assert_eq!(ball.handles, Resolution::Fixed(9));
        assert_eq!(ball.cubature, Resolution::Auto);
        assert_eq!(ball.kind, ObjectKind::Deformable);
        assert!(matches!(ball.source(), Source::Shape(ShapeSpec::Sphere(r)) if *r == 0.1));
        assert_eq!(scene.sleep, Some(SleepRule::default()));
    }

    #[test]
    fn mistakes_are_named() {
        let cases = [
            ("objects:\n  - name: a\n    shape: {sphere: 0.1}\n    handels: 9\n", "handels"),
            ("objects:\n  - name: a\n    shape: {sphere: 0.1}\n    handles: many\n", "handles"),
            ("objects:\n  - name: a\n    shape: {sphere: 0.1}\n    material: {poisson: 0.5}\n", "material.poisson"),
            ("objects:\n  - name: a\n    shape: {sphere: 0.1}\n  - name: a\n    shape: {sphere: 0.1}\n", "two objects"),
            ("objects:\n  - name: a\n    shape: {sphere: 0.1}\n    attach: {robot: arm, link: tool, center: [0,0,0], radius: 0.1}\n", "attach.robot `arm`"),
            ("objects: []\n", "no objects"),
            ("objects:\n  - name: a\n", "exactly one of `file`, `shape` and `topic`"),
            ("rate_hz: -1\nobjects: []\n", "rate_hz"),
        ];
        for (text, named) in cases {
            let err = SceneFile::parse(text).unwrap_err();
            assert!(err.contains(named), "`{named}` not in: {err}");
        }
    }
}
