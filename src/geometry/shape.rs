//! A shape as the pipeline sees it: positions (world units), optional triangles, and the map to [-1, 1]^3.

use nalgebra::Vector3;

use super::mesh_io::RawGeometry;
use crate::error::{Error, Result};

/// Uniform map between world units and the normalized cube [-1, 1]^3:
/// `normalized = (world - center) / scale`, where `scale` is half the longest bounding-box side.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Normalization {
    /// The bounding box's centre, world units.
    pub center: Vector3<f64>,
    /// Half the bounding box's longest side, world units.
    pub scale: f64,
}

impl Normalization {
    /// A world point in the normalized cube.
    pub fn to_normalized(&self, world: &Vector3<f64>) -> Vector3<f64> {
        (world - self.center) / self.scale
    }
    /// A normalized point in world units.
    pub fn to_world(&self, normalized: &Vector3<f64>) -> Vector3<f64> {
        normalized * self.scale + self.center
    }
    /// The map that changes nothing (centre 0, scale 1).
    pub fn identity() -> Self {
        Self {
            center: Vector3::zeros(),
            scale: 1.0,
        }
    }
}

/// Content hash of geometry: positions (bit patterns) and triangles. The same points and
/// triangles always hash alike; anything else almost never does.
pub fn content_hash(positions: &[Vector3<f64>], triangles: &[[u32; 3]]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for p in positions {
        p.iter().for_each(|c| c.to_bits().hash(&mut h));
    }
    triangles.hash(&mut h);
    h.finish()
}

/// A triangle mesh, or a bare point cloud when `triangles` is empty. Positions are in world units.
#[derive(Clone, Debug, Default)]
pub struct Shape {
    /// Vertex or point positions, world units (m).
    pub positions: Vec<Vector3<f64>>,
    /// One normal per position when the input had them, as given.
    pub normals: Option<Vec<Vector3<f64>>>,
    /// Triangles as indices into `positions`; empty for a point cloud.
    pub triangles: Vec<[u32; 3]>,
}

/// Objects from 1 mm to 1 km across: outside, the input is almost surely in another unit.
const SIZE_RANGE_M: (f64, f64) = (1e-3, 1e3);
/// Below this fraction of its length, a side counts as zero: the points lie on a line or plane.
const FLAT: f64 = 1e-3;

/// The extents of `points` along their principal axes, largest first.
pub(crate) fn principal_extents(points: &[Vector3<f64>]) -> [f64; 3] {
    let n = points.len() as f64;
    let mean = points.iter().sum::<Vector3<f64>>() / n;
    let covariance = points
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum::<nalgebra::Matrix3<f64>>()
        / n;
    let axes = nalgebra::SymmetricEigen::new(covariance).eigenvectors;
    let mut extents = [0, 1, 2].map(|a| {
        let along = points.iter().map(|p| p.dot(&axes.column(a)));
        let (lo, hi) = along.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        hi - lo
    });
    extents.sort_by(|a, b| b.total_cmp(a));
    extents
}

impl Shape {
    /// Validates and converts loaded geometry: finite coordinates, indices in range, a non-degenerate extent.
    pub fn from_raw(raw: RawGeometry) -> Result<Self> {
        let positions: Vec<Vector3<f64>> =
            raw.positions.iter().map(|p| Vector3::from(*p)).collect();
        let normals = raw
            .normals
            .map(|n| n.iter().map(|v| Vector3::from(*v)).collect());
        Self::new(positions, normals, raw.triangles)
    }

    /// Checks and builds a shape. An [`Error::Geometry`] when there are no positions, a
    /// coordinate is not finite, the normals do not match the positions in number, a triangle
    /// indexes past the positions, or all positions coincide.
    pub fn new(
        positions: Vec<Vector3<f64>>,
        normals: Option<Vec<Vector3<f64>>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self> {
        if positions.is_empty() {
            return Err(Error::Geometry("the shape has no points".into()));
        }
        if let Some(i) = positions
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(Error::Geometry(format!(
                "point {i} has a non-finite coordinate"
            )));
        }
        if let Some(n) = &normals {
            if n.len() != positions.len() {
                return Err(Error::Geometry(format!(
                    "{} normals for {} points",
                    n.len(),
                    positions.len()
                )));
            }
        }
        let count = positions.len() as u32;
        if let Some((t, tri)) = triangles
            .iter()
            .enumerate()
            .find(|(_, tri)| tri.iter().any(|&v| v >= count))
        {
            return Err(Error::Geometry(format!(
                "triangle {t} {tri:?} indexes past the {count} vertices"
            )));
        }
        let shape = Self {
            positions,
            normals,
            triangles,
        };
        let (lo, hi) = shape.bounds();
        let extent = (hi - lo).max();
        if extent <= 0.0 {
            return Err(Error::Geometry(
                "the shape has zero extent (all points coincide)".into(),
            ));
        }
        Ok(shape)
    }

