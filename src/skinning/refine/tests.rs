use nalgebra::{DMatrix, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::geometry::{box_mesh, VoxelGrid};
use crate::skinning::EigenmodeOptions;

/// The crate example's bar, 1 x 0.2 x 0.2 m, tetrahedralized at each of `resolutions` (cells
/// along its length), and its normalization.
fn bar(resolutions: &[usize]) -> (Vec<TetMesh>, Normalization) {
    let shape = box_mesh(Vector3::new(1.0, 0.2, 0.2));
    let fine = VoxelGrid::from_shape(&shape, 128, None);
    let meshes = resolutions
        .iter()
        .map(|&r| TetMesh::from_grid(&fine.resample(r)))
        .collect();
    (meshes, shape.normalization())
}

fn eigenmodes(mesh: &TetMesh, normalization: Normalization, modes: usize) -> EigenmodeField {
    let options = EigenmodeOptions {
        modes,
        ..Default::default()
    };
    EigenmodeField::compute(mesh.clone(), normalization, &options).unwrap()
}

fn random_block(n: usize, k: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(n, k, |_, _| rng.random::<f64>() - 0.5)
}

/// Every handle of `field` (the constant included) at the mesh's vertices.
fn vertex_columns(field: &EigenmodeField) -> DMatrix<f64> {
    let n = field.mesh().vertices.len();
    DMatrix::from_fn(n, field.handle_count(), |v, h| field.vertex_weights(v)[h])
}

fn mass_times(a: &DMatrix<f64>, mass: &[f64]) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |r, c| mass[r] * a[(r, c)])
}

fn m_orthonormal(a: &DMatrix<f64>, mass: &[f64]) -> DMatrix<f64> {
    let gram = a.tr_mul(&mass_times(a, mass));
    let l = gram.cholesky().expect("independent columns").l();
    a * l.try_inverse().expect("invertible").transpose()
}

/// The principal angles (radians) between span(a) and span(b) in the M inner product.
fn principal_angles(a: &DMatrix<f64>, b: &DMatrix<f64>, mass: &[f64]) -> Vec<f64> {
    let (qa, qb) = (m_orthonormal(a, mass), m_orthonormal(b, mass));
    let cosines = qa
        .tr_mul(&mass_times(&qb, mass))
        .svd(false, false)
        .singular_values;
    cosines.iter().map(|c| c.clamp(-1.0, 1.0).acos()).collect()
}

#[test]
fn the_sum_of_the_ritz_values_never_increases() {
    let (meshes, normalization) = bar(&[20]);
    let mesh = &meshes[0];
    let start = random_block(mesh.vertices.len(), 8, 3);
    for search in [
        RefineSearch::Subspace,
        RefineSearch::Enriched,
        RefineSearch::LocallyOptimal,
    ] {
        let options = RefineOptions {
            budget: RefineBudget::Iterations(40),
            search,
            ..Default::default()
        };
        let report = refine(mesh.clone(), normalization, &start, &options)
            .unwrap()
            .report;
        let traces = report.traces();
        assert!(report.iterations > 0);
        assert_eq!(traces.len(), report.iterations + 1);
        assert_eq!(report.iteration_ms.len(), report.iterations);
        // Entry 0 is the start block's: each later one is at most the one before.
        for (i, pair) in traces.windows(2).enumerate() {
            assert!(
                pair[1] <= pair[0] * (1.0 + 1e-12),
                "{search:?}, iteration {}: {} after {}",
                i + 1,
                pair[1],
                pair[0]
            );
        }
        assert!(
            traces[traces.len() - 1] < 0.5 * traces[0],
            "{search:?}: {traces:?}"
        );
    }
}

#[test]
fn full_refinement_finds_the_eigenmodes_span() {
    let (meshes, normalization) = bar(&[20]);
    let mesh = &meshes[0];
    let modes = 8;
    let eigen = eigenmodes(mesh, normalization, modes);
    let start = random_block(mesh.vertices.len(), modes, 5);
    let refined = refine(
        mesh.clone(),
        normalization,
        &start,
        &RefineOptions::default(),
    )
    .unwrap();
    assert!(refined.report.converged, "{:?}", refined.report.traces());
    assert_eq!(refined.field.handle_count(), modes + 1);
    assert_eq!(refined.field.kind(), "refined");
    let mass = mesh.lumped_volumes();
    let angles = principal_angles(
        &vertex_columns(&refined.field),
        &vertex_columns(&eigen),
        &mass,
    );
    assert_eq!(angles.len(), modes + 1);
    assert!(angles.iter().all(|a| *a < 1e-3), "{angles:?}");
    for (r, e) in refined
        .field
        .eigenvalues
        .iter()
        .zip(&eigen.eigenvalues)
        .skip(1)
    {
        assert!((r - e).abs() < 1e-6 * e, "Ritz value {r} vs eigenvalue {e}");
    }
}

