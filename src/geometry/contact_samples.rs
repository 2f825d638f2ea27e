//! Surface samples for contact: a quadrature of the surface whose sums over a contact patch
//! put the patch's force where the surface's would be.
//!
//! Plain random samples (the network's input) put the centre of a ball's 3 cm contact patch
//! 1.5 mm off its true place: the floor then pushes the ball with a torque, friction turns the
//! torque into rolling, and a ball at rest rolls away. Mesh vertices with their share of the
//! surrounding area integrate every linear function exactly on each triangle, and on a ball
//! leave the patch centre within 0.01 mm.

use std::collections::HashMap;

use nalgebra::Vector3;
use rand::Rng;

use super::cubature::stratified_subset;
use super::point_index::PointIndex;
use super::sampling::estimated_area;
use super::shape::Shape;
use super::voxel::VoxelGrid;

/// Surface points that collide, with the area each stands for (they add up to the surface's).
/// No normals: a penetration's direction comes from the obstacle.
#[derive(Clone, Debug, Default)]
pub struct ContactSamples {
    /// The points, in the shape's frame.
    pub points: Vec<Vector3<f64>>,
    /// The surface area each point stands for, in the shape's units squared (m^2).
    pub areas: Vec<f64>,
}

/// About `count` points that collide: a mesh's vertices, its triangles divided where they are
/// coarser than `count` points need, each with a third of the area of the triangles around it;
/// where that gives over twice `count` points (a dense scan), or for a cloud, `count` points
/// spread evenly and each moved to the centroid of the surface nearest to it.
pub fn contact_samples(
    shape: &Shape,
    grid: &VoxelGrid,
    count: usize,
    rng: &mut impl Rng,
) -> ContactSamples {
    let fine = if shape.is_point_cloud() {
        cloud_shares(shape, grid, 4 * count, rng)
    } else {
        let lumped = lumped_vertices(shape, spacing(shape, count));
        if lumped.points.len() <= 2 * count {
            return lumped;
        }
        // Too dense to test every step: the vertices become the fine samples.
        lumped
    };
    centroidal(&fine, count, 0.5 * grid.cell)
}

/// Up to `count` of a cloud's points (all of them, if fewer), each with an equal share of the
/// surface area estimated from `grid`.
fn cloud_shares(
    shape: &Shape,
    grid: &VoxelGrid,
    count: usize,
    rng: &mut impl Rng,
) -> ContactSamples {
    let all = &shape.positions;
    let points: Vec<Vector3<f64>> = if all.len() <= count {
        all.clone()
    } else {
        rand::seq::index::sample(rng, all.len(), count)
            .into_iter()
            .map(|i| all[i])
            .collect()
    };
    let share = estimated_area(grid) / points.len().max(1) as f64;
    ContactSamples {
        areas: vec![share; points.len()],
        points,
    }
}

