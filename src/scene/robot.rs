//! Robots from URDF: the kinematic tree, forward kinematics from joint positions, and each
//! link's collision geometry as parry3d shapes that push soft objects.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use parry3d::shape::SharedShape;

use super::urdf_geometry::{collision_shape, pose_of, to_parry, visual_box, MeshLookup};
use super::SceneError;
use crate::physics::Obstacle;

/// A robot: links, the joints between them, and the joints' current positions.
#[derive(Clone)]
pub struct Robot {
    name: String,
    base: Isometry3<f64>,
    links: Vec<Link>,
    /// Joints ordered parents first, so one pass computes every link pose.
    joints: Vec<Joint>,
    root: usize,
    link_index: HashMap<String, usize>,
}

#[derive(Clone)]
struct Link {
    name: String,
    /// Collision shapes and their poses in the link frame.
    shapes: Vec<(SharedShape, Isometry3<f64>)>,
}

#[derive(Clone)]
struct Joint {
    name: String,
    motion: JointMotion,
    origin: Isometry3<f64>,
    axis: Unit<Vector3<f64>>,
    parent: usize,
    child: usize,
    lower: f64,
    upper: f64,
    position: f64,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum JointMotion {
    Fixed,
    Revolute,
    Prismatic,
}

impl Robot {
    /// Reads a URDF file; meshes are looked up beside it, then in the ROS package paths. A
    /// collision shape that cannot be made is an error.
    pub fn from_urdf(path: &Path, base: Isometry3<f64>) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: path.into(),
            source,
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::from_urdf_text(&text, dir, base).map_err(|reason| SceneError::Urdf {
            path: path.into(),
            reason,
        })
    }

    /// Parses URDF text; `dir` resolves mesh file names. A collision shape that cannot be
    /// made is an error.
    pub fn from_urdf_text(text: &str, dir: &Path, base: Isometry3<f64>) -> Result<Self, String> {
        let (robot, _) = Self::parse(text, &MeshLookup::beside(dir), base, false)?;
        Ok(robot)
    }

    /// A robot as `robot_description` carries it, its root link at the origin. A collision
    /// mesh that cannot be found or read does not refuse the robot: the link collides as the
    /// box around its visual geometry (or not at all without one), and the returned notes say
    /// so, one per link.
    pub fn from_description(
        text: &str,
        meshes: &MeshLookup,
    ) -> Result<(Self, Vec<String>), String> {
        Self::parse(text, meshes, Isometry3::identity(), true)
    }

