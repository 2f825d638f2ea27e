//! `bench fem`: how far the full-space FEM reference of `bench sim` is from converged. Each bench
//! shape hangs from its pinned end (the hanging scenario's pins, material and gravity) at
//! several voxel resolutions, the bench's among them; each equilibrium is solved statically and
//! compared with the finest's: the sag (mass-weighted mean displacement along gravity), the
//! largest displacement, and Rayleigh's estimate of the lowest frequency from the sag (see
//! `statics`).

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use super::sim::{
    bench_min_vertices, bench_resolutions, prepare_shape, scenario_params, smallest_resolution,
    BenchShape, SHAPES, YOUNGS,
};
use super::statics::{fem_hanging, rayleigh_hz, sag_and_largest};
use crate::error::{Error, Result};
use crate::geometry::{bundled, Shape, TetMesh, VoxelGrid};
use crate::physics::{FemElement, SimParams};

/// Which voxel mesh the study solves on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FemMesh {
    /// `bench sim`'s: every cell the surface cuts is kept, so the mesh reaches past the
    /// surface by up to a cell on every side.
    CutCells,
    /// Cells that tile the shape's bounds exactly (each axis stretched a little), a cell solid
    /// when half of it is: the demo's reference (`geometry::reference_mesh`).
    Fitted,
}

/// One shape at one resolution.
#[derive(Clone, Debug, Serialize)]
pub struct FemConvergenceRow {
    /// The bench shape.
    pub shape: String,
    /// The voxel mesh solved on.
    pub mesh: FemMesh,
    /// The FEM's element.
    pub element: FemElement,
    /// Voxel cells across the longest side.
    pub resolution: usize,
    /// Whether `bench sim` uses this resolution.
    pub bench: bool,
    /// Mesh vertices and tetrahedra, and the FEM's nodes (more than the vertices for
    /// quadratic elements).
    pub vertices: usize,
    pub tets: usize,
    pub nodes: usize,
    /// The tetrahedral mesh's volume over the shape's: the voxel mesh keeps every cell the
    /// surface cuts, so a thin shape comes out thicker, and stiffer, than it is.
    pub volume_ratio: f64,
    /// Mass-weighted mean displacement along gravity at equilibrium, m.
    pub sag_m: f64,
    /// Largest vertex displacement at equilibrium, m.
    pub max_displacement_m: f64,
    /// Rayleigh's estimate of the lowest frequency from the sag, Hz.
    pub rayleigh_hz: f64,
    /// `sag_m` off the finest resolution's, %.
    pub sag_off_finest_pct: f64,
    /// `rayleigh_hz` off the finest resolution's, %.
    pub rayleigh_off_finest_pct: f64,
    /// Static steps taken, and whether the last settled (see `statics`).
    pub steps: usize,
    pub settled: bool,
    /// Wall-clock time of the static solve, s.
    pub solve_s: f64,
}

/// What `bench fem` reports.
#[derive(Clone, Debug, Serialize)]
pub struct FemConvergenceReport {
    pub rows: Vec<FemConvergenceRow>,
}

/// The resolutions studied for `SHAPES[i]`, coarse to fine, and the bench's: `bench sim`'s
/// (the creature's the smallest with its vertex count) and around it, half as many cells
/// across for quadratic elements (some seven times the nodes per vertex); `quick`: small ones.
fn resolutions(i: usize, quick: bool, element: FemElement) -> (Vec<usize>, usize) {
    if quick {
        return (vec![16, 24, 32], 24);
    }
    let scale = match element {
        FemElement::Linear => 1.0,
        FemElement::Quadratic => 0.5,
    };
    let bench = match bench_resolutions(false)[i] {
        0 => {
            let fine = VoxelGrid::from_shape(&bundled(SHAPES[i]).expect("bundled"), 128, None);
            smallest_resolution(&fine, bench_min_vertices(false))
        }
        r => r,
    };
    let around = [0.5, 0.75, 1.0, 1.25].map(|f| (bench as f64 * f * scale).round() as usize);
    (around.to_vec(), bench)
}

