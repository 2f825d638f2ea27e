//! A URDF's geometry as parry3d shapes: its primitives, and its meshes found the ROS way
//! (beside the URDF file, or in a package on `ROS_PACKAGE_PATH` or under `share/` of an
//! `AMENT_PREFIX_PATH` prefix).

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use parry3d::math::{Pose, Rotation, Vector};
use parry3d::shape::SharedShape;

/// Where a URDF's mesh file names are looked up.
#[derive(Clone, Debug, Default)]
pub struct MeshLookup {
    /// The URDF file's directory, when it came from a file.
    dir: Option<PathBuf>,
    /// `ROS_PACKAGE_PATH`'s entries: each a package, or a directory of packages.
    package_paths: Vec<PathBuf>,
    /// `AMENT_PREFIX_PATH`'s entries: a package `pkg` lives in `prefix/share/pkg`.
    prefixes: Vec<PathBuf>,
}

impl MeshLookup {
    /// Meshes of a URDF file in `dir`, then the environment's packages.
    pub fn beside(dir: &Path) -> Self {
        Self {
            dir: Some(dir.to_path_buf()),
            ..Self::from_environment()
        }
    }

    /// Meshes of a URDF that came without a file (`robot_description`): the environment's
    /// packages only.
    pub fn from_environment() -> Self {
        let var = |name: &str| std::env::var(name).unwrap_or_default();
        Self::with_paths(None, &var("ROS_PACKAGE_PATH"), &var("AMENT_PREFIX_PATH"))
    }

    /// Meshes looked up beside `dir` (if any), then in the colon-separated `ros_package_path`
    /// and `ament_prefix_path`.
    pub fn with_paths(
        dir: Option<PathBuf>,
        ros_package_path: &str,
        ament_prefix_path: &str,
    ) -> Self {
        let split = |s: &str| -> Vec<PathBuf> {
            s.split(':')
                .filter(|p| !p.is_empty())
                .map(PathBuf::from)
                .collect()
        };
        Self {
            dir,
            package_paths: split(ros_package_path),
            prefixes: split(ament_prefix_path),
        }
    }

    /// The file a URDF mesh name stands for: a path relative to the URDF, `file://`, or
    /// `package://pkg/rest` (beside the URDF and one directory up, as a package's `urdf/` and
    /// `meshes/` usually sit, then in the ROS package paths).
    pub fn find(&self, filename: &str) -> Result<PathBuf, String> {
        if let Some(path) = filename.strip_prefix("file://") {
            return Ok(PathBuf::from(path));
        }
        let Some(rest) = filename.strip_prefix("package://") else {
            return match &self.dir {
                Some(dir) => Ok(dir.join(filename)),
                None => Ok(PathBuf::from(filename)),
            };
        };
        let (package, inner) = rest.split_once('/').unwrap_or(("", rest));
        let beside = self.dir.iter().flat_map(|d| [d.clone(), d.join("..")]);
        beside
            .chain(self.package_dirs(package))
            .map(|d| d.join(inner))
            .find(|p| p.exists())
            .ok_or_else(|| {
                let beside = self
                    .dir
                    .as_ref()
                    .map_or(String::new(), |d| format!("beside {}, ", d.display()));
                format!(
                    "mesh `{filename}` not found ({beside}in ROS_PACKAGE_PATH {:?} or under \
                     share/ of AMENT_PREFIX_PATH {:?})",
                    self.package_paths, self.prefixes
                )
            })
    }

    /// Where package `name` may live: a ROS_PACKAGE_PATH entry that is the package (by its
    /// directory name or its package.xml), a directory of that name in an entry, and
    /// `share/name` under each ament prefix.
    fn package_dirs<'a>(&'a self, name: &'a str) -> impl Iterator<Item = PathBuf> + 'a {
        let is_package = move |dir: &Path| {
            dir.file_name().is_some_and(|n| n == name)
                || std::fs::read_to_string(dir.join("package.xml"))
                    .is_ok_and(|xml| xml.contains(&format!("<name>{name}</name>")))
        };
        let ros = self.package_paths.iter().flat_map(move |p| {
            let own = is_package(p).then(|| p.clone());
            own.into_iter().chain([p.join(name)])
        });
        let ament = self
            .prefixes
            .iter()
            .map(move |p| p.join("share").join(name));
        ros.chain(ament)
    }
}

