//! The eigenmode baseline: a constant first mode, the right spectrum, M-orthogonality.

use std::sync::Arc;

use nalgebra::Vector3;
use physskin::geometry::{box_mesh, Normalization, TetMesh, VoxelGrid};
use physskin::skinning::{EigenmodeField, EigenmodeOptions, SkinningField};

fn bar_modes(modes: usize) -> (EigenmodeField, TetMesh) {
    // A 1 x 0.25 x 0.25 bar: its lowest Neumann Laplacian eigenvalues are (k pi / 1)^2 for
    // k = 1, 2, 3 before the first transverse one at (pi / 0.25)^2 = 16 pi^2.
    let shape = box_mesh(Vector3::new(1.0, 0.25, 0.25));
    let grid = VoxelGrid::from_shape(&shape, 128, None).resample(32);
    let mesh = TetMesh::from_grid(&grid);
    let field = EigenmodeField::compute(
        mesh.clone(),
        shape.normalization(),
        &EigenmodeOptions {
            modes,
            ..Default::default()
        },
    )
    .unwrap();
    (field, mesh)
}

#[test]
fn first_mode_is_constant_and_the_spectrum_matches_the_continuum() {
    let (field, mesh) = bar_modes(6);
    assert_eq!(field.handle_count(), 7);
    assert_eq!(field.eigenvalues[0], 0.0);
    for v in 0..mesh.vertices.len() {
        assert_eq!(field.vertex_weights(v)[0], 1.0);
    }
    // The voxelized bar is 1 x 0.25 x 0.25 up to a cell; allow discretization error.
    let pi2 = std::f64::consts::PI.powi(2);
    for (k, expected) in [(1, pi2), (2, 4.0 * pi2), (3, 9.0 * pi2)] {
        let got = field.eigenvalues[k];
        assert!(
            (got - expected).abs() / expected < 0.06,
            "mode {k}: {got} vs {expected}"
        );
    }
    assert!(field.eigenvalues.windows(2).all(|w| w[0] <= w[1] + 1e-9));
}

#[test]
fn modes_are_mass_orthogonal_to_each_other_and_to_the_constant() {
    let (field, mesh) = bar_modes(8);
    let mass = mesh.lumped_volumes();
    let k = field.handle_count();
    for a in 0..k {
        for b in 0..a {
            let dot: f64 = (0..mesh.vertices.len())
                .map(|v| mass[v] * field.vertex_weights(v)[a] * field.vertex_weights(v)[b])
                .sum();
            let na: f64 = (0..mesh.vertices.len())
                .map(|v| mass[v] * field.vertex_weights(v)[a].powi(2))
                .sum();
            let nb: f64 = (0..mesh.vertices.len())
                .map(|v| mass[v] * field.vertex_weights(v)[b].powi(2))
                .sum();
            assert!(dot.abs() / (na * nb).sqrt() < 1e-6, "modes {a}, {b}: {dot}");
        }
    }
}

#[test]
fn evaluation_interpolates_nodal_values_and_gradients_match_finite_differences() {
    let (field, mesh) = bar_modes(4);
    let map: Normalization = *field.normalization();
    let k = field.handle_count();
    let mut w = vec![0.0; k];
    for v in (0..mesh.vertices.len()).step_by(97) {
        field.evaluate(&[map.to_normalized(&mesh.vertices[v])], &mut w, None);
        for (computed, stored) in w.iter().zip(field.vertex_weights(v)) {
            assert!((computed - stored).abs() < 1e-9);
        }
    }
    // Inside a tetrahedron the field is linear: central differences are exact there.
    let p = map.to_normalized(&Vector3::new(0.1234, 0.0312, -0.0421));
    let mut g = vec![Vector3::zeros(); k];
    field.evaluate(&[p], &mut w, Some(&mut g));
    let eps = 1e-7;
    for axis in 0..3 {
        let (mut plus, mut minus) = (vec![0.0; k], vec![0.0; k]);
        let mut q = p;
        q[axis] += eps;
        field.evaluate(&[q], &mut plus, None);
        q[axis] -= 2.0 * eps;
        field.evaluate(&[q], &mut minus, None);
        for h in 0..k {
            let fd = (plus[h] - minus[h]) / (2.0 * eps);
            assert!(
                (fd - g[h][axis]).abs() < 1e-5 * (1.0 + fd.abs()),
                "handle {h} axis {axis}: {fd} vs {}",
                g[h][axis]
            );
        }
    }
    // Points just outside the solid extend the nearest cell's values instead of failing.
    let outside = map.to_normalized(&Vector3::new(0.6, 0.0, 0.0));
    field.evaluate(&[outside], &mut w, None);
    assert!(w.iter().all(|x| x.is_finite()));
    let _ = Arc::new(field);
}