    /// The robot of URDF `text`; with `lenient`, links whose collision shapes cannot be made
    /// stand in with their visual box (and a note says so).
    fn parse(
        text: &str,
        meshes: &MeshLookup,
        base: Isometry3<f64>,
        lenient: bool,
    ) -> Result<(Self, Vec<String>), String> {
        let urdf = urdf_rs::read_from_string(text).map_err(|e| e.to_string())?;
        let mut link_index = HashMap::new();
        let mut links = Vec::new();
        let mut notes = Vec::new();
        for link in &urdf.links {
            if link_index.insert(link.name.clone(), links.len()).is_some() {
                return Err(format!("link `{}` is defined twice", link.name));
            }
            let shapes = match link_shapes(link, meshes) {
                Ok(shapes) => shapes,
                Err(e) if lenient => {
                    let stand_in = visual_box(link, meshes);
                    let how = if stand_in.is_some() {
                        "it collides as the box around its visual geometry"
                    } else {
                        "it has no visual geometry to stand in and does not collide"
                    };
                    notes.push(format!("link `{}`: {e}; {how}", link.name));
                    stand_in.into_iter().collect()
                }
                Err(e) => return Err(format!("link `{}`: {e}", link.name)),
            };
            links.push(Link {
                name: link.name.clone(),
                shapes,
            });
        }
        if links.is_empty() {
            return Err("the robot has no links".into());
        }
        let mut joints = Vec::new();
        let mut has_parent = vec![false; links.len()];
        for j in &urdf.joints {
            let find = |name: &str| {
                link_index
                    .get(name)
                    .copied()
                    .ok_or_else(|| format!("joint `{}` names an unknown link `{name}`", j.name))
            };
            let (parent, child) = (find(&j.parent.link)?, find(&j.child.link)?);
            if std::mem::replace(&mut has_parent[child], true) {
                return Err(format!("link `{}` has two parent joints", j.child.link));
            }
            use urdf_rs::JointType as T;
            let motion = match j.joint_type {
                T::Fixed => JointMotion::Fixed,
                T::Revolute | T::Continuous => JointMotion::Revolute,
                T::Prismatic => JointMotion::Prismatic,
                ref other => {
                    return Err(format!(
                        "joint `{}` is {other:?}: only fixed, revolute, continuous and \
                         prismatic joints are supported",
                        j.name
                    ))
                }
            };
            let axis = Vector3::from(j.axis.xyz.0);
            let axis = Unit::try_new(axis, 1e-9).unwrap_or(Vector3::x_axis());
            let (lower, upper) = match j.joint_type {
                T::Revolute | T::Prismatic if j.limit.lower <= j.limit.upper => {
                    (j.limit.lower, j.limit.upper)
                }
                _ => (f64::NEG_INFINITY, f64::INFINITY),
            };
            joints.push(Joint {
                name: j.name.clone(),
                motion,
                origin: pose_of(&j.origin),
                axis,
                parent,
                child,
                lower,
                upper,
                position: 0.0_f64.clamp(lower, upper),
            });
        }
        let roots: Vec<usize> = (0..links.len()).filter(|&l| !has_parent[l]).collect();
        let [root] = roots[..] else {
            let names: Vec<_> = roots.iter().map(|&l| links[l].name.as_str()).collect();
            return Err(format!("the robot needs one root link, found {names:?}"));
        };
        // Parents first: a breadth-first walk from the root (a cycle leaves joints unvisited).
        let mut ordered = Vec::with_capacity(joints.len());
        let mut frontier = vec![root];
        while let Some(link) = frontier.pop() {
            for (i, j) in joints.iter().enumerate().filter(|(_, j)| j.parent == link) {
                ordered.push(i);
                frontier.push(j.child);
            }
        }
        if ordered.len() != joints.len() {
            return Err("the joints form a cycle".into());
        }
        let mut slots: Vec<Option<Joint>> = joints.into_iter().map(Some).collect();
        let joints = ordered
            .into_iter()
            .map(|i| slots[i].take().expect("each joint once"))
            .collect();
        let robot = Self {
            name: urdf.name,
            base,
            links,
            joints,
            root,
            link_index,
        };
        Ok((robot, notes))
    }

    /// The index of the link named `name`; None when the robot has none such.
    pub fn link(&self, name: &str) -> Option<usize> {
        self.link_index.get(name).copied()
    }

    /// The robot's name, as its URDF gives it.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// (links, collision shapes).
    pub fn size(&self) -> (usize, usize) {
        let shapes = self.links.iter().map(|l| l.shapes.len()).sum();
        (self.links.len(), shapes)
    }

    /// Whether the robot has a joint named `name` (fixed joints included).
    pub fn has_joint(&self, name: &str) -> bool {
        self.joints.iter().any(|j| j.name == name)
    }

