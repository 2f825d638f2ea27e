//! Rigid obstacles the object is pushed out of by penalty contact: an exact plane, or any
//! parry3d shape.

use nalgebra::Vector3;
use parry3d::math::{Pose, Vector};
use parry3d::shape::SharedShape;

/// A static rigid obstacle in the world.
#[derive(Clone)]
pub enum Obstacle {
    /// Solid on the side opposite `normal`: points with `normal . p < offset` penetrate.
    /// Kept in f64: the floor is the most common contact and its energy feeds a line search.
    Plane { normal: Vector3<f64>, offset: f64 },
    /// A parry3d shape at a pose (f32 geometry).
    Shape { shape: SharedShape, pose: Pose },
}

/// Penetration of a point into an obstacle: depth (> 0 inside) and the direction that pushes out.
#[derive(Clone, Copy, Debug)]
pub struct Penetration {
    pub depth: f64,
    pub normal: Vector3<f64>,
}

impl Obstacle {
    /// The floor `z = height`, solid below.
    pub fn floor(height: f64) -> Self {
        Obstacle::Plane {
            normal: Vector3::z(),
            offset: height,
        }
    }

    /// Penetration of `p`, or `None` when `p` is outside.
    pub fn penetration(&self, p: &Vector3<f64>) -> Option<Penetration> {
        match self {
            Obstacle::Plane { normal, offset } => {
                let depth = offset - normal.dot(p);
                (depth > 0.0).then_some(Penetration {
                    depth,
                    normal: *normal,
                })
            }
            Obstacle::Shape { shape, pose } => {
                let point = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                let projection = shape.project_point(pose, point, false);
                if !projection.is_inside {
                    return None;
                }
                let to_surface = projection.point - point;
                let depth = to_surface.length();
                (depth > 0.0).then(|| {
                    let n = to_surface / depth;
                    Penetration {
                        depth: depth as f64,
                        normal: Vector3::new(n.x as f64, n.y as f64, n.z as f64),
                    }
                })
            }
        }
    }
}