    /// Refuses geometry that is not a solid of a size in metres, naming why: voxelizing a line,
    /// a plane or a micrometre object would build a body from voxels the input never had.
    pub fn check_solid(&self) -> Result<()> {
        self.check_faces()?;
        let [length, width, thickness] = principal_extents(&self.positions);
        let refuse = |why: String| Err(Error::Geometry(why));
        if length < SIZE_RANGE_M.0 {
            return refuse(format!(
                "the object is {length:.3e} m across, smaller than 1 mm: positions are read in metres (is the input in another unit?)"
            ));
        }
        if length > SIZE_RANGE_M.1 {
            return refuse(format!(
                "the object is {length:.3e} m across, larger than 1 km: positions are read in metres (is the input in another unit?)"
            ));
        }
        if width < FLAT * length {
            return refuse(format!(
                "the points lie on one line ({width:.3e} m wide over {length:.3e} m): a solid needs width and depth"
            ));
        }
        if thickness < FLAT * length {
            return refuse(format!(
                "the points lie on one plane ({thickness:.3e} m thick over {length:.3e} m): a solid needs depth"
            ));
        }
        Ok(())
    }

    /// Refuses a mesh whose faces have no area in all (every triangle degenerate): it has no
    /// surface to fill, whatever its points span.
    fn check_faces(&self) -> Result<()> {
        if self.triangles.is_empty() {
            return Ok(());
        }
        let area: f64 = (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.triangle(t);
                0.5 * (b - a).cross(&(c - a)).norm()
            })
            .sum();
        let (lo, hi) = self.bounds();
        let extent = (hi - lo).max();
        if area <= 1e-9 * extent * extent {
            return Err(Error::Geometry(format!(
                "the mesh's {} faces have no area ({area:.3e} m^2 in all): each has coinciding or collinear corners",
                self.triangles.len()
            )));
        }
        Ok(())
    }

    /// Whether the shape has no triangles.
    pub fn is_point_cloud(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The axis-aligned bounding box: (lowest, highest) corner.
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }

    /// The length of the bounding box's diagonal, world units (m).
    pub fn bounding_diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).norm()
    }

    /// The map that centers the bounding box and scales its longest half-side to 1.
    pub fn normalization(&self) -> Normalization {
        let (lo, hi) = self.bounds();
        Normalization {
            center: (lo + hi) * 0.5,
            scale: (hi - lo).max() * 0.5,
        }
    }

    /// A copy in normalized coordinates (normals are unchanged by a uniform scale).
    pub fn normalized(&self, map: &Normalization) -> Shape {
        Shape {
            positions: self
                .positions
                .iter()
                .map(|p| map.to_normalized(p))
                .collect(),
            normals: self.normals.clone(),
            triangles: self.triangles.clone(),
        }
    }

    /// The corners of triangle `t`. Panics when `t` is out of range.
    pub fn triangle(&self, t: usize) -> [Vector3<f64>; 3] {
        self.triangles[t].map(|v| self.positions[v as usize])
    }

    /// Enclosed volume by the divergence theorem, when the triangles form a closed, consistently
    /// wound surface: every directed edge is matched by as many reversed ones (non-manifold
    /// edges shared by four faces included); `None` otherwise.
    pub fn closed_volume(&self) -> Option<f64> {
        if self.triangles.is_empty() {
            return None;
        }
        let mut balance: std::collections::HashMap<(u32, u32), i64> =
            std::collections::HashMap::with_capacity(self.triangles.len() * 3);
        for tri in &self.triangles {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a == b {
                    return None;
                }
                let (key, sign) = if a < b { ((a, b), 1) } else { ((b, a), -1) };
                *balance.entry(key).or_insert(0) += sign;
            }
        }
        if balance.values().any(|&b| b != 0) {
            return None;
        }
        let volume: f64 = (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.triangle(t);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum();
        Some(volume.abs())
    }
}