/// Edge length of a regular triangle lattice with `count` vertices over `shape`'s surface.
fn spacing(shape: &Shape, count: usize) -> f64 {
    let area: f64 = (0..shape.triangles.len())
        .map(|t| {
            let [a, b, c] = shape.triangle(t);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum();
    (2.0 * area / (3f64.sqrt() * count.max(1) as f64)).sqrt()
}

/// Every triangle divided into n x n similar ones (n from its longest edge and `spacing`, at
/// most 64), the corners shared between triangles merged, each carrying a third of the area of
/// the small triangles it belongs to.
fn lumped_vertices(shape: &Shape, spacing: f64) -> ContactSamples {
    let longest = |t: usize| {
        let [a, b, c] = shape.triangle(t);
        [(b - a).norm(), (c - b).norm(), (a - c).norm()]
            .into_iter()
            .fold(0.0, f64::max)
    };
    if (0..shape.triangles.len()).all(|t| longest(t) <= spacing) {
        return lumped_mesh_vertices(shape);
    }
    let quantum = spacing * 1e-6;
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut out = ContactSamples::default();
    let mut add = |p: Vector3<f64>, area: f64| {
        let key = (p / quantum).map(|x| x.round() as i64).into();
        let i = *index.entry(key).or_insert_with(|| {
            out.points.push(p);
            out.areas.push(0.0);
            out.points.len() - 1
        });
        out.areas[i] += area;
    };
    for t in 0..shape.triangles.len() {
        let [a, b, c] = shape.triangle(t);
        let n = ((longest(t) / spacing).ceil() as usize).clamp(1, 64);
        let (u, v) = ((b - a) / n as f64, (c - a) / n as f64);
        let share = 0.5 * (b - a).cross(&(c - a)).norm() / (n * n) as f64 / 3.0;
        let at = |i: usize, j: usize| a + u * i as f64 + v * j as f64;
        for i in 0..n {
            for j in 0..n - i {
                for p in [at(i, j), at(i + 1, j), at(i, j + 1)] {
                    add(p, share);
                }
                if i + j + 1 < n {
                    for p in [at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)] {
                        add(p, share);
                    }
                }
            }
        }
    }
    out
}

/// The mesh's own vertices (those on a triangle), each with a third of its triangles' area:
/// the same as [`lumped_vertices`] when no triangle needs dividing, by index instead of by
/// position, which matters on dense scans of a million triangles.
fn lumped_mesh_vertices(shape: &Shape) -> ContactSamples {
    let mut areas = vec![0.0; shape.positions.len()];
    for (t, triangle) in shape.triangles.iter().enumerate() {
        let [a, b, c] = shape.triangle(t);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for &v in triangle {
            areas[v as usize] += third;
        }
    }
    let (points, areas) = shape
        .positions
        .iter()
        .zip(areas)
        .filter(|(_, a)| *a > 0.0)
        .unzip();
    ContactSamples { points, areas }
}

/// `count` of `fine` (spread evenly along a space-filling curve quantized to `cell`), each
/// moved to the centroid of the fine samples nearest to it, with their summed area.
fn centroidal(fine: &ContactSamples, count: usize, cell: f64) -> ContactSamples {
    let (seeds, _) = stratified_subset(&fine.points, &fine.areas, cell, count);
    let seed_points: Vec<Vector3<f64>> = seeds.iter().map(|&i| fine.points[i]).collect();
    let index = PointIndex::for_surface(&seed_points);
    let mut out = ContactSamples {
        points: vec![Vector3::zeros(); seeds.len()],
        areas: vec![0.0; seeds.len()],
    };
    for (p, a) in fine.points.iter().zip(&fine.areas) {
        let area = a.max(f64::MIN_POSITIVE);
        let Some(&s) = index.nearest(p, 1, None).first() else {
            continue;
        };
        out.points[s] += p * area;
        out.areas[s] += area;
    }
    // A seed is its own nearest unless another seed stands at the same spot (a cloud's
    // duplicate points: the edges of a box sampled face by face): that one gathers nothing,
    // and dividing by its zero area would put a NaN among the contact points.
    let (points, areas) = (out.points.iter().zip(&out.areas))
        .filter(|(_, a)| **a > 0.0)
        .map(|(p, a)| (p / *a, *a))
        .unzip();
    ContactSamples { points, areas }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::geometry::{box_mesh, sample_surface, sdf_mesh, SurfaceSampling};

    /// Where the floor's force acts on a ball of radius 0.1 m pressed `depth` into it, tilted by
    /// `tilt` about y, relative to the point below its centre (m).
    fn patch_offset(points: &[Vector3<f64>], areas: &[f64], depth: f64, tilt: f64) -> f64 {
        let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), tilt);
        let (mut force, mut moment) = (0.0, Vector3::zeros());
        for (p, a) in points.iter().zip(areas) {
            let x = turn * p;
            let d = (depth - 0.1 - x.z).max(0.0);
            force += a * d;
            moment += x * (a * d);
        }
        (moment / force).xy().norm()
    }

    #[test]
    fn a_balls_contact_patch_pushes_below_its_centre() {
        let ball = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 40);
        let grid = VoxelGrid::from_shape(&ball, 64, None);
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let contact = contact_samples(&ball, &grid, 4096, &mut rng);
        let random = sample_surface(&ball, &grid, &SurfaceSampling::default(), &mut rng);
        let total = |areas: &[f64]| areas.iter().sum::<f64>();
        assert!((total(&contact.areas) - total(&random.areas)).abs() < 1e-9 * total(&random.areas));
        for tilt in [0.0, 0.01, 0.03] {
            let offset = patch_offset(&contact.points, &contact.areas, 0.004, tilt);
            assert!(
                offset < 2e-4,
                "tilted {tilt}: patch centre {offset:e} m off"
            );
        }
        // What the samples are for: plain random ones are off by a millimetre or more.
        assert!(patch_offset(&random.points, &random.areas, 0.004, 0.0) > 1e-3);
    }

    #[test]
    fn coarse_triangles_are_divided_and_dense_meshes_thinned() {
        // A 0.2 m cube of 12 triangles: 8 corners alone would be all its contact.
        let cube = box_mesh(Vector3::repeat(0.2));
        let grid = VoxelGrid::from_shape(&cube, 32, None);
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let samples = contact_samples(&cube, &grid, 1000, &mut rng);
        assert!(
            (500..=2000).contains(&samples.points.len()),
            "{}",
            samples.points.len()
        );
        let area: f64 = samples.areas.iter().sum();
        assert!((area - 0.24).abs() < 1e-9, "area {area}");
        let bottom = samples.points.iter().filter(|p| p.z < -0.0999).count();
        assert!(bottom > 100, "{bottom} samples on the bottom face");
        let dense = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 40);
        let samples = contact_samples(&dense, &grid, 500, &mut rng);
        assert_eq!(samples.points.len(), 500);
    }

    #[test]
    fn a_cloud_with_duplicate_points_gives_finite_samples() {
        // Every point twice, as a box's edges are when its faces are sampled one by one.
        let cube = box_mesh(Vector3::repeat(0.2));
        let grid = VoxelGrid::from_shape(&cube, 32, None);
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let once = sample_surface(&cube, &grid, &SurfaceSampling::default(), &mut rng).points;
        let twice: Vec<_> = once.iter().flat_map(|p| [*p, *p]).collect();
        let cloud = Shape::new(twice, None, Vec::new()).unwrap();
        let samples = contact_samples(&cloud, &grid, 500, &mut rng);
        assert!(samples.points.len() > 100, "{}", samples.points.len());
        assert!(samples
            .points
            .iter()
            .all(|p| p.iter().all(|x| x.is_finite())));
        assert!(samples.areas.iter().all(|a| *a > 0.0));
    }
}
