//! One depth camera's view of a mesh: a point where each pixel's ray first meets the surface
//! (a z-buffer), the visible side only, as a robot's camera sees an object. Tests and benches
//! make their single-view inputs with it.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use parry3d::math::Vector;
use parry3d::query::{Ray, RayCast};
use parry3d::shape::TriMesh;

use super::shape::Shape;
use crate::{Error, Result};

/// A pinhole camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// The camera's centre, in the shape's frame.
    pub position: Vector3<f64>,
    /// The point at the centre of the image.
    pub target: Vector3<f64>,
    /// Image width, pixels.
    pub width: usize,
    /// Image height, pixels.
    pub height: usize,
    /// Horizontal field of view.
    pub fov_deg: f64,
}

impl Camera {
    /// A camera `diagonals` bounding-box diagonals from the centre of `shape`, on the side
    /// `direction` points to, looking at the centre; the object spans about 80 % of the
    /// image's height.
    pub fn looking_at(
        shape: &Shape,
        direction: Vector3<f64>,
        diagonals: f64,
        width: usize,
        height: usize,
    ) -> Self {
        let (lo, hi) = shape.bounds();
        let centre = (lo + hi) / 2.0;
        let diagonal = (hi - lo).norm();
        let distance = diagonals * diagonal;
        let vertical = 2.0 * (0.5 * diagonal / 0.8 / distance).atan();
        let horizontal = 2.0 * ((vertical / 2.0).tan() * width as f64 / height as f64).atan();
        Self {
            position: centre + direction.normalize() * distance,
            target: centre,
            width,
            height,
            fov_deg: horizontal.to_degrees(),
        }
    }

    /// The camera's optical frame in world coordinates (REP 103: z forward, x right, y down),
    /// as the transform of points from that frame into the world.
    pub fn optical_pose(&self) -> Isometry3<f64> {
        let forward = (self.target - self.position).normalize();
        let up = if forward.cross(&Vector3::z()).norm() > 1e-6 {
            Vector3::z()
        } else {
            Vector3::y()
        };
        let right = forward.cross(&up).normalize();
        let down = forward.cross(&right);
        let rotation =
            Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[right, down, forward]));
        Isometry3::from_parts(
            Translation3::from(self.position),
            UnitQuaternion::from_rotation_matrix(&rotation),
        )
    }

    /// The unit ray of pixel (column, row), in world coordinates.
    fn ray(&self, pose: &Isometry3<f64>, column: usize, row: usize) -> Vector3<f64> {
        let focal = 0.5 * self.width as f64 / (self.fov_deg.to_radians() / 2.0).tan();
        let x = (column as f64 + 0.5 - 0.5 * self.width as f64) / focal;
        let y = (row as f64 + 0.5 - 0.5 * self.height as f64) / focal;
        (pose.rotation * Vector3::new(x, y, 1.0)).normalize()
    }
}

/// The camera's image of `shape` (a mesh), row by row: per pixel the first surface point its
/// ray meets, in world coordinates, or None where the ray misses.
pub fn scan(shape: &Shape, camera: &Camera) -> Result<Vec<Option<Vector3<f64>>>> {
    if shape.is_point_cloud() {
        return Err(Error::Geometry(
            "a scan needs a mesh: a point cloud has no surface to hit".into(),
        ));
    }
    let image = scan_faces(&shape.positions, &shape.triangles, camera)?;
    Ok(image.into_iter().map(|hit| hit.map(|(p, _)| p)).collect())
}

/// Per pixel, where its ray met a triangle and which triangle: None where it met none.
pub type FaceHits = Vec<Option<(Vector3<f64>, usize)>>;

/// `scan` of a triangle soup, each hit with the index of the triangle it lies on: what a
/// benchmark needs to know which material point each pixel saw.
pub fn scan_faces(
    positions: &[Vector3<f64>],
    triangles: &[[u32; 3]],
    camera: &Camera,
) -> Result<FaceHits> {
    let vertices = positions
        .iter()
        .map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32))
        .collect();
    let mesh = TriMesh::new(vertices, triangles.to_vec())
        .map_err(|e| Error::Geometry(format!("the mesh cannot be ray-cast: {e:?}")))?;
    let pose = camera.optical_pose();
    let origin = camera.position;
    let o = Vector::new(origin.x as f32, origin.y as f32, origin.z as f32);
    let mut image = Vec::with_capacity(camera.width * camera.height);
    for row in 0..camera.height {
        for column in 0..camera.width {
            let d = camera.ray(&pose, column, row);
            let ray = Ray::new(o, Vector::new(d.x as f32, d.y as f32, d.z as f32));
            let hit = mesh.cast_local_ray_and_get_normal(&ray, f32::MAX, true);
            image.push(hit.map(|h| (origin + d * h.time_of_impact as f64, h.subshape as usize)));
        }
    }
    Ok(image)
}

/// The points of a scan, without the misses.
pub fn scan_points(shape: &Shape, camera: &Camera) -> Result<Vec<Vector3<f64>>> {
    Ok(scan(shape, camera)?.into_iter().flatten().collect())
}
