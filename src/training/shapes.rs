//! The training data: solids generated in code from signed distance functions (negative
//! inside), in families that cover what robots meet: primitives, unions, limbs, animals, thin
//! plates, hollow shells, shapes with holes and random constructive solids.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

pub use super::families::ShapeFamily;
use super::families::{draw, random_rotation};
use super::sdf::Sdf;
use crate::geometry::{sample_surface, sdf_mesh, Normalization, Shape, SurfaceSampling, VoxelGrid};

/// A generated solid: its family, seed and signed distance function (world units, about 2 m
/// across, centered near the origin).
// The name, family and seed identify a shape in Debug output and the tests' messages.
#[allow(dead_code)]
#[derive(Clone, Debug)]
pub struct GeneratedShape {
    /// `<family>-<seed>`, the seed written with at least four digits.
    pub name: String,
    /// The family it was drawn from.
    pub family: ShapeFamily,
    /// The seed it was drawn with.
    pub seed: u64,
    sdf: Sdf,
}

/// What a training step or an evaluation needs of a shape, in its normalized frame.
#[allow(dead_code)]
#[derive(Clone, Debug)]
pub struct ShapeSample {
    /// The shape's name.
    pub name: String,
    /// Points on the surface.
    pub surface_points: Vec<Vector3<f32>>,
    /// Unit outward normals.
    pub surface_normals: Vec<Vector3<f32>>,
    /// Uniform in the solid.
    pub interior_points: Vec<Vector3<f32>>,
    /// Solid volume, normalized units.
    pub volume: f64,
    /// The map from world units to the normalized frame.
    pub normalization: Normalization,
}

/// Half-size of the cube every generated shape lies in, and the mesher's lattice across it:
/// cells of 2.6 / 104 = 0.025, so the thinnest walls (0.08) span three cells.
const HALF: f64 = 1.3;
const MESH_RESOLUTION: usize = 104;

impl GeneratedShape {
    /// A shape of `family`; draws again (deterministically) until the solid is one connected
    /// piece of reasonable volume.
    pub fn generate(family: ShapeFamily, seed: u64) -> GeneratedShape {
        for attempt in 0..64u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1_000_003) ^ (attempt << 48));
            let drawn = draw(family, &mut rng).moved(random_rotation(&mut rng), Vector3::zeros());
            let Some(sdf) = fitted(drawn) else { continue };
            if is_one_solid(&sdf) {
                return GeneratedShape {
                    name: format!("{}-{seed:04}", family.name()),
                    family,
                    seed,
                    sdf,
                };
            }
        }
        // Every family draws a connected solid far more often than not; a capsule is the fallback.
        GeneratedShape {
            name: format!("{}-{seed:04}", family.name()),
            family,
            seed,
            sdf: Sdf::Capsule {
                a: Vector3::new(-0.8, 0.0, 0.0),
                b: Vector3::new(0.8, 0.0, 0.0),
                radius: 0.3,
            },
        }
    }

    /// The signed distance function at `p`, world units (negative inside).
    #[cfg(test)]
    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        self.sdf.at(p)
    }

    /// The surface, triangulated on a `resolution`^3 lattice (world units).
    pub fn mesh(&self, resolution: usize) -> Shape {
        sdf_mesh(&|p| self.sdf.at(p), HALF, resolution)
    }

    /// `surface_count` surface points with normals and up to `interior_count` uniform
    /// interior points (rejection sampling, at most 200 draws per point asked), in the
    /// normalized frame; the volume is estimated from the same draws.
    pub fn sample(
        &self,
        surface_count: usize,
        interior_count: usize,
        rng: &mut impl Rng,
    ) -> ShapeSample {
        let mesh = self.mesh(MESH_RESOLUTION);
        let map = mesh.normalization();
        // The grid only orients normals of bare clouds; a mesh's winding already does.
        let grid = VoxelGrid::from_shape(&mesh, 8, None);
        let surface = sample_surface(
            &mesh,
            &grid,
            &SurfaceSampling {
                count: surface_count,
                ..Default::default()
            },
            rng,
        );
        let (lo, hi) = mesh.bounds();
        let mut interior = Vec::with_capacity(interior_count);
        let mut draws = 0usize;
        while interior.len() < interior_count && draws < 200 * interior_count.max(1) {
            let p = Vector3::from_fn(|i, _| rng.random_range(lo[i]..hi[i]));
            draws += 1;
            if self.sdf.at(&p) < 0.0 {
                interior.push(map.to_normalized(&p).cast::<f32>());
            }
        }
        let box_volume = (hi - lo).product();
        let volume = box_volume * interior.len() as f64 / draws.max(1) as f64 / map.scale.powi(3);
        ShapeSample {
            name: self.name.clone(),
            surface_points: surface
                .points
                .iter()
                .map(|p| map.to_normalized(p).cast::<f32>())
                .collect(),
            surface_normals: surface.normals.iter().map(|n| n.cast::<f32>()).collect(),
            interior_points: interior,
            volume,
            normalization: map,
        }
    }
}