/// A URDF geometry as a parry3d shape in the geometry's own frame (URDF cylinders and capsules
/// run along z; parry's cylinder runs along y, so it is turned). Meshes collide as their convex
/// hull: parry's inside test on a triangle mesh needs a closed, consistently wound surface,
/// which robot meshes often are not.
pub(crate) fn collision_shape(
    geometry: &urdf_rs::Geometry,
    meshes: &MeshLookup,
) -> Result<SharedShape, String> {
    use urdf_rs::Geometry as G;
    Ok(match geometry {
        G::Box { size } => {
            let [x, y, z] = size.0;
            SharedShape::cuboid(
                positive("box size", x)? / 2.0,
                positive("box size", y)? / 2.0,
                positive("box size", z)? / 2.0,
            )
        }
        G::Sphere { radius } => SharedShape::ball(positive("sphere radius", *radius)?),
        G::Capsule { radius, length } => SharedShape::capsule_z(
            positive("capsule length", *length)? / 2.0,
            positive("capsule radius", *radius)?,
        ),
        G::Cylinder { radius, length } => {
            let cylinder = SharedShape::cylinder(
                positive("cylinder length", *length)? / 2.0,
                positive("cylinder radius", *radius)?,
            );
            let y_to_z = Isometry3::rotation(Vector3::x() * std::f64::consts::FRAC_PI_2);
            SharedShape::compound(vec![(to_parry(&y_to_z), cylinder)])
        }
        G::Mesh { filename, scale } => {
            let (points, path) = mesh_points(filename, scale.as_ref(), meshes)?;
            SharedShape::convex_hull(&points)
                .ok_or_else(|| format!("mesh {}: no convex hull (flat?)", path.display()))?
        }
    })
}

/// The box around a link's visual geometry, with its pose in the link frame: what stands in
/// for a collision shape that cannot be made (its mesh not found). None when no visual
/// geometry can be made either.
pub(crate) fn visual_box(
    link: &urdf_rs::Link,
    meshes: &MeshLookup,
) -> Option<(SharedShape, Isometry3<f64>)> {
    link.visual.iter().find_map(|v| {
        let (lo, hi) = geometry_bounds(&v.geometry, meshes)?;
        let half = (hi - lo) / 2.0;
        let centre = Isometry3::translation(
            (lo.x + hi.x) / 2.0,
            (lo.y + hi.y) / 2.0,
            (lo.z + hi.z) / 2.0,
        );
        let positive = half.iter().all(|h| *h > 0.0 && h.is_finite());
        positive.then(|| {
            let shape = SharedShape::cuboid(half.x as f32, half.y as f32, half.z as f32);
            (shape, pose_of(&v.origin) * centre)
        })
    })
}

/// The axis-aligned bounds of a geometry in its own frame.
fn geometry_bounds(
    geometry: &urdf_rs::Geometry,
    meshes: &MeshLookup,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    use urdf_rs::Geometry as G;
    let symmetric = |h: Vector3<f64>| Some((-h, h));
    match geometry {
        G::Box { size } => symmetric(Vector3::from(size.0) / 2.0),
        G::Sphere { radius } => symmetric(Vector3::repeat(*radius)),
        G::Cylinder { radius, length } => symmetric(Vector3::new(*radius, *radius, length / 2.0)),
        G::Capsule { radius, length } => {
            symmetric(Vector3::new(*radius, *radius, length / 2.0 + radius))
        }
        G::Mesh { filename, scale } => {
            let (points, _) = mesh_points(filename, scale.as_ref(), meshes).ok()?;
            let as_f64 = |p: &Vector| Vector3::new(p.x as f64, p.y as f64, p.z as f64);
            let first = as_f64(points.first()?);
            Some(
                points
                    .iter()
                    .map(as_f64)
                    .fold((first, first), |(lo, hi), p| (lo.inf(&p), hi.sup(&p))),
            )
        }
    }
}