    /// Sets joint positions by name (rad or m), as a JointState carries them; positions outside
    /// a joint's limits are clamped. Names this robot lacks are an error (naming them), but the
    /// known ones are still applied.
    pub fn set_joint_positions(
        &mut self,
        names: &[String],
        positions: &[f64],
    ) -> Result<(), String> {
        if names.len() != positions.len() {
            return Err(format!(
                "{} joint names but {} positions",
                names.len(),
                positions.len()
            ));
        }
        let mut unknown = Vec::new();
        for (name, &q) in names.iter().zip(positions) {
            match self.joints.iter_mut().find(|j| j.name == *name) {
                Some(j) if q.is_finite() => j.position = q.clamp(j.lower, j.upper),
                Some(_) => unknown.push(format!("{name} (non-finite position {q})")),
                None => unknown.push(name.clone()),
            }
        }
        if unknown.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "robot `{}` has no joint {}",
                self.name,
                unknown.join(", ")
            ))
        }
    }

    /// World pose of every link (indexed like `link`), from the current joint positions.
    pub fn link_poses(&self) -> Vec<Isometry3<f64>> {
        self.link_poses_with(|_| None)
    }

    /// World pose of every link: where `placed` puts it (by link name; a pose from /tf), else
    /// its parent's pose moved by the joint between them (the root: the robot's base).
    pub fn link_poses_with(
        &self,
        placed: impl Fn(&str) -> Option<Isometry3<f64>>,
    ) -> Vec<Isometry3<f64>> {
        let mut poses = vec![Isometry3::identity(); self.links.len()];
        poses[self.root] = placed(&self.links[self.root].name).unwrap_or(self.base);
        for j in &self.joints {
            if let Some(pose) = placed(&self.links[j.child].name) {
                poses[j.child] = pose;
                continue;
            }
            let motion = match j.motion {
                JointMotion::Fixed => Isometry3::identity(),
                JointMotion::Revolute => Isometry3::from_parts(
                    Translation3::identity(),
                    UnitQuaternion::from_axis_angle(&j.axis, j.position),
                ),
                JointMotion::Prismatic => Isometry3::from_parts(
                    Translation3::from(j.axis.into_inner() * j.position),
                    UnitQuaternion::identity(),
                ),
            };
            poses[j.child] = poses[j.parent] * j.origin * motion;
        }
        poses
    }

    /// Every link's collision shapes at the link poses, as obstacles.
    pub fn colliders(&self, poses: &[Isometry3<f64>]) -> Vec<Obstacle> {
        self.links
            .iter()
            .zip(poses)
            .flat_map(|(link, pose)| {
                link.shapes
                    .iter()
                    .map(move |(shape, local)| Obstacle::Shape {
                        shape: shape.clone(),
                        pose: to_parry(&(pose * local)),
                    })
            })
            .collect()
    }
}