/// How the dataset is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct DatasetSpec {
    /// Seed of the dataset: shape i is generated with seed `seed * 100000 + i`.
    pub seed: u64,
    /// Shapes in all, cycling through the families.
    pub count: usize,
    /// Of each family, every this many-th shape is held out.
    pub held_out_every: usize,
}

/// (training, held-out) shapes. Shape i has family i mod 8 and is held out when
/// (i / 8) mod held_out_every == held_out_every - 1, so both splits cover every family.
pub fn dataset(spec: &DatasetSpec) -> (Vec<GeneratedShape>, Vec<GeneratedShape>) {
    let families = ShapeFamily::ALL.len();
    let every = spec.held_out_every.max(2);
    let (mut train, mut held_out) = (Vec::new(), Vec::new());
    let shapes: Vec<GeneratedShape> = {
        use rayon::prelude::*;
        (0..spec.count)
            .into_par_iter()
            .map(|i| {
                GeneratedShape::generate(
                    ShapeFamily::ALL[i % families],
                    spec.seed * 100_000 + i as u64,
                )
            })
            .collect()
    };
    for (i, shape) in shapes.into_iter().enumerate() {
        if (i / families) % every == every - 1 {
            held_out.push(shape);
        } else {
            train.push(shape);
        }
    }
    (train, held_out)
}

/// The solid moved and scaled so its bounding box is centered with a longest side of 2.2 (the
/// mesher's cube is 2.6): drawn shapes vary in size, and only their proportions matter once
/// normalized. None when nothing is inside.
fn fitted(sdf: Sdf) -> Option<Sdf> {
    const N: usize = 48;
    const REACH: f64 = 3.5;
    let step = 2.0 * REACH / N as f64;
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for k in 0..=N {
        for j in 0..=N {
            for i in 0..=N {
                let p = Vector3::new(i as f64, j as f64, k as f64) * step - Vector3::repeat(REACH);
                if sdf.at(&p) < 0.0 {
                    lo = lo.inf(&p);
                    hi = hi.sup(&p);
                }
            }
        }
    }
    if lo.x > hi.x {
        return None;
    }
    // The lattice sees the solid up to a cell short on each side.
    let (lo, hi) = (
        lo - Vector3::repeat(step / 2.0),
        hi + Vector3::repeat(step / 2.0),
    );
    let scale = 2.2 / (hi - lo).max();
    Some(Sdf::Scaled {
        scale,
        center: (lo + hi) / 2.0,
        inner: Box::new(sdf),
    })
}

