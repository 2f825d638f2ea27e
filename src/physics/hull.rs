//! A convex hull as half-spaces in f64: how deformable objects collide with each other. A
//! point inside a convex solid is nearest to the boundary through one of its faces, so its
//! depth is the least distance to a face plane: exact, smooth within a face, and a few dozen
//! dot products, where parry's projection onto a polyhedron cost tens of microseconds a point.

use std::collections::HashSet;

use nalgebra::Vector3;
use parry3d::math::Vector;
use parry3d::transformation::try_convex_hull;
use wide::f64x4;

/// Planes whose normals (unit) and offsets (m) agree to this count as one face: a box's hull
/// is triangulated, two triangles a side.
const SAME_PLANE: f64 = 1e-6;

/// A convex solid: the points with `normal . p <= offset` for every face.
#[derive(Clone, Debug)]
pub struct ConvexHull {
    /// Outward unit normal and offset of each face plane.
    planes: Vec<(Vector3<f64>, f64)>,
    /// The same planes four at a time, for the tests every contact point makes in every
    /// evaluation: a deformed body's hull has hundreds of faces, and the plane loops were
    /// about a sixth of the bundled scene's step (perf).
    quads: Vec<PlaneQuad>,
    lo: Vector3<f64>,
    hi: Vector3<f64>,
}

/// Four face planes: normals' x, y and z, and offsets. Lanes past the last face hold a plane
/// at infinity, which holds every point and is never the nearest.
#[derive(Clone, Copy, Debug)]
struct PlaneQuad {
    normal: [f64x4; 3],
    offset: f64x4,
}

impl PlaneQuad {
    fn of(planes: &[(Vector3<f64>, f64)]) -> Vec<Self> {
        type Plane = (Vector3<f64>, f64);
        planes
            .chunks(4)
            .map(|chunk| {
                let lanes = |entry: &dyn Fn(&Plane) -> f64, pad: f64| {
                    f64x4::from(std::array::from_fn(|i| chunk.get(i).map_or(pad, entry)))
                };
                Self {
                    normal: [0, 1, 2].map(|d| lanes(&|(n, _)| n[d], 0.0)),
                    offset: lanes(&|(_, o)| *o, f64::INFINITY),
                }
            })
            .collect()
    }

    /// `offset - normal . p` in each lane: how far inside each plane `p` is.
    fn room(&self, p: &[f64x4; 3]) -> f64x4 {
        let [x, y, z] = self.normal;
        self.offset - (x * p[0] + y * p[1] + z * p[2])
    }
}

/// `p` in every lane.
fn splat(p: &Vector3<f64>) -> [f64x4; 3] {
    [p.x, p.y, p.z].map(f64x4::splat)
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
        (planes.len() >= 4).then(|| Self {
            quads: PlaneQuad::of(&planes),
            planes,
            lo,
            hi,
        })
    }

    /// A hull that holds no point and whose bounds are empty: the place of an object that is
    /// far from everything, which keeps the other colliders' indices.
    pub fn nowhere() -> Self {
        Self {
            planes: Vec::new(),
            quads: Vec::new(),
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
        let (at, margin) = (splat(p), f64x4::splat(-margin));
        // Within margin of every plane: room > -margin (false for NaN, as before).
        !self.quads.is_empty() && self.quads.iter().all(|q| q.room(&at).simd_gt(margin).all())
    }

    /// How deep `p` is inside (m) and the outward normal of the nearest face; None outside.
    pub fn penetration(&self, p: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
        let at = splat(p);
        let mut best = f64x4::splat(f64::INFINITY);
        let mut best_quad = [0usize; 4];
        for (i, quad) in self.quads.iter().enumerate() {
            let room = quad.room(&at);
            if room.simd_le(f64x4::ZERO).any() {
                return None;
            }
            // Per lane, the first plane with the least room, as a loop over them keeps it.
            let nearer_lanes = room.simd_lt(best);
            let nearer = nearer_lanes.to_bitmask();
            if nearer != 0 {
                best = nearer_lanes.bitselect(room, best);
                for (lane, quad) in best_quad.iter_mut().enumerate() {
                    if nearer & (1 << lane) != 0 {
                        *quad = i;
                    }
                }
            }
        }
        let depths = best.to_array();
        // The least over the lanes; of equals, the first plane.
        let lane = (0..4).filter(|&l| depths[l].is_finite()).min_by(|&a, &b| {
            let plane = |l: usize| 4 * best_quad[l] + l;
            depths[a]
                .total_cmp(&depths[b])
                .then(plane(a).cmp(&plane(b)))
        })?;
        Some((depths[lane], self.planes[4 * best_quad[lane] + lane].0))
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

    /// The four-lane plane tests agree exactly with a loop over the planes, hull sizes that are
    /// not a multiple of four included: the same points within a margin, the same depths and
    /// the nearest face's normal (the first of equals).
    #[test]
    fn lane_tests_agree_with_a_loop_over_the_planes() {
        let mut seed = 7u64;
        let mut random = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for count in [8, 13, 40, 97] {
            let points: Vec<Vector3<f64>> = (0..count)
                .map(|_| Vector3::new(random(), random(), random()).normalize())
                .collect();
            let hull = ConvexHull::of(&points).unwrap();
            for _ in 0..2000 {
                let p = Vector3::new(random(), random(), random()) * 2.4;
                let within = hull.planes.iter().all(|(n, o)| n.dot(&p) - o < 0.1);
                assert_eq!(hull.is_within(&p, 0.1), within);
                let mut nearest: Option<(f64, Vector3<f64>)> = None;
                let mut outside = false;
                for (n, o) in &hull.planes {
                    let depth = o - n.dot(&p);
                    outside |= depth <= 0.0;
                    if nearest.is_none_or(|(d, _)| depth < d) {
                        nearest = Some((depth, *n));
                    }
                }
                let expected = if outside { None } else { nearest };
                assert_eq!(hull.penetration(&p), expected, "{count} points, at {p:?}");
            }
        }
    }
}
