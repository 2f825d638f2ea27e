//! A convex hull as half-spaces in f64: how deformable objects collide with each other. A
//! point inside a convex solid is nearest to the boundary through one of its faces, so its
//! depth is the least distance to a face plane: exact, smooth within a face, and a few dozen
//! dot products, where parry's projection onto a polyhedron cost tens of microseconds a point.

use std::collections::HashSet;

use nalgebra::Vector3;
use parry3d::math::Vector;
use parry3d::transformation::try_convex_hull;

/// Planes whose normals (unit) and offsets (m) agree to this count as one face: a box's hull
/// is triangulated, two triangles a side.
const SAME_PLANE: f64 = 1e-6;

/// A convex solid: the points with `normal . p <= offset` for every face.
#[derive(Clone, Debug)]
pub struct ConvexHull {
    /// Outward unit normal and offset of each face plane.
    planes: Vec<(Vector3<f64>, f64)>,
    lo: Vector3<f64>,
    hi: Vector3<f64>,
}

impl ConvexHull {
    /// The hull of `points`; None when they span no volume.
    pub fn of(points: &[Vector3<f64>]) -> Option<Self> {
        let (lo, hi) = points.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), p| (lo.inf(p), hi.sup(p)),
        );
        let at: Vec<Vector> = points
            .iter()
            .map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32))
            .collect();
        let (vertices, triangles) = try_convex_hull(&at).ok()?;
        let v = |i: u32| {
            let c = vertices[i as usize];
            Vector3::new(c.x as f64, c.y as f64, c.z as f64)
        };
        let centre = (lo + hi) / 2.0;
        let mut planes: Vec<(Vector3<f64>, f64)> = Vec::new();
        let mut seen = HashSet::new();
        for [a, b, c] in triangles {
            let (a, b, c) = (v(a), v(b), v(c));
            let Some(mut normal) = (b - a).cross(&(c - a)).try_normalize(1e-18) else {
                continue;
            };
            if normal.dot(&(a - centre)) < 0.0 {
                normal = -normal;
            }
            let offset = normal.dot(&a);
            // Coplanar triangles (a box's sides) are one face: keyed by the plane, rounded.
            let key =
                [normal.x, normal.y, normal.z, offset].map(|x| (x / SAME_PLANE).round() as i64);
            if seen.insert(key) {
                planes.push((normal, offset));
            }
        }
        (planes.len() >= 4).then_some(Self { planes, lo, hi })
    }

    /// A hull that holds no point and whose bounds are empty: the place of an object that is
    /// far from everything, which keeps the other colliders' indices.
    pub fn nowhere() -> Self {
        Self {
            planes: Vec::new(),
            lo: Vector3::repeat(f64::INFINITY),
            hi: Vector3::repeat(f64::NEG_INFINITY),
        }
    }

    /// Whether this is [`ConvexHull::nowhere`].
    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
    }

    /// The bounding box grown by `margin`.
    pub fn bounds(&self, margin: f64) -> (Vector3<f64>, Vector3<f64>) {
        let m = Vector3::repeat(margin);
        (self.lo - m, self.hi + m)
    }

    /// Whether `p` is inside or may be within `margin` of the hull: false only when a face's
    /// plane has it farther outside than that (the distance to a convex solid is at least the
    /// largest distance outside one of its face planes).
    pub fn is_within(&self, p: &Vector3<f64>, margin: f64) -> bool {
        !self.planes.is_empty()
            && self
                .planes
                .iter()
                .all(|(normal, offset)| normal.dot(p) - offset < margin)
    }

    /// How deep `p` is inside (m) and the outward normal of the nearest face; None outside.
    pub fn penetration(&self, p: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
        if self.planes.is_empty() {
            return None;
        }
        let mut best: Option<(f64, &Vector3<f64>)> = None;
        for (normal, offset) in &self.planes {
            let depth = offset - normal.dot(p);
            if depth <= 0.0 {
                return None;
            }
            if best.is_none_or(|(d, _)| depth < d) {
                best = Some((depth, normal));
            }
        }
        best.map(|(depth, normal)| (depth, *normal))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cube_hull_has_six_faces_and_exact_depths() {
        let corners: Vec<Vector3<f64>> = (0..8)
            .map(|i| Vector3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64))
            .collect();
        let hull = ConvexHull::of(&corners).unwrap();
        assert_eq!(hull.planes.len(), 6);
        let (depth, normal) = hull.penetration(&Vector3::new(0.5, 0.5, 0.9)).unwrap();
        assert!((depth - 0.1).abs() < 1e-6 && (normal - Vector3::z()).norm() < 1e-6);
        assert!(hull.penetration(&Vector3::new(0.5, 0.5, 1.01)).is_none());
        assert!(
            ConvexHull::of(&corners[..4]).is_none(),
            "a square spans no volume"
        );
    }
}