/// Runs the study on `shapes` (all three when empty); `progress` gets a line per solve.
pub fn run_fem_convergence(
    shapes: &[String],
    quick: bool,
    mesh: FemMesh,
    element: FemElement,
    mut progress: impl FnMut(&str),
) -> Result<FemConvergenceReport> {
    let mut rows = Vec::new();
    for (i, (name, young)) in SHAPES.into_iter().zip(YOUNGS).enumerate() {
        if !shapes.is_empty() && !shapes.iter().any(|s| s == name) {
            continue;
        }
        let (list, bench) = resolutions(i, quick, element);
        let mut of_shape = Vec::new();
        for resolution in list {
            let source = bundled(name).expect("bundled");
            let mut shape = match mesh {
                FemMesh::CutCells => prepare_shape(source, young, resolution, 0, 0)?,
                FemMesh::Fitted => fitted_shape(source, young, resolution)?,
            };
            shape.reference = element;
            let is_bench = resolution == bench && element == FemElement::Linear;
            let row = hanging_equilibrium(name, &shape, mesh, resolution, is_bench)?;
            progress(&format!(
                "{name} at {resolution}: {} nodes, sag {:.6} m, max {:.6} m, Rayleigh {:.4} Hz, {} steps ({:.1} s)",
                row.nodes, row.sag_m, row.max_displacement_m, row.rayleigh_hz, row.steps, row.solve_s
            ));
            of_shape.push(row);
        }
        let finest = of_shape.last().cloned().expect("at least one resolution");
        for row in &mut of_shape {
            row.sag_off_finest_pct = 100.0 * (row.sag_m / finest.sag_m - 1.0);
            row.rayleigh_off_finest_pct = 100.0 * (row.rayleigh_hz / finest.rayleigh_hz - 1.0);
        }
        rows.extend(of_shape);
    }
    if rows.is_empty() {
        return Err(Error::InvalidParameter {
            name: "shape",
            reason: "no bench shape chosen (plate, rod, creature)".into(),
        });
    }
    Ok(FemConvergenceReport { rows })
}

/// The static equilibrium of `shape` (on a mesh of kind `mesh`) hanging from its pinned end,
/// and its figures.
fn hanging_equilibrium(
    name: &str,
    shape: &BenchShape,
    mesh: FemMesh,
    resolution: usize,
    bench: bool,
) -> Result<FemConvergenceRow> {
    let params = scenario_params(shape);
    let started = Instant::now();
    let equilibrium = fem_hanging(shape, &params)?;
    let solve_s = started.elapsed().as_secs_f64();
    let (sag_m, max_displacement_m) = sag_and_largest(shape, &params, &equilibrium.positions);
    Ok(FemConvergenceRow {
        shape: name.into(),
        mesh,
        element: shape.reference,
        resolution,
        bench,
        vertices: shape.mesh.vertices.len(),
        tets: shape.mesh.tets.len(),
        nodes: equilibrium.nodes,
        volume_ratio: shape.mesh.volume() / shape.source.closed_volume().unwrap_or(f64::NAN),
        sag_m,
        max_displacement_m,
        rayleigh_hz: rayleigh_hz(shape, &params, &equilibrium.positions),
        sag_off_finest_pct: 0.0,
        rayleigh_off_finest_pct: 0.0,
        steps: equilibrium.steps,
        settled: equilibrium.settled,
        solve_s,
    })
}

/// `shape` on a mesh whose cells tile its bounds at `resolution` cells across its longest side
/// (see [`FemMesh::Fitted`]), without eigenmodes: the study solves the FEM only.
fn fitted_shape(source: Shape, young: f64, resolution: usize) -> Result<BenchShape> {
    let fine = VoxelGrid::from_shape(&source, 128, None);
    let (lo, hi) = source.bounds();
    let (grid, stretch) = fine.resample_fitted_half_cut(lo, hi, resolution);
    let mesh = TetMesh::from_fitted_grid(&grid, stretch);
    let (lo, hi) = mesh.bounds();
    Ok(BenchShape {
        source,
        mesh: Arc::new(mesh),
        grid,
        eigen: None,
        diagonal: (hi - lo).norm(),
        young,
        poisson: SimParams::default().poisson,
        reference: FemElement::Linear,
    })
}
