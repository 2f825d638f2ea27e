//! The training data: solids generated in code from signed distance functions (negative
//! inside), in families that cover what robots meet: primitives, unions, limbs, animals, thin
//! plates, hollow shells, shapes with holes and random constructive solids.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::geometry::{sample_surface, sdf_mesh, Normalization, Shape, SurfaceSampling, VoxelGrid};

/// The families, in the order the dataset cycles through them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeFamily {
    Primitive,
    Union,
    Limbs,
    Animal,
    Plate,
    Shell,
    Holed,
    Csg,
}

impl ShapeFamily {
    pub const ALL: [ShapeFamily; 8] = [
        ShapeFamily::Primitive,
        ShapeFamily::Union,
        ShapeFamily::Limbs,
        ShapeFamily::Animal,
        ShapeFamily::Plate,
        ShapeFamily::Shell,
        ShapeFamily::Holed,
        ShapeFamily::Csg,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ShapeFamily::Primitive => "primitive",
            ShapeFamily::Union => "union",
            ShapeFamily::Limbs => "limbs",
            ShapeFamily::Animal => "animal",
            ShapeFamily::Plate => "plate",
            ShapeFamily::Shell => "shell",
            ShapeFamily::Holed => "holed",
            ShapeFamily::Csg => "csg",
        }
    }
}

/// A signed distance tree. Distances are exact for the primitives and bounds for the
/// combinations, which is all the mesher and the inside test need.
#[derive(Clone, Debug)]
enum Sdf {
    Ellipsoid {
        radii: Vector3<f64>,
    },
    Box {
        half: Vector3<f64>,
        round: f64,
    },
    Capsule {
        a: Vector3<f64>,
        b: Vector3<f64>,
        radius: f64,
    },
    /// Along z, capped.
    Cylinder {
        radius: f64,
        half_height: f64,
    },
    /// Around z.
    Torus {
        major: f64,
        minor: f64,
    },
    /// A frustum along z, radii at -h and +h.
    Cone {
        bottom: f64,
        top: f64,
        half_height: f64,
    },
    Moved {
        rotation: Matrix3<f64>,
        offset: Vector3<f64>,
        inner: Box<Sdf>,
    },
    Union {
        parts: Vec<Sdf>,
        smooth: f64,
    },
    Intersection(Box<Sdf>, Box<Sdf>),
    Difference(Box<Sdf>, Box<Sdf>),
    /// The inner solid moved so `center` is at the origin, then scaled by `scale`.
    Scaled {
        scale: f64,
        center: Vector3<f64>,
        inner: Box<Sdf>,
    },
    /// The wall of thickness `thickness` around the inner solid's surface, half of it inside.
    Shell {
        inner: Box<Sdf>,
        thickness: f64,
    },
}

impl Sdf {
    fn at(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Sdf::Ellipsoid { radii } => {
                let k0 = p.component_div(radii).norm();
                let k1 = p.component_div(&radii.component_mul(radii)).norm();
                if k1 > 0.0 {
                    k0 * (k0 - 1.0) / k1
                } else {
                    -radii.min()
                }
            }
            Sdf::Box { half, round } => {
                let q = p.abs() - (half - Vector3::repeat(*round));
                q.sup(&Vector3::zeros()).norm() + q.max().min(0.0) - round
            }
            Sdf::Capsule { a, b, radius } => {
                let ab = b - a;
                let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                (p - (a + ab * t)).norm() - radius
            }
            Sdf::Cylinder {
                radius,
                half_height,
            } => {
                let d = [p.xy().norm() - radius, p.z.abs() - half_height];
                d[0].max(d[1]).min(0.0) + (d[0].max(0.0).powi(2) + d[1].max(0.0).powi(2)).sqrt()
            }
            Sdf::Torus { major, minor } => {
                let q = nalgebra::Vector2::new(p.xy().norm() - major, p.z);
                q.norm() - minor
            }
            Sdf::Cone {
                bottom,
                top,
                half_height,
            } => {
                let t = ((p.z + half_height) / (2.0 * half_height)).clamp(0.0, 1.0);
                let radius = bottom + (top - bottom) * t;
                let slope = ((top - bottom) / (2.0 * half_height)).atan().cos();
                ((p.xy().norm() - radius) * slope).max(p.z.abs() - half_height)
            }
            Sdf::Moved {
                rotation,
                offset,
                inner,
            } => inner.at(&(rotation.transpose() * (p - offset))),
            Sdf::Union { parts, smooth } => parts
                .iter()
                .map(|s| s.at(p))
                .reduce(|a, b| smooth_min(a, b, *smooth))
                .unwrap_or(f64::INFINITY),
            Sdf::Intersection(a, b) => a.at(p).max(b.at(p)),
            Sdf::Difference(a, b) => a.at(p).max(-b.at(p)),
            Sdf::Shell { inner, thickness } => inner.at(p).abs() - thickness / 2.0,
            Sdf::Scaled {
                scale,
                center,
                inner,
            } => inner.at(&(p / *scale + center)) * scale,
        }
    }

    fn moved(self, rotation: Matrix3<f64>, offset: Vector3<f64>) -> Sdf {
        Sdf::Moved {
            rotation,
            offset,
            inner: Box::new(self),
        }
    }
}

fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b * (1.0 - h) + a * h - k * h * (1.0 - h)
}

/// A generated solid: its family, seed and signed distance function (world units, about 2 m
/// across, centered near the origin).
#[derive(Clone, Debug)]
pub struct GeneratedShape {
    pub name: String,
    pub family: ShapeFamily,
    pub seed: u64,
    sdf: Sdf,
}

/// What a training step or an evaluation needs of a shape, in its normalized frame.
#[derive(Clone, Debug)]
pub struct ShapeSample {
    pub name: String,
    pub surface_points: Vec<Vector3<f32>>,
    /// Unit outward normals.
    pub surface_normals: Vec<Vector3<f32>>,
    /// Uniform in the solid.
    pub interior_points: Vec<Vector3<f32>>,
    /// Solid volume, normalized units.
    pub volume: f64,
    pub normalization: Normalization,
}

/// Half-size of the cube every generated shape lies in, and the mesher's lattice across it:
/// cells of 2.6 / 104 = 0.025, so the thinnest walls (0.08) span three cells.
const HALF: f64 = 1.3;
const MESH_RESOLUTION: usize = 104;
const THINNEST: f64 = 0.08;

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

    pub fn sdf(&self, p: &Vector3<f64>) -> f64 {
        self.sdf.at(p)
    }

    /// The surface, triangulated on a `resolution`^3 lattice (world units).
    pub fn mesh(&self, resolution: usize) -> Shape {
        sdf_mesh(&|p| self.sdf.at(p), HALF, resolution)
    }

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

fn random_rotation(rng: &mut impl Rng) -> Matrix3<f64> {
    let axis = random_direction(rng);
    *Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(axis),
        rng.random_range(0.0..std::f64::consts::TAU),
    )
    .matrix()
}

