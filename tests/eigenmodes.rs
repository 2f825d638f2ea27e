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

#[test]
fn points_just_outside_the_voxelized_solid_get_continuous_weights() {
    // A cube with its top corner cell left out, as a voxelization leaves out cells the surface
    // barely enters. A point in that cell is as near the cell beside it in x as the one beside
    // it in y; snapping to the nearer cell gave weights 1e-3 apart for the same point moved by
    // round-off (two copies of one box in a scene).
    let shape = box_mesh(Vector3::new(0.2, 0.2, 0.2));
    let mut grid = VoxelGrid::from_shape(&shape, 64, None).resample(8);
    let solid: Vec<usize> = (0..grid.len()).filter(|&i| grid.solid[i]).collect();
    let corner = *solid
        .iter()
        .max_by_key(|&&i| grid.coords(i).iter().sum::<usize>())
        .unwrap();
    grid.solid[corner] = false;
    let mesh = TetMesh::from_grid(&grid);
    let columns = nalgebra::DMatrix::from_fn(mesh.vertices.len(), 2, |v, c| {
        let p = mesh.vertices[v];
        if c == 0 {
            p.x + 2.0 * p.y + p.z
        } else {
            (7.0 * p.x).sin() * p.y
        }
    });
    let map = shape.normalization();
    let field = EigenmodeField::from_columns(mesh.clone(), map, &columns, &[1.0, 2.0], 0).unwrap();
    // On the diagonal of the missing cell's top face, nudged either way by round-off.
    let c = grid.cell_center(grid.coords(corner));
    let at = |p: Vector3<f64>| {
        let mut w = vec![0.0; field.handle_count()];
        field.evaluate(&[map.to_normalized(&p)], &mut w, None);
        w
    };
    let p = c + Vector3::new(-0.3, -0.3, 0.2) * grid.cell;
    for nudge in [Vector3::new(1e-12, 0.0, 0.0), Vector3::new(0.0, 1e-12, 0.0)] {
        let (a, b) = (at(p + nudge), at(p - nudge));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-9, "{a:?} against {b:?}");
        }
    }
    // Inside the solid the field is the mesh's interpolation, unchanged by the outer layer.
    for v in (0..mesh.vertices.len()).step_by(7) {
        let w = at(mesh.vertices[v]);
        for (h, x) in w.iter().enumerate() {
            assert!(
                (x - field.vertex_weights(v)[h]).abs() < 1e-9,
                "vertex {v}, handle {h}"
            );
        }
    }
}
