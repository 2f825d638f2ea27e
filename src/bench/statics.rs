//! Hanging equilibria, solved statically, and what they tell: the static error of a reduced
//! body against the FEM, and Rayleigh's estimate of the lowest frequency.
//!
//! Rayleigh's quotient with the static deflection u under the gravity load f = M g as the trial
//! shape gives the fundamental frequency from above, ω² ≈ uᵀKu / uᵀMu = gᵀMu / uᵀMu (K u = f at
//! equilibrium, for small deflections); it needs no eigen-solve of a 100,000-unknown stiffness,
//! and it moves with the stiffness as the lowest mode does.

use std::sync::Arc;

use nalgebra::Vector3;

use super::sim::{pinned_vertices, run_reduced, BenchShape, Scenario};
use crate::error::Result;
use crate::physics::{FemElement, FemSim, SimParams, Solver, Subspace};

/// Implicit Euler steps this long, s, damp the swing out in a few steps (ω h >= 8 for every
/// mode of the bench shapes, the slowest the creature's at 0.65 Hz): the step sequence settles
/// on the static equilibrium, which no step size moves.
const STATIC_DT: f64 = 2.0;
/// Steps at most; the FEM's solve stops earlier when a step moves no vertex more than `SETTLED`.
const MAX_STATIC_STEPS: usize = 40;
/// Steps of the reduced body (a few unknowns per handle: it settles as fast, and is cheap).
const REDUCED_STATIC_STEPS: usize = 20;
/// A step that moves no vertex more than this fraction of the diagonal has settled.
const SETTLED: f64 = 1e-6;

/// `params` made to settle: long steps, damped at their rate.
fn settling(params: &SimParams) -> SimParams {
    SimParams {
        dt: STATIC_DT,
        damping: 1.0 / STATIC_DT,
        ..params.clone()
    }
}

/// A static hanging equilibrium of the FEM: its positions (x, y, z per vertex), the steps it
/// took and whether the last moved less than `SETTLED`.
pub(crate) struct Equilibrium {
    pub positions: Vec<f64>,
    /// The FEM's nodes.
    pub nodes: usize,
    pub steps: usize,
    pub settled: bool,
}

/// `shape` hanging from its pinned end under `params`, solved statically with its FEM
/// reference.
pub(crate) fn fem_hanging(shape: &BenchShape, params: &SimParams) -> Result<Equilibrium> {
    let (mesh, params) = (shape.mesh.clone(), settling(params));
    match shape.reference {
        FemElement::Linear => settle(FemSim::new(mesh, params)?, shape),
        FemElement::Quadratic => settle(FemSim::quadratic(mesh, params)?, shape),
    }
}

fn settle<const N: usize, const D: usize>(
    mut fem: FemSim<N, D>,
    shape: &BenchShape,
) -> Result<Equilibrium> {
    fem.pin_vertices(&pinned_vertices(&shape.mesh));
    let (mut steps, mut settled) = (0, false);
    while steps < MAX_STATIC_STEPS && !settled {
        let before = fem.positions().to_vec();
        fem.step()?;
        steps += 1;
        let moved = before
            .chunks(3)
            .zip(fem.positions().chunks(3))
            .map(|(a, b)| Vector3::new(a[0] - b[0], a[1] - b[1], a[2] - b[2]).norm())
            .fold(0.0, f64::max);
        settled = moved < SETTLED * shape.diagonal;
    }
    Ok(Equilibrium {
        positions: fem.positions().to_vec(),
        nodes: fem.nodes(),
        steps,
        settled,
    })
}

/// The reduced body's hanging equilibrium against the FEM's, `fem`: the RMS distance of the
/// mesh's vertices (lifted) to it, % of the diagonal, and the ratio of their Rayleigh
/// frequencies (reduced over FEM).
pub(crate) fn reduced_against(
    shape: &BenchShape,
    params: &SimParams,
    subspace: &Arc<Subspace>,
    solver: Solver,
    fem: &Equilibrium,
) -> Result<(f64, f64)> {
    let reference = vec![fem.positions.clone(); REDUCED_STATIC_STEPS];
    let (_, lifted) = run_reduced(
        shape,
        Scenario::Hanging,
        &settling(params),
        subspace,
        solver,
        &reference,
    )?;
    let lifted: Vec<f64> = lifted.iter().map(|&x| f64::from(x)).collect();
    let squared: f64 = lifted
        .iter()
        .zip(&fem.positions)
        .map(|(a, b)| (a - b).powi(2))
        .sum();
    let error = (squared / shape.mesh.vertices.len() as f64).sqrt() / shape.diagonal * 100.0;
    let ratio = rayleigh_hz(shape, params, &lifted) / rayleigh_hz(shape, params, &fem.positions);
    Ok((error, ratio))
}

/// Rayleigh's estimate of the lowest frequency, Hz, from the static deflection `positions` of
/// `shape`'s mesh under `params.gravity`, with the mesh's lumped masses.
pub(crate) fn rayleigh_hz(shape: &BenchShape, params: &SimParams, positions: &[f64]) -> f64 {
    let (work, inertia) = deflections(shape, params, positions)
        .map(|(m, u)| (m * u.dot(&params.gravity), m * u.norm_squared()))
        .fold((0.0, 0.0), |(w, i), (a, b)| (w + a, i + b));
    (work / inertia).sqrt() / std::f64::consts::TAU
}

/// The mass-weighted mean displacement along gravity, m, and the largest displacement, m.
pub(crate) fn sag_and_largest(
    shape: &BenchShape,
    params: &SimParams,
    positions: &[f64],
) -> (f64, f64) {
    let down = params.gravity.normalize();
    let (mass, sag, largest) = deflections(shape, params, positions)
        .fold((0.0, 0.0, 0.0f64), |(mass, sag, largest), (m, u)| {
            (mass + m, sag + m * u.dot(&down), largest.max(u.norm()))
        });
    (sag / mass, largest)
}

/// Each vertex's lumped mass and displacement from rest.
fn deflections<'a>(
    shape: &'a BenchShape,
    params: &'a SimParams,
    positions: &'a [f64],
) -> impl Iterator<Item = (f64, Vector3<f64>)> + 'a {
    let mesh = &shape.mesh;
    mesh.lumped_volumes()
        .into_iter()
        .zip(&mesh.vertices)
        .zip(positions.chunks(3))
        .map(|((volume, v), x)| {
            (
                volume * params.density,
                Vector3::new(x[0] - v.x, x[1] - v.y, x[2] - v.z),
            )
        })
}