#[test]
fn a_warm_start_is_most_of_the_way_after_one_iteration() {
    // The start: the eigenmodes of a mesh with half the resolution, at the fine vertices,
    // the stand-in for a network's columns. They miss every mode antisymmetric across the
    // coarse bar's two cells, which the guard columns bring in.
    let (meshes, normalization) = bar(&[10, 20]);
    let coarse = eigenmodes(&meshes[0], normalization, 8);
    let fine = &meshes[1];
    let options = RefineOptions::default();
    let warm = refine_field(&coarse, fine.clone(), normalization, &options).unwrap();
    let random = random_block(fine.vertices.len(), 8, 5);
    let cold = refine(fine.clone(), normalization, &random, &options).unwrap();
    assert!(warm.report.converged && cold.report.converged);
    let (warm_traces, cold_traces) = (warm.report.traces(), cold.report.traces());
    let best = warm_traces[warm_traces.len() - 1];
    assert!((best - cold_traces[cold_traces.len() - 1]).abs() < 1e-8 * best);
    let (warm_gap, cold_gap) = (warm_traces[1] / best - 1.0, cold_traces[1] / best - 1.0);
    assert!(
        warm_gap < 0.25 * cold_gap,
        "after one iteration: warm {warm_gap:e}, cold {cold_gap:e}"
    );
    let eigen = eigenmodes(fine, normalization, 8);
    let mass = fine.lumped_volumes();
    let angles = principal_angles(&vertex_columns(&warm.field), &vertex_columns(&eigen), &mass);
    assert!(angles.iter().all(|a| *a < 1e-3), "{angles:?}");
}

#[test]
fn without_iterations_the_field_holds_the_start_span() {
    let (meshes, normalization) = bar(&[12]);
    let mesh = &meshes[0];
    let n = mesh.vertices.len();
    let start = random_block(n, 4, 9);
    for budget in [RefineBudget::Off, RefineBudget::Millis(0)] {
        let options = RefineOptions {
            budget,
            ..Default::default()
        };
        let refined = refine(mesh.clone(), normalization, &start, &options).unwrap();
        assert_eq!(refined.report.iterations, 0);
        assert_eq!(refined.report.ritz_values.len(), 1);
        let with_constant =
            DMatrix::from_fn(n, 5, |r, c| if c == 0 { 1.0 } else { start[(r, c - 1)] });
        let angles = principal_angles(
            &vertex_columns(&refined.field),
            &with_constant,
            &mesh.lumped_volumes(),
        );
        assert!(angles.iter().all(|a| *a < 1e-6), "{budget:?}: {angles:?}");
    }
    let wrong = random_block(n + 1, 4, 9);
    assert!(refine(
        mesh.clone(),
        normalization,
        &wrong,
        &RefineOptions::default()
    )
    .is_err());
}

/// Columns 1, x, y + 2z: affine in space, so interpolating them is exact.
struct Affine;

impl SkinningField for Affine {
    fn handle_count(&self) -> usize {
        3
    }
    fn evaluate(&self, p: &[Vector3<f64>], w: &mut [f64], _: Option<&mut [Vector3<f64>]>) {
        for (i, p) in p.iter().enumerate() {
            w[3 * i..3 * i + 3].copy_from_slice(&[1.0, p.x, p.y + 2.0 * p.z]);
        }
    }
    fn kind(&self) -> &'static str {
        "test"
    }
}

#[test]
fn the_start_block_sampled_on_every_other_line_is_exact_for_an_affine_field() {
    // 60 cells along the bar, 12 across: most vertices have all their coarse neighbours.
    let (meshes, normalization) = bar(&[60]);
    let mesh = &meshes[0];
    let plan = CoarseSampling::new(mesh);
    let evaluated = plan.evaluated.len();
    assert!(
        evaluated < mesh.vertices.len() / 2,
        "{evaluated} of {} vertices evaluated",
        mesh.vertices.len()
    );
    let start = start_block(&Affine, mesh, &normalization);
    for (v, x) in mesh.vertices.iter().enumerate() {
        let q = normalization.to_normalized(x);
        assert!((start[(v, 0)] - q.x).abs() < 1e-12, "vertex {v}: x");
        assert!(
            (start[(v, 1)] - (q.y + 2.0 * q.z)).abs() < 1e-12,
            "vertex {v}: y + 2z"
        );
    }
}

#[test]
fn a_settled_budget_stops_once_no_ritz_value_moves_by_more_than_settled() {
    let (meshes, normalization) = bar(&[20]);
    let mesh = &meshes[0];
    let start = random_block(mesh.vertices.len(), 8, 3);
    let run = |budget| {
        let options = RefineOptions {
            budget,
            ..Default::default()
        };
        refine(mesh.clone(), normalization, &start, &options).unwrap()
    };
    let values = run(RefineBudget::Iterations(40)).report.ritz_values;
    // The first iteration after which no value moved by SETTLED of itself.
    let settled_at = (1..values.len())
        .find(|&i| {
            values[i - 1]
                .iter()
                .zip(&values[i])
                .all(|(old, new)| (old - new).abs() < SETTLED * new.abs())
        })
        .expect("the values settle within 40 iterations");
    assert!(settled_at > 1 && settled_at < 40, "{values:?}");
    let settled = run(RefineBudget::Settled(40));
    assert_eq!(settled.report.iterations, settled_at, "{values:?}");
    // It is the fixed count's refinement, stopped there: the same field to the last bit.
    let fixed = run(RefineBudget::Iterations(settled_at as u32));
    assert_eq!(settled.field.eigenvalues, fixed.field.eigenvalues);
    assert_eq!(vertex_columns(&settled.field), vertex_columns(&fixed.field));
    // A cap below that point stops at the cap.
    let capped = run(RefineBudget::Settled(settled_at as u32 - 1)).report;
    assert_eq!(capped.iterations, settled_at - 1);
}