/// A link's collision shapes with their poses in the link frame.
fn link_shapes(
    link: &urdf_rs::Link,
    meshes: &MeshLookup,
) -> Result<Vec<(SharedShape, Isometry3<f64>)>, String> {
    link.collision
        .iter()
        .map(|c| Ok((collision_shape(&c.geometry, meshes)?, pose_of(&c.origin))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARM: &str = r#"<robot name="arm">
      <link name="base"><collision><geometry><cylinder radius="0.1" length="0.2"/></geometry></collision></link>
      <link name="upper"><collision><origin xyz="0 0 0.25"/><geometry><box size="0.05 0.05 0.5"/></geometry></collision></link>
      <link name="tool"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
        <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="wrist" type="fixed"><parent link="upper"/><child link="tool"/><origin xyz="0 0 0.5"/></joint>
    </robot>"#;

    #[test]
    fn forward_kinematics_follows_the_joints() {
        let mut arm = Robot::from_urdf_text(ARM, Path::new("."), Isometry3::identity()).unwrap();
        let tool = arm.link("tool").unwrap();
        let at_zero = arm.link_poses()[tool].translation.vector;
        assert!((at_zero - Vector3::new(0.0, 0.0, 0.6)).norm() < 1e-12);
        arm.set_joint_positions(&["shoulder".into()], &[std::f64::consts::FRAC_PI_4 * 2.0])
            .unwrap();
        // Clamped to the upper limit, 1 rad about y: the tool swings toward +x.
        let p = arm.link_poses()[tool].translation.vector;
        let expected = Vector3::new(0.5 * 1f64.sin(), 0.0, 0.1 + 0.5 * 1f64.cos());
        assert!((p - expected).norm() < 1e-12, "{p}");
        let err = arm
            .set_joint_positions(&["elbow".into()], &[0.0])
            .unwrap_err();
        assert!(err.contains("no joint elbow"), "{err}");
    }

    #[test]
    fn link_colliders_push_points_out() {
        let arm = Robot::from_urdf_text(ARM, Path::new("."), Isometry3::identity()).unwrap();
        let colliders = arm.colliders(&arm.link_poses());
        assert_eq!(colliders.len(), 3);
        // The base cylinder stands along z: a point 0.09 up its axis is inside, 0.09 along y
        // at mid-height is inside near the side, and one above its top is not.
        let base = &colliders[0];
        assert!(base.penetration(&Vector3::new(0.0, 0.0, 0.09)).is_some());
        assert!(base.penetration(&Vector3::new(0.0, 0.09, 0.0)).is_some());
        assert!(base.penetration(&Vector3::new(0.0, 0.0, 0.11)).is_none());
        let tool = colliders[2]
            .penetration(&Vector3::new(0.0, 0.0, 0.64))
            .unwrap();
        assert!((tool.depth - 0.01).abs() < 1e-5 && tool.normal.z > 0.99);
    }

    #[test]
    fn mesh_geometry_collides_as_its_convex_hull() {
        // A package-style path, found one directory above the URDF's.
        let root = std::env::temp_dir().join(format!("physskin-urdf-{}", std::process::id()));
        std::fs::create_dir_all(root.join("meshes")).unwrap();
        std::fs::create_dir_all(root.join("urdf")).unwrap();
        let cube = crate::geometry::box_mesh(Vector3::new(1.0, 1.0, 1.0));
        let raw = crate::geometry::RawGeometry {
            positions: cube.positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
            normals: None,
            triangles: cube.triangles.clone(),
        };
        let mut file = std::fs::File::create(root.join("meshes/cube.obj")).unwrap();
        crate::geometry::write_obj(&raw, &mut file).unwrap();
        let urdf = r#"<robot name="m"><link name="l"><collision><geometry>
            <mesh filename="package://m/meshes/cube.obj" scale="0.2 0.2 0.4"/></geometry></collision></link></robot>"#;
        let robot = Robot::from_urdf_text(
            urdf,
            &root.join("urdf"),
            Isometry3::translation(1.0, 0.0, 0.0),
        )
        .unwrap();
        let colliders = robot.colliders(&robot.link_poses());
        let inside = colliders[0]
            .penetration(&Vector3::new(1.0, 0.0, 0.15))
            .unwrap();
        assert!((inside.depth - 0.05).abs() < 1e-5, "{inside:?}");
        assert!(colliders[0]
            .penetration(&Vector3::new(1.0, 0.0, 0.25))
            .is_none());
        let missing = urdf.replace("cube.obj", "gone.obj");
        let err = Robot::from_urdf_text(&missing, &root.join("urdf"), Isometry3::identity())
            .err()
            .unwrap();
        assert!(err.contains("package://m/meshes/gone.obj"), "{err}");
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn unsupported_joints_and_unknown_links_are_named() {
        let floating = ARM.replace(r#"type="fixed""#, r#"type="floating""#);
        let err = Robot::from_urdf_text(&floating, Path::new("."), Isometry3::identity())
            .err()
            .unwrap();
        assert!(err.contains("joint `wrist` is Floating"), "{err}");
        let orphan = ARM.replace(r#"<child link="tool"/>"#, r#"<child link="hand"/>"#);
        let err = Robot::from_urdf_text(&orphan, Path::new("."), Isometry3::identity())
            .err()
            .unwrap();
        assert!(err.contains("unknown link `hand`"), "{err}");
    }
}
