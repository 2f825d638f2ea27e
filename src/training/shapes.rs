//! TEMPORARY stub until the generated-shapes module lands.
use nalgebra::Vector3;
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::geometry::{sample_surface, sdf_mesh, Normalization, Shape, SurfaceSampling, VoxelGrid};

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum ShapeFamily {
    Primitive,
}
pub struct GeneratedShape {
    pub name: String,
    pub family: ShapeFamily,
    pub seed: u64,
    radii: Vector3<f64>,
}
pub struct ShapeSample {
    pub name: String,
    pub surface_points: Vec<Vector3<f32>>,
    pub surface_normals: Vec<Vector3<f32>>,
    pub interior_points: Vec<Vector3<f32>>,
    pub volume: f64,
    pub normalization: Normalization,
    pub mesh: Shape,
}
pub struct DatasetSpec {
    pub seed: u64,
    pub count: usize,
    pub held_out_every: usize,
}
pub fn dataset(spec: &DatasetSpec) -> (Vec<GeneratedShape>, Vec<GeneratedShape>) {
    let mut train = Vec::new();
    let mut held = Vec::new();
    for i in 0..spec.count {
        let s = GeneratedShape::generate(ShapeFamily::Primitive, spec.seed * 1000 + i as u64);
        if i % spec.held_out_every == spec.held_out_every - 1 {
            held.push(s)
        } else {
            train.push(s)
        }
    }
    (train, held)
}
impl GeneratedShape {
    pub fn generate(family: ShapeFamily, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let radii = Vector3::new(
            rng.random_range(0.2..1.0),
            rng.random_range(0.2..1.0),
            rng.random_range(0.2..1.0),
        );
        Self {
            name: format!("ellipsoid-{seed}"),
            family,
            seed,
            radii,
        }
    }
    pub fn mesh(&self, _resolution: usize) -> Shape {
        sdf_mesh(&|p| self.sdf(p), 1.1, 40)
    }
    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        let q = p.component_div(&self.radii);
        (q.norm() - 1.0) * self.radii.min()
    }
    pub fn sample(
        &self,
        surface_count: usize,
        interior_count: usize,
        rng: &mut impl Rng,
    ) -> ShapeSample {
        let sdf = |p: &Vector3<f64>| self.sdf(p);
        let mesh = sdf_mesh(&sdf, 1.1, 40);
        let map = mesh.normalization();
        let grid = VoxelGrid::from_shape(&mesh, 16, None);
        let s = sample_surface(
            &mesh,
            &grid,
            &SurfaceSampling {
                count: surface_count,
                ..Default::default()
            },
            rng,
        );
        let mut interior = Vec::new();
        let mut tries = 0usize;
        while interior.len() < interior_count {
            let p = Vector3::new(
                rng.random_range(-1.1..1.1),
                rng.random_range(-1.1..1.1),
                rng.random_range(-1.1..1.1),
            );
            tries += 1;
            if sdf(&p) < 0.0 {
                interior.push(map.to_normalized(&p).cast::<f32>());
            }
        }
        let volume = 2.2f64.powi(3) * interior_count as f64 / tries as f64 / map.scale.powi(3);
        ShapeSample {
            name: self.name.clone(),
            surface_points: s
                .points
                .iter()
                .map(|p| map.to_normalized(p).cast::<f32>())
                .collect(),
            surface_normals: s.normals.iter().map(|n| n.cast::<f32>()).collect(),
            interior_points: interior,
            volume,
            normalization: map,
            mesh,
        }
    }
}
