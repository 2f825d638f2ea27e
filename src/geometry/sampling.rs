//! Surface samples with normals: area-weighted on triangles, concentrated on sharp edges, or
//! drawn from a bare cloud with normals estimated from its neighbours.

use nalgebra::Vector3;
use rand::Rng;

use super::point_index::{neighbourhood_plane, NeighbourhoodPlane, PointIndex};
use super::shape::Shape;
use super::voxel::VoxelGrid;

/// Points on the surface with unit outward normals.
#[derive(Clone, Debug, Default)]
pub struct SurfaceSamples {
    /// The samples, in the shape's frame.
    pub points: Vec<Vector3<f64>>,
    /// Each sample's unit outward normal.
    pub normals: Vec<Vector3<f64>>,
    /// Surface area each sample stands for (they add up to the surface area; for clouds, an estimate).
    pub areas: Vec<f64>,
}

/// How to draw surface samples.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSampling {
    /// Number of samples. Default 4096 (the network's input size).
    pub count: usize,
    /// Share of the samples placed on sharp or open edges. Default 0.1.
    pub edge_fraction: f64,
    /// Dihedral angle (degrees) beyond which an edge counts as sharp. Default 30.
    pub sharp_angle_deg: f64,
}

impl Default for SurfaceSampling {
    fn default() -> Self {
        Self {
            count: 4096,
            edge_fraction: 0.1,
            sharp_angle_deg: 30.0,
        }
    }
}

/// Samples the surface of `shape`; `grid` (the inside test) orients estimated cloud normals outward.
pub fn sample_surface(
    shape: &Shape,
    grid: &VoxelGrid,
    options: &SurfaceSampling,
    rng: &mut impl Rng,
) -> SurfaceSamples {
    if shape.is_point_cloud() {
        sample_cloud(shape, grid, options.count, rng)
    } else {
        sample_mesh(shape, options, rng)
    }
}

fn sample_mesh(shape: &Shape, options: &SurfaceSampling, rng: &mut impl Rng) -> SurfaceSamples {
    let face_normals: Vec<Vector3<f64>> = (0..shape.triangles.len())
        .map(|t| {
            let [a, b, c] = shape.triangle(t);
            (b - a).cross(&(c - a))
        })
        .collect();
    let areas: Vec<f64> = face_normals.iter().map(|n| 0.5 * n.norm()).collect();
    let total_area: f64 = areas.iter().sum();
    let edges = sharp_edges(shape, &face_normals, options.sharp_angle_deg);
    let edge_count = if edges.is_empty() {
        0
    } else {
        (options.count as f64 * options.edge_fraction).round() as usize
    };
    let face_count = options.count - edge_count;
    let mut out = SurfaceSamples::default();
    let by_area = cumulative(&areas);
    for _ in 0..face_count {
        let t = pick(&by_area, rng);
        let [a, b, c] = shape.triangle(t);
        let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        out.points.push(a + (b - a) * u + (c - a) * v);
        out.normals.push(
            face_normals[t]
                .try_normalize(1e-300)
                .unwrap_or(Vector3::z()),
        );
        out.areas.push(total_area / face_count as f64);
    }
    // Edge samples carry the normal of one adjacent face and no area of their own: they add
    // detail where the geometry turns sharply, not extra surface.
    let lengths: Vec<f64> = edges.iter().map(|e| (e.1 - e.0).norm()).collect();
    let by_length = cumulative(&lengths);
    for _ in 0..edge_count {
        let (a, b, n) = edges[pick(&by_length, rng)];
        out.points.push(a + (b - a) * rng.random::<f64>());
        out.normals.push(n);
        out.areas.push(0.0);
    }
    out
}