fn random_direction(rng: &mut impl Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// One primitive about `size` across with aspect ratios up to 8:1.
fn primitive(rng: &mut impl Rng, size: f64) -> Sdf {
    let r = size / 2.0;
    let aspect = |rng: &mut ChaCha8Rng| rng.random_range(0.25..1.0);
    let mut local = ChaCha8Rng::seed_from_u64(rng.random());
    let thick = |x: f64| x.max(THINNEST);
    match rng.random_range(0..6) {
        0 => Sdf::Ellipsoid {
            radii: Vector3::new(
                r,
                thick(r * aspect(&mut local)),
                thick(r * aspect(&mut local) * 0.8),
            ),
        },
        1 => {
            let half = Vector3::new(
                r,
                thick(r * aspect(&mut local)),
                thick(r * aspect(&mut local)),
            );
            Sdf::Box {
                round: rng.random_range(0.0..0.5) * half.min(),
                half,
            }
        }
        2 => {
            let radius = thick(r * rng.random_range(0.12..0.5));
            Sdf::Capsule {
                a: Vector3::new(-(r - radius).max(0.0), 0.0, 0.0),
                b: Vector3::new((r - radius).max(0.0), 0.0, 0.0),
                radius,
            }
        }
        3 => Sdf::Cylinder {
            radius: thick(r * rng.random_range(0.15..1.0)),
            half_height: thick(r * rng.random_range(0.2..1.0)),
        },
        4 => {
            let minor = thick(r * rng.random_range(0.12..0.35));
            Sdf::Torus {
                major: (r - minor).max(minor * 1.3),
                minor,
            }
        }
        _ => Sdf::Cone {
            bottom: thick(r * rng.random_range(0.3..0.9)),
            top: thick(r * rng.random_range(0.05..0.6)),
            half_height: r * rng.random_range(0.4..1.0),
        },
    }
}

fn draw(family: ShapeFamily, rng: &mut ChaCha8Rng) -> Sdf {
    match family {
        ShapeFamily::Primitive => primitive(rng, 2.0),
        ShapeFamily::Union => {
            let count = rng.random_range(2..=4);
            let mut parts = Vec::new();
            let mut centers = vec![Vector3::zeros()];
            for _ in 0..count {
                let anchor = centers[rng.random_range(0..centers.len())];
                let center = anchor + random_direction(rng) * rng.random_range(0.0..0.35);
                let size = rng.random_range(0.7..1.3);
                let rotation = random_rotation(rng);
                parts.push(primitive(rng, size).moved(rotation, center));
                centers.push(center);
            }
            Sdf::Union {
                parts,
                smooth: rng.random_range(0.0..0.1),
            }
        }
        ShapeFamily::Limbs => {
            let count = rng.random_range(3..=7);
            let mut joints = vec![Vector3::zeros()];
            let mut parts = Vec::new();
            for _ in 0..count {
                let start = joints[rng.random_range(0..joints.len())];
                let end = start + random_direction(rng) * rng.random_range(0.35..0.8);
                parts.push(Sdf::Capsule {
                    a: start,
                    b: end,
                    radius: rng.random_range(0.06..0.14),
                });
                joints.push(end);
            }
            Sdf::Union {
                parts,
                smooth: rng.random_range(0.02..0.08),
            }
        }
        ShapeFamily::Animal => animal(rng),
        ShapeFamily::Plate => {
            let length = 2.0;
            let width = length * rng.random_range(0.2..1.0);
            let thickness = (length * rng.random_range(0.03f64..0.08)).max(THINNEST);
            let plate = Sdf::Box {
                half: Vector3::new(length / 2.0, width / 2.0, thickness / 2.0),
                round: rng.random_range(0.0..0.5) * thickness / 2.0,
            };
            if rng.random_bool(0.35) {
                // A plate bent along a crease: two slabs meeting at an angle.
                let angle = rng.random_range(0.3..1.4);
                let half = Sdf::Box {
                    half: Vector3::new(length / 4.0, width / 2.0, thickness / 2.0),
                    round: 0.0,
                };
                let tilt = |a: f64| *Rotation3::from_axis_angle(&Vector3::y_axis(), a).matrix();
                let offset = |a: f64| tilt(a) * Vector3::new(length / 4.0, 0.0, 0.0);
                Sdf::Union {
                    parts: vec![
                        half.clone().moved(tilt(-angle / 2.0), offset(-angle / 2.0)),
                        half.moved(tilt(angle / 2.0), -offset(angle / 2.0)),
                    ],
                    smooth: 0.02,
                }
            } else {
                plate
            }
        }
        ShapeFamily::Shell => {
            let inner = match rng.random_range(0..3) {
                0 => Sdf::Ellipsoid {
                    radii: Vector3::new(
                        0.9,
                        rng.random_range(0.5..0.9),
                        rng.random_range(0.4..0.9),
                    ),
                },
                1 => Sdf::Box {
                    half: Vector3::new(0.9, rng.random_range(0.4..0.9), rng.random_range(0.3..0.9)),
                    round: 0.1,
                },
                _ => Sdf::Capsule {
                    a: Vector3::new(-0.5, 0.0, 0.0),
                    b: Vector3::new(0.5, 0.0, 0.0),
                    radius: rng.random_range(0.3..0.45),
                },
            };
            Sdf::Shell {
                inner: Box::new(inner),
                thickness: (2.0 * rng.random_range(0.05f64..0.12)).max(THINNEST),
            }
        }
        ShapeFamily::Holed => {
            let base = if rng.random_bool(0.5) {
                Sdf::Box {
                    half: Vector3::new(1.0, rng.random_range(0.4..0.9), rng.random_range(0.1..0.5)),
                    round: 0.05,
                }
            } else {
                Sdf::Cylinder {
                    radius: 0.9,
                    half_height: rng.random_range(0.1..0.5),
                }
            };
            let holes = rng.random_range(1..=3);
            let mut cut = Vec::new();
            for _ in 0..holes {
                let center = Vector3::new(
                    rng.random_range(-0.55..0.55),
                    rng.random_range(-0.25..0.25),
                    0.0,
                );
                cut.push(
                    Sdf::Cylinder {
                        radius: rng.random_range(0.1..0.25),
                        half_height: 2.0,
                    }
                    .moved(Matrix3::identity(), center),
                );
            }
            Sdf::Difference(
                Box::new(base),
                Box::new(Sdf::Union {
                    parts: cut,
                    smooth: 0.0,
                }),
            )
        }
        ShapeFamily::Csg => {
            let depth = 2 + usize::from(rng.random_bool(0.5));
            csg(rng, depth)
        }
    }
}

fn animal(rng: &mut ChaCha8Rng) -> Sdf {
    let body = Vector3::new(
        rng.random_range(0.45..0.7),
        rng.random_range(0.18..0.3),
        rng.random_range(0.16..0.28),
    );
    let mut parts = vec![Sdf::Ellipsoid { radii: body }];
    let legs = 2 * rng.random_range(1..=3);
    let leg_length = rng.random_range(0.3..0.6);
    let leg_radius = rng.random_range(0.05..0.09);
    for i in 0..legs / 2 {
        let x = if legs == 2 {
            0.0
        } else {
            -0.7 * body.x + 1.4 * body.x * i as f64 / (legs / 2 - 1) as f64
        };
        for side in [-1.0, 1.0] {
            let top = Vector3::new(x, side * 0.6 * body.y, -0.3 * body.z);
            let foot = top + Vector3::new(rng.random_range(-0.1..0.1), side * 0.05, -leg_length);
            parts.push(Sdf::Capsule {
                a: top,
                b: foot,
                radius: leg_radius,
            });
        }
    }
    let neck_base = Vector3::new(0.8 * body.x, 0.0, 0.3 * body.z);
    let head_at = neck_base
        + Vector3::new(
            rng.random_range(0.1..0.35),
            0.0,
            rng.random_range(0.15..0.5),
        );
    parts.push(Sdf::Capsule {
        a: neck_base,
        b: head_at,
        radius: rng.random_range(0.06..0.1),
    });
    parts.push(
        Sdf::Ellipsoid {
            radii: Vector3::new(
                rng.random_range(0.12..0.22),
                rng.random_range(0.09..0.14),
                rng.random_range(0.09..0.14),
            ),
        }
        .moved(Matrix3::identity(), head_at),
    );
    if rng.random_bool(0.7) {
        let base = Vector3::new(-0.95 * body.x, 0.0, 0.2 * body.z);
        parts.push(Sdf::Capsule {
            a: base,
            b: base
                + Vector3::new(
                    -rng.random_range(0.2..0.5),
                    0.0,
                    rng.random_range(-0.1..0.4),
                ),
            radius: rng.random_range(0.04..0.07),
        });
    }
    Sdf::Union {
        parts,
        smooth: 0.05,
    }
}

fn csg(rng: &mut ChaCha8Rng, depth: usize) -> Sdf {
    if depth == 0 {
        let center = random_direction(rng) * rng.random_range(0.0..0.3);
        let size = rng.random_range(1.0..1.8);
        let rotation = random_rotation(rng);
        return primitive(rng, size).moved(rotation, center);
    }
    let a = Box::new(csg(rng, depth - 1));
    let b = Box::new(csg(rng, depth - 1));
    match rng.random_range(0..3) {
        0 => Sdf::Union {
            parts: vec![*a, *b],
            smooth: 0.03,
        },
        1 => Sdf::Intersection(a, b),
        _ => Sdf::Difference(a, b),
    }
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