/// A mesh file's vertices, scaled, and the file they came from.
fn mesh_points(
    filename: &str,
    scale: Option<&urdf_rs::Vec3>,
    meshes: &MeshLookup,
) -> Result<(Vec<Vector>, PathBuf), String> {
    let path = meshes.find(filename)?;
    let raw = crate::geometry::load_geometry(&path)
        .map_err(|e| format!("mesh {}: {e}", path.display()))?;
    let s = scale.map(|s| s.0).unwrap_or([1.0; 3]);
    let points = raw
        .positions
        .iter()
        .map(|p| {
            Vector::new(
                (p[0] * s[0]) as f32,
                (p[1] * s[1]) as f32,
                (p[2] * s[2]) as f32,
            )
        })
        .collect();
    Ok((points, path))
}

/// A URDF pose (xyz, then roll-pitch-yaw about fixed x, y, z).
pub(crate) fn pose_of(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [r, pitch, y] = p.rpy.0;
    Isometry3::from_parts(
        Translation3::from(Vector3::from(p.xyz.0)),
        UnitQuaternion::from_euler_angles(r, pitch, y),
    )
}

pub(crate) fn to_parry(pose: &Isometry3<f64>) -> Pose {
    let t = pose.translation.vector;
    let q = pose.rotation.quaternion();
    Pose::from_parts(
        Vector::new(t.x as f32, t.y as f32, t.z as f32),
        Rotation::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32).normalize(),
    )
}

fn positive(what: &str, v: f64) -> Result<f32, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v as f32)
    } else {
        Err(format!("{what} must be positive, got {v}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory under the system's temporary one.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("physskin-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn packages_are_found_on_both_ros_paths() {
        let root = scratch("packages");
        for dir in [
            "src/gripper_description/meshes",
            "install/share/arm_description/meshes",
        ] {
            std::fs::create_dir_all(root.join(dir)).unwrap();
        }
        std::fs::write(root.join("src/gripper_description/meshes/finger.stl"), b"x").unwrap();
        std::fs::write(
            root.join("install/share/arm_description/meshes/link.stl"),
            b"x",
        )
        .unwrap();
        let ros = root.join("src");
        let ament = format!("/nonexistent:{}", root.join("install").display());
        let lookup = MeshLookup::with_paths(None, ros.to_str().unwrap(), &ament);
        let found = lookup
            .find("package://gripper_description/meshes/finger.stl")
            .unwrap();
        assert_eq!(
            found,
            root.join("src/gripper_description/meshes/finger.stl")
        );
        let found = lookup
            .find("package://arm_description/meshes/link.stl")
            .unwrap();
        assert_eq!(
            found,
            root.join("install/share/arm_description/meshes/link.stl")
        );
        // A ROS_PACKAGE_PATH entry may be the package itself.
        let own = MeshLookup::with_paths(
            None,
            root.join("src/gripper_description").to_str().unwrap(),
            "",
        );
        assert!(own
            .find("package://gripper_description/meshes/finger.stl")
            .is_ok());
        let err = lookup
            .find("package://arm_description/meshes/gone.stl")
            .unwrap_err();
        assert!(
            err.contains("package://arm_description/meshes/gone.stl")
                && err.contains("AMENT_PREFIX_PATH"),
            "{err}"
        );
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_visual_box_bounds_the_visual_geometry_at_its_origin() {
        let urdf = r#"<robot name="r"><link name="l">
            <visual><origin xyz="0 0 0.5"/><geometry><cylinder radius="0.1" length="0.4"/></geometry></visual>
            <collision><geometry><mesh filename="package://none/gone.stl"/></geometry></collision>
            </link></robot>"#;
        let robot = urdf_rs::read_from_string(urdf).unwrap();
        let lookup = MeshLookup::default();
        assert!(collision_shape(&robot.links[0].collision[0].geometry, &lookup).is_err());
        let (shape, pose) = visual_box(&robot.links[0], &lookup).unwrap();
        let cuboid = shape.as_cuboid().unwrap();
        assert!((cuboid.half_extents - Vector::new(0.1, 0.1, 0.2)).length() < 1e-6);
        assert!((pose.translation.vector - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
    }
}