/// Edges whose faces meet at more than `angle_deg`, and open (boundary) edges, with one face normal.
fn sharp_edges(
    shape: &Shape,
    face_normals: &[Vector3<f64>],
    angle_deg: f64,
) -> Vec<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> {
    let mut faces_of_edge: std::collections::HashMap<(u32, u32), Vec<usize>> =
        std::collections::HashMap::new();
    for (t, tri) in shape.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            faces_of_edge
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(t);
        }
    }
    let cos_limit = angle_deg.to_radians().cos();
    let mut edges: Vec<_> = faces_of_edge
        .into_iter()
        .filter_map(|((a, b), faces)| {
            let n0 = face_normals[faces[0]].try_normalize(1e-300)?;
            let sharp = faces.len() != 2 || {
                let n1 = face_normals[faces[1]].try_normalize(1e-300)?;
                n0.dot(&n1) < cos_limit
            };
            sharp.then(|| (shape.positions[a as usize], shape.positions[b as usize], n0))
        })
        .collect();
    // HashMap order is random; sort so a seeded run is reproducible.
    edges.sort_by(|x, y| {
        let key = |e: &(Vector3<f64>, Vector3<f64>, Vector3<f64>)| {
            [e.0.x, e.0.y, e.0.z, e.1.x, e.1.y, e.1.z]
        };
        key(x)
            .partial_cmp(&key(y))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    edges
}

fn sample_cloud(
    shape: &Shape,
    grid: &VoxelGrid,
    count: usize,
    rng: &mut impl Rng,
) -> SurfaceSamples {
    let points = &shape.positions;
    let chosen: Vec<usize> = if points.len() <= count {
        (0..points.len()).collect()
    } else {
        rand::seq::index::sample(rng, points.len(), count).into_vec()
    };
    let index = PointIndex::for_surface(points);
    let area = estimated_area(grid);
    let mut out = SurfaceSamples::default();
    for &i in &chosen {
        let p = points[i];
        let normal = match &shape.normals {
            Some(n) => n[i].try_normalize(1e-300).unwrap_or(Vector3::z()),
            None => estimate_normal(points, &index, i, grid),
        };
        out.points.push(p);
        out.normals.push(normal);
        out.areas.push(area / chosen.len() as f64);
    }
    out
}

/// Surface area of the solid as the count of exposed cell faces, scaled by 2/3 (the mean ratio
/// of a staircase to the smooth surface it approximates, over all orientations).
pub(super) fn estimated_area(grid: &VoxelGrid) -> f64 {
    let [nx, ny, nz] = grid.dims;
    let solid = &grid.solid;
    // A face is open where the cell beyond it is off the grid or not solid.
    let open = |inside: bool, n: usize| usize::from(!inside || !solid[n]);
    let mut faces = 0usize;
    let mut index = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if solid[index] {
                    faces += open(i > 0, index.wrapping_sub(1))
                        + open(i + 1 < nx, index + 1)
                        + open(j > 0, index.wrapping_sub(nx))
                        + open(j + 1 < ny, index + nx)
                        + open(k > 0, index.wrapping_sub(nx * ny))
                        + open(k + 1 < nz, index + nx * ny);
                }
                index += 1;
            }
        }
    }
    faces as f64 * grid.cell * grid.cell * 2.0 / 3.0
}

/// PCA normal of the 16 nearest neighbours, turned to point out of the solid.
fn estimate_normal(
    points: &[Vector3<f64>],
    index: &PointIndex,
    i: usize,
    grid: &VoxelGrid,
) -> Vector3<f64> {
    let neighbours = index.nearest(&points[i], 16, None);
    let Some(NeighbourhoodPlane { normal, .. }) = neighbourhood_plane(points, &neighbours) else {
        return Vector3::z();
    };
    // Probed 1, 2 and 3 cells out: a noisy cloud's surface cells are ragged.
    grid.outward(&points[i], &normal, &[1.0, 2.0, 3.0])
        .unwrap_or(normal)
}

fn cumulative(weights: &[f64]) -> Vec<f64> {
    let mut acc = 0.0;
    weights
        .iter()
        .map(|w| {
            acc += w;
            acc
        })
        .collect()
}

fn pick(cumulative: &[f64], rng: &mut impl Rng) -> usize {
    let total = *cumulative.last().unwrap_or(&0.0);
    let x = rng.random::<f64>() * total;
    cumulative
        .partition_point(|&c| c <= x)
        .min(cumulative.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 x 4 x 5 block of cells, touching the grid's low x side, counts 2 (12 + 20 + 15) faces.
    #[test]
    fn a_block_of_cells_shows_its_six_sides() {
        let dims = [5, 6, 7];
        let mut solid = vec![false; dims.iter().product()];
        for (k, j, i) in
            (1..6).flat_map(|k| (1..5).flat_map(move |j| (0..3).map(move |i| (k, j, i))))
        {
            solid[i + dims[0] * (j + dims[1] * k)] = true;
        }
        let grid = VoxelGrid {
            origin: Vector3::zeros(),
            cell: 0.5,
            dims,
            surface: vec![false; solid.len()],
            solid,
        };
        let faces = 2.0 * (12.0 + 20.0 + 15.0);
        assert!((estimated_area(&grid) - faces * 0.25 * 2.0 / 3.0).abs() < 1e-12);
    }
}
