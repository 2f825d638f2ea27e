//! `bench track`'s truth: the full-space FEM run through a sequence, and the surface the camera
//! sees on it.

use nalgebra::Vector3;

use crate::error::Result;
use crate::geometry::{nearest_point, reference_mesh, Shape, TetLocation, TetMesh};
use crate::physics::{phi_of, FemSim, Obstacle, Poke};
use crate::runtime::NodeParams;

/// A box the camera sees and the node does not model (a poker's rod, a paddle): its eight
/// corners, corner c at the signs of its bits (x, y, z), as `box_mesh` numbers them.
pub(super) type Occluder = [Vector3<f64>; 8];

/// A run of a sequence (the FEM's or a peer engine's): the surface the camera sees, its
/// vertices per step, and what hides it.
pub(super) struct Truth {
    /// The shape's own surface (see [`embedded_surface`]).
    pub(super) surface: Vec<[u32; 3]>,
    /// The surface's vertices, per step.
    pub(super) positions: Vec<Vec<Vector3<f64>>>,
    /// Diagonal of the FEM mesh's bounds, m: errors are fractions of it.
    pub(super) diagonal: f64,
    /// The boxes in front of the camera at each step.
    pub(super) occluders: Vec<Vec<Occluder>>,
}

impl Truth {
    /// Points spread over the surface at `step`, about as dense as a body's surface samples:
    /// each triangle at its corners, along its edges and inside, at the fewest barycentric
    /// steps that give `DENSE_POINTS` (at most `MAX_STEPS`: MuJoCo's block has 416 triangles
    /// 3 cm across, and at 15 points a triangle its surface's own sampling, 2.5 mm from a
    /// point on it on average, held the Chamfer distance near 0.8 % of the diagonal).
    pub(super) fn dense_surface(&self, step: usize) -> Vec<Vector3<f64>> {
        let x = &self.positions[step];
        let per_triangle = |n: usize| (n + 1) * (n + 2) / 2;
        let n = (1..MAX_STEPS)
            .find(|&n| per_triangle(n) * self.surface.len() >= DENSE_POINTS)
            .unwrap_or(MAX_STEPS);
        let mut out = Vec::with_capacity(per_triangle(n) * self.surface.len());
        for t in &self.surface {
            let [a, b, c] = t.map(|i| x[i as usize]);
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    out.push(a * (1.0 - u - v) + b * u + c * v);
                }
            }
        }
        out
    }

    pub(super) fn at(&self, step: usize, (t, b): (usize, [f64; 3])) -> Vector3<f64> {
        let tri = self.surface[t];
        (0..3)
            .map(|i| self.positions[step][tri[i] as usize] * b[i])
            .sum()
    }
}

/// The FEM stepped through the sequence: a floor at z = 0, the node's default material.
pub(super) fn run_truth(
    shape: &Shape,
    lifted: f64,
    pokes: &[Poke],
    params: &NodeParams,
    seconds: f64,
) -> Result<Truth> {
    let reference = reference_mesh(shape);
    let mut mesh = (*reference.mesh).clone();
    mesh.vertices.iter_mut().for_each(|v| v.z += lifted);
    let mut fem = FemSim::new(std::sync::Arc::new(mesh), params.sim_params())?;
    fem.add_obstacle(Obstacle::floor(0.0));
    for poke in pokes {
        let mut poke = *poke;
        poke.point.z += lifted;
        fem.add_poke(poke);
    }
    let steps = (seconds * params.rate_hz).round() as usize;
    let read = |fem: &FemSim| -> Vec<Vector3<f64>> {
        fem.positions()
            .chunks_exact(3)
            .map(|p| Vector3::new(p[0], p[1], p[2]))
            .collect()
    };
    let (carried, surface) = embedded_surface(shape, &reference.mesh);
    let mut positions = vec![carry(&carried, &read(&fem))];
    for _ in 0..steps {
        fem.step()?;
        positions.push(carry(&carried, &read(&fem)));
    }
    let dt = params.sim_params().dt;
    let tips: Vec<usize> = (pokes.iter())
        .map(|p| nearest_point(&positions[0], &p.point).expect("a surface has vertices"))
        .collect();
    let occluders = (0..positions.len())
        .map(|step| {
            let t = step as f64 * dt;
            (pokes.iter().zip(&tips))
                .filter(|(p, _)| p.start <= t && t < p.end)
                .map(|(poke, &tip)| poker_rod(poke, &positions[step][tip]))
                .collect()
        })
        .collect();
    Ok(Truth {
        surface,
        diagonal: reference.diagonal,
        positions,
        occluders,
    })
}

/// A 2.4 cm square rod from `tip` 0.3 m back along the poke's force: it hides what lies behind
/// it from the camera. Its tip follows the surface's vertex nearest the poked point at rest.
fn poker_rod(poke: &Poke, tip: &Vector3<f64>) -> Occluder {
    let axis = -poke.force.normalize();
    let side = axis.cross(&Vector3::z()).normalize() * 0.012;
    let up = axis.cross(&side).normalize() * 0.012;
    let sign = |c: usize, bit: usize| if c & bit == 0 { -1.0 } else { 1.0 };
    std::array::from_fn(|c| {
        let along = if c & 1 == 0 { 0.01 } else { 0.3 };
        tip + axis * along + side * sign(c, 2) + up * sign(c, 4)
    })
}