/// Whether the solid fills at least 0.3% of its cube, stays inside it, and is one 26-connected
/// piece on a 40^3 grid.
fn is_one_solid(sdf: &Sdf) -> bool {
    const N: usize = 40;
    let step = 2.0 * HALF / N as f64;
    let index = |i: usize, j: usize, k: usize| i + N * (j + N * k);
    let mut inside = vec![false; N * N * N];
    for k in 0..N {
        for j in 0..N {
            for i in 0..N {
                let p = Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * step
                    - Vector3::repeat(HALF);
                inside[index(i, j, k)] = sdf.at(&p) < 0.0;
            }
        }
    }
    let total = inside.iter().filter(|v| **v).count();
    // Touching the cube's border means the shape is cut off by the mesher.
    let touches_border = (0..N).any(|a| {
        (0..N).any(|b| {
            inside[index(0, a, b)]
                || inside[index(N - 1, a, b)]
                || inside[index(a, 0, b)]
                || inside[index(a, N - 1, b)]
                || inside[index(a, b, 0)]
                || inside[index(a, b, N - 1)]
        })
    });
    if total < N * N * N * 3 / 1000 || touches_border {
        return false;
    }
    let start = inside.iter().position(|v| *v).expect("counted");
    let mut seen = vec![false; inside.len()];
    let mut stack = vec![start];
    seen[start] = true;
    let mut reached = 0;
    while let Some(c) = stack.pop() {
        reached += 1;
        let (i, j, k) = (c % N, (c / N) % N, c / (N * N));
        for dk in -1i64..=1 {
            for dj in -1i64..=1 {
                for di in -1i64..=1 {
                    let (x, y, z) = (i as i64 + di, j as i64 + dj, k as i64 + dk);
                    if x < 0 || y < 0 || z < 0 || x >= N as i64 || y >= N as i64 || z >= N as i64 {
                        continue;
                    }
                    let n = index(x as usize, y as usize, z as usize);
                    if inside[n] && !seen[n] {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
    }
    reached == total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_family_gives_one_solid_with_outward_normals() {
        for family in ShapeFamily::ALL {
            for seed in 0..3 {
                let shape = GeneratedShape::generate(family, seed);
                assert!(is_one_solid(&shape.sdf), "{}", shape.name);
                assert!(
                    matches!(shape.sdf, Sdf::Scaled { .. }),
                    "{} fell back to the capsule",
                    shape.name
                );
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let sample = shape.sample(512, 256, &mut rng);
                assert_eq!(sample.interior_points.len(), 256, "{}", shape.name);
                assert!(
                    sample.volume > 0.05,
                    "{}: volume {}",
                    shape.name,
                    sample.volume
                );
                let outward = sample
                    .surface_points
                    .iter()
                    .zip(&sample.surface_normals)
                    .filter(|(p, n)| {
                        let world = sample.normalization.to_world(&p.cast::<f64>());
                        let n = n.cast::<f64>();
                        shape.sdf(&(world + n * 0.01)) > shape.sdf(&(world - n * 0.01))
                    })
                    .count();
                assert!(
                    outward * 100 >= 97 * sample.surface_points.len(),
                    "{}: {outward} outward",
                    shape.name
                );
                let extent = sample
                    .surface_points
                    .iter()
                    .fold(0.0f32, |m, p| m.max(p.abs().max()));
                assert!(
                    (extent - 1.0).abs() < 0.05,
                    "{}: extent {extent}",
                    shape.name
                );
            }
        }
    }

    #[test]
    fn the_dataset_is_deterministic_and_splits_every_family() {
        let spec = DatasetSpec {
            seed: 1,
            count: 32,
            held_out_every: 2,
        };
        let (train, held_out) = dataset(&spec);
        let (again, _) = dataset(&spec);
        assert_eq!(train.len() + held_out.len(), 32);
        for family in ShapeFamily::ALL {
            assert!(train.iter().any(|s| s.family == family));
            assert!(held_out.iter().any(|s| s.family == family));
        }
        assert!(train
            .iter()
            .all(|s| held_out.iter().all(|h| h.name != s.name)));
        let mut a = ChaCha8Rng::seed_from_u64(4);
        let mut b = ChaCha8Rng::seed_from_u64(4);
        assert_eq!(
            train[3].sample(64, 64, &mut a).interior_points,
            again[3].sample(64, 64, &mut b).interior_points
        );
    }
}