/// Longest edge of the surface the camera sees, as a fraction of the FEM mesh's diagonal, about
/// a cell of the mesh: a box's twelve triangles are split until they bend with it (3,072
/// triangles), a ball's 5,148 are short enough.
const SURFACE_EDGE: f64 = 1.0 / 12.0;
/// Points `Truth::dense_surface` spreads at least (or `MAX_STEPS` steps along each edge).
const DENSE_POINTS: usize = 20_000;
/// The most barycentric steps along a triangle's edge `Truth::dense_surface` takes.
const MAX_STEPS: usize = 12;

/// The shape's own surface carried by the FEM, as a renderer draws a simulated soft body's
/// mesh on its simulation mesh: each vertex of the shape's triangles (split until no edge is
/// longer than `SURFACE_EDGE` of the diagonal) moves with the tetrahedron it lies in at rest.
/// The camera then sees the object (a round ball), not the voxel mesh's staircase, which keeps
/// every cell the surface cuts: the ball's FEM mesh (823 vertices) is one no ellipsoid fits.
/// `mesh` is the FEM's mesh at rest, before the sequence lifts it (the shape's frame).
fn embedded_surface(shape: &Shape, mesh: &TetMesh) -> (Vec<TetLocation>, Vec<[u32; 3]>) {
    let (lo, hi) = mesh.bounds();
    let (vertices, triangles) = split_long_edges(
        shape.positions.clone(),
        shape.triangles.clone(),
        SURFACE_EDGE * (hi - lo).norm(),
    );
    let located = vertices.iter().map(|p| mesh.locate(p)).collect();
    (located, triangles)
}

/// The surface's vertices where the FEM's vertices (`nodes`) put them.
fn carry(located: &[TetLocation], nodes: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    located
        .iter()
        .map(|l| {
            (0..4)
                .map(|i| nodes[l.vertices[i] as usize] * l.barycentric[i])
                .sum()
        })
        .collect()
}

/// Every triangle split in four at its edges' midpoints (shared between neighbours, so the
/// surface stays closed) until no edge is longer than `longest`.
fn split_long_edges(
    mut vertices: Vec<Vector3<f64>>,
    mut triangles: Vec<[u32; 3]>,
    longest: f64,
) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
    let too_long = |v: &[Vector3<f64>], t: &[[u32; 3]]| {
        t.iter().any(|f| {
            (0..3).any(|i| (v[f[i] as usize] - v[f[(i + 1) % 3] as usize]).norm() > longest)
        })
    };
    while too_long(&vertices, &triangles) {
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vector3<f64>>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]) / 2.0);
                vertices.len() as u32 - 1
            })
        };
        let mut split = Vec::with_capacity(4 * triangles.len());
        for [a, b, c] in triangles {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut vertices),
                midpoint(b, c, &mut vertices),
                midpoint(c, a, &mut vertices),
            );
            split.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        triangles = split;
    }
    (vertices, triangles)
}

/// The best any state of a body's subspace does on its material points: the least-squares fit
/// of the handle matrix to their true places. No tracker can beat it; a sequence whose tracked
/// error sits near it asks for a richer subspace, not a better correction.
pub(super) struct SubspaceFit {
    /// Each point's phi = w (x) [x; 1]: points x 4K.
    phi: nalgebra::DMatrix<f64>,
    normal: nalgebra::linalg::Cholesky<f64, nalgebra::Dyn>,
}

impl SubspaceFit {
    /// The fit for the rest points of `lifter`; None when its points do not pin every
    /// handle's affine map down.
    pub(super) fn new(lifter: &crate::physics::Lifter) -> Option<Self> {
        let (n, k) = (lifter.len(), lifter.handles());
        let rest = lifter.rest_points();
        let rows: Vec<_> = (0..n)
            .map(|i| {
                let weights: Vec<f64> = (0..k).map(|a| lifter.weight(i, a) as f64).collect();
                phi_of(&weights, &rest[i])
            })
            .collect();
        let phi = nalgebra::DMatrix::from_fn(n, 4 * k, |i, c| rows[i][c]);
        let mut normal = phi.transpose() * &phi;
        // A hair of ridge: a handle that hardly reaches the points leaves the rest unchanged.
        let ridge = 1e-12 * normal.trace() / normal.nrows() as f64;
        normal
            .iter_mut()
            .step_by(4 * k + 1)
            .for_each(|d| *d += ridge);
        Some(Self {
            normal: normal.cholesky()?,
            phi,
        })
    }

    /// RMS distance of the best fit to `targets` (one per rest point), m.
    pub(super) fn error(&self, targets: &[Vector3<f64>]) -> f64 {
        let t = nalgebra::DMatrix::from_fn(targets.len(), 3, |i, d| targets[i][d]);
        let coefficients = self.normal.solve(&(self.phi.transpose() * &t));
        let residual = &self.phi * coefficients - t;
        (residual.norm_squared() / targets.len().max(1) as f64).sqrt()
    }
}
