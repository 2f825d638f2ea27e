//! Geometry in: loaders, normalization, the voxel inside test, sampling, cubature, tet meshes.

use crate::geometry::{
    box_mesh, bundled, load_geometry, reference_mesh, sample_surface, sdf_mesh, write_obj,
    Cubature, RawGeometry, Shape, SurfaceSampling, TetMesh, VoxelGrid,
};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn sphere(radius: f64) -> Shape {
    sdf_mesh(&|p: &Vector3<f64>| p.norm() - radius, radius * 1.2, 40)
}

#[test]
fn normalization_maps_the_bounding_box_into_the_unit_cube_and_back() {
    let shape = box_mesh(Vector3::new(4.0, 2.0, 1.0));
    let shifted = Shape::new(
        shape
            .positions
            .iter()
            .map(|p| p + Vector3::new(10.0, -3.0, 7.0))
            .collect(),
        None,
        shape.triangles.clone(),
    )
    .unwrap();
    let map = shifted.normalization();
    assert!((map.scale - 2.0).abs() < 1e-12);
    let normalized = shifted.normalized(&map);
    let (lo, hi) = normalized.bounds();
    assert!((lo.x + 1.0).abs() < 1e-12 && (hi.x - 1.0).abs() < 1e-12);
    assert!((hi.y - 0.5).abs() < 1e-12 && (hi.z - 0.25).abs() < 1e-12);
    for (p, q) in shifted.positions.iter().zip(&normalized.positions) {
        assert!((map.to_world(q) - p).norm() < 1e-12);
    }
}

#[test]
fn closed_mesh_volume_is_exact_and_open_mesh_has_none() {
    let b = box_mesh(Vector3::new(0.4, 0.3, 0.2));
    assert!((b.closed_volume().unwrap() - 0.024).abs() < 1e-12);
    let mut open = b.clone();
    open.triangles.pop();
    assert!(open.closed_volume().is_none());
}

#[test]
fn voxel_inside_test_fills_closed_and_open_meshes_and_clouds() {
    let s = sphere(0.5);
    let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.125;
    let grid = VoxelGrid::from_shape(&s, 64, None);
    assert!(grid.contains(&Vector3::zeros()));
    assert!(grid.contains(&Vector3::new(0.45, 0.0, 0.0)));
    assert!(!grid.contains(&Vector3::new(0.56, 0.0, 0.0)));
    assert!(!grid.contains(&Vector3::new(0.4, 0.4, 0.4)));
    let v = grid.solid_volume();
    assert!(
        (v - exact).abs() / exact < 0.03,
        "voxel volume {v} vs {exact}"
    );

    // Open: cut a hole of a few triangles near the top.
    let mut open = s.clone();
    let before = open.triangles.len();
    open.triangles.retain(|t| {
        let c = (open.positions[t[0] as usize]
            + open.positions[t[1] as usize]
            + open.positions[t[2] as usize])
            / 3.0;
        c.z < 0.499
    });
    assert!(open.triangles.len() < before, "the hole removed triangles");
    assert!(open.closed_volume().is_none());
    let grid = VoxelGrid::from_shape(&open, 64, Some(2));
    assert!(
        grid.contains(&Vector3::zeros()),
        "a small hole must not empty the inside"
    );
    assert!((grid.solid_volume() - exact).abs() / exact < 0.05);

    // Bare cloud: the mesh's vertices alone.
    let cloud = Shape::new(s.positions.clone(), None, Vec::new()).unwrap();
    let grid = VoxelGrid::from_shape(&cloud, 64, None);
    assert!(grid.contains(&Vector3::zeros()));
    assert!(!grid.contains(&Vector3::new(0.4, 0.4, 0.4)));
    let v = grid.solid_volume();
    assert!(
        (v - exact).abs() / exact < 0.08,
        "cloud volume {v} vs {exact}"
    );
}

#[test]
fn surface_samples_have_outward_unit_normals_for_meshes_and_clouds() {
    let s = sphere(0.5);
    let grid = VoxelGrid::from_shape(&s, 64, None);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let options = SurfaceSampling {
        count: 2000,
        ..Default::default()
    };
    let samples = sample_surface(&s, &grid, &options, &mut rng);
    assert_eq!(samples.points.len(), 2000);
    for (p, n) in samples.points.iter().zip(&samples.normals) {
        assert!((n.norm() - 1.0).abs() < 1e-9);
        assert!(n.dot(&p.normalize()) > 0.9, "normal {n} at {p}");
        assert!((p.norm() - 0.5).abs() < 0.02);
    }
    let area: f64 = samples.areas.iter().sum();
    let exact_area = 4.0 * std::f64::consts::PI * 0.25;
    assert!((area - exact_area).abs() / exact_area < 0.03, "area {area}");

    let cloud = Shape::new(s.positions.clone(), None, Vec::new()).unwrap();
    let grid = VoxelGrid::from_shape(&cloud, 64, None);
    let samples = sample_surface(&cloud, &grid, &options, &mut rng);
    let outward = samples
        .points
        .iter()
        .zip(&samples.normals)
        .filter(|(p, n)| n.dot(&p.normalize()) > 0.8)
        .count();
    assert!(
        outward as f64 > 0.98 * samples.points.len() as f64,
        "{outward} outward"
    );
}

#[test]
fn sharp_edges_of_a_box_get_samples() {
    let b = box_mesh(Vector3::new(1.0, 1.0, 1.0));
    let grid = VoxelGrid::from_shape(&b, 32, None);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let samples = sample_surface(
        &b,
        &grid,
        &SurfaceSampling {
            count: 1000,
            edge_fraction: 0.2,
            sharp_angle_deg: 30.0,
        },
        &mut rng,
    );
    let on_edges = samples
        .points
        .iter()
        .filter(|p| p.iter().filter(|c| (c.abs() - 0.5).abs() < 1e-9).count() >= 2)
        .count();
    assert_eq!(on_edges, 200);
}

#[test]
fn cubature_volumes_add_up_to_the_object_volume() {
    let b = box_mesh(Vector3::new(0.4, 0.3, 0.2));
    let grid = VoxelGrid::from_shape(&b, 64, None);
    for target in [64, 256, 1000] {
        let c = Cubature::stratified(&grid, target, b.closed_volume().unwrap());
        assert!((c.total_volume() - 0.024).abs() < 1e-12);
        assert_eq!(c.len(), target);
        for p in &c.points {
            assert!(
                grid.contains(p),
                "cubature point {:?} outside; cell {:?} origin {:?} cell {}",
                p.as_slice(),
                grid.cell_of(p),
                grid.origin.as_slice(),
                grid.cell
            );
        }
    }
}

#[test]
fn tet_mesh_covers_the_solid_and_interpolates_linear_functions_exactly() {
    let grid = VoxelGrid::from_shape(&bundled("creature").unwrap(), 24, None);
    let mesh = TetMesh::from_grid(&grid);
    let cell = grid.cell;
    let tet_volume: f64 = mesh
        .tets
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| mesh.vertices[v as usize]);
            (b - a).dot(&(c - a).cross(&(d - a))) / 6.0
        })
        .sum();
    assert!(mesh.tets.iter().all(|t| {
        let [a, b, c, d] = t.map(|v| mesh.vertices[v as usize]);
        (b - a).dot(&(c - a).cross(&(d - a))) > 0.0
    }));
    assert!((tet_volume - grid.solid_count() as f64 * cell.powi(3)).abs() < 1e-9);
    let lumped: f64 = mesh.lumped_volumes().iter().sum();
    assert!((lumped - tet_volume).abs() < 1e-9);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (lo, hi) = grid.solid_bounds();
    let mut checked = 0;
    while checked < 500 {
        let p = lo
            + (hi - lo).component_mul(&Vector3::from_fn(|_, _| rand::Rng::random::<f64>(&mut rng)));
        if !grid.contains(&p) {
            continue;
        }
        interpolates_linear_functions_at(&mesh, &p);
        checked += 1;
    }
    let boundary_area: f64 = mesh.boundary_areas.iter().sum();
    assert!(boundary_area > 0.0);
}

/// At `p`, inside the mesh's solid: the located weights are a partition of unity, none
/// negative, and interpolating a linear function from the vertices gives it and its gradient.
fn interpolates_linear_functions_at(mesh: &TetMesh, p: &Vector3<f64>) {
    let linear = |p: &Vector3<f64>| 2.0 * p.x - 3.0 * p.y + 0.5 * p.z + 1.0;
    let at = mesh.locate(p);
    let value: f64 = (0..4)
        .map(|i| at.barycentric[i] * linear(&mesh.vertices[at.vertices[i] as usize]))
        .sum();
    let gradient: Vector3<f64> = (0..4)
        .map(|i| at.gradients[i] * linear(&mesh.vertices[at.vertices[i] as usize]))
        .sum();
    assert!((at.barycentric.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!(at.barycentric.iter().all(|b| *b >= -1e-12));
    assert!((value - linear(p)).abs() < 1e-9, "value {value} at {p:?}");
    assert!(
        (gradient - Vector3::new(2.0, -3.0, 0.5)).norm() < 1e-9,
        "{gradient:?} at {p:?}"
    );
}

/// On a voxelized ball, a normal given inward is turned out and one given outward kept; at a
/// point deep inside (no side to tell) there is no answer.
#[test]
fn normals_are_turned_out_of_the_solid() {
    let ball = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 28);
    let solid = VoxelGrid::from_shape(&ball, 64, None);
    for direction in [Vector3::x(), Vector3::new(0.3, -0.5, 0.8).normalize()] {
        let p = direction * 0.1;
        let turned = solid
            .outward(&p, &-direction, &[2.0])
            .expect("a side to tell");
        assert!((turned - direction).norm() < 1e-12, "turned to {turned:?}");
        let kept = solid
            .outward(&p, &direction, &[2.0])
            .expect("a side to tell");
        assert!((kept - direction).norm() < 1e-12);
    }
    assert_eq!(
        solid.outward(&Vector3::zeros(), &-Vector3::z(), &[2.0]),
        None
    );
}

/// The bundled rod resampled to a fitted grid 32 cells long: counting the fine cells its
/// surface cuts as half solid keeps its volume closer to the rod's than counting them whole,
/// which makes it a fine cell thicker all round.
#[test]
fn a_fitted_resample_counts_cut_cells_half() {
    let rod = bundled("rod").expect("bundled");
    let truth = rod.closed_volume().expect("closed");
    let fine = VoxelGrid::from_shape(&rod, 128, None);
    let (lo, hi) = rod.bounds();
    let ratio = |(grid, stretch)| TetMesh::from_fitted_grid(&grid, stretch).volume() / truth;
    let whole = ratio(fine.resample_fitted(lo, hi, 32));
    let half = ratio(fine.resample_fitted_half_cut(lo, hi, 32));
    assert!(
        (half - 1.0).abs() < 0.15,
        "cut cells half: {half:.3} of the volume"
    );
    assert!(
        (half - 1.0).abs() < (whole - 1.0).abs(),
        "half {half:.3}, whole {whole:.3}"
    );
}

/// A reference mesh stretched to fit a slab (cells cubic in the grid's frame, a 6 cm side
/// spanned by whole cells) locates in the world: the FEM's lifter and its tetrahedra agree.
#[test]
fn a_stretched_reference_mesh_locates_in_the_world() {
    let mesh = reference_mesh(&box_mesh(Vector3::new(0.4, 0.4, 0.06))).mesh;
    for p in [
        Vector3::new(0.013, -0.17, 0.021),
        Vector3::new(-0.19, 0.05, -0.029),
    ] {
        interpolates_linear_functions_at(&mesh, &p);
    }
}

#[test]
fn loaders_read_back_what_was_written() {
    let dir = std::env::temp_dir().join(format!("physskin-geometry-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let b = box_mesh(Vector3::new(1.0, 2.0, 3.0));
    let raw = RawGeometry {
        positions: b.positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
        normals: None,
        triangles: b.triangles.clone(),
    };
    let path = dir.join("box.obj");
    write_obj(&raw, &mut std::fs::File::create(&path).unwrap()).unwrap();
    let loaded = Shape::from_raw(load_geometry(&path).unwrap()).unwrap();
    assert_eq!(loaded.triangles, b.triangles);
    assert!((loaded.closed_volume().unwrap() - 6.0).abs() < 1e-12);
    let err = load_geometry(&dir.join("missing.ply"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("missing.ply"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn shapes_with_bad_data_are_refused_with_a_reason() {
    let nan = Shape::new(vec![Vector3::new(f64::NAN, 0.0, 0.0)], None, vec![]).unwrap_err();
    assert!(nan.to_string().contains("point 0"), "{nan}");
    let index =
        Shape::new(vec![Vector3::zeros(), Vector3::x()], None, vec![[0, 1, 5]]).unwrap_err();
    assert!(index.to_string().contains("triangle 0"), "{index}");
    let flat = Shape::new(vec![Vector3::zeros(); 3], None, vec![]).unwrap_err();
    assert!(flat.to_string().contains("zero extent"), "{flat}");
}

#[test]
fn bundled_shapes_are_closed_and_their_voxel_volume_matches() {
    for name in crate::geometry::BUNDLED {
        let shape = bundled(name).unwrap();
        let exact = shape
            .closed_volume()
            .unwrap_or_else(|| panic!("{name} is not closed"));
        let grid = VoxelGrid::from_shape(&shape, 128, None);
        let voxels = grid.solid_volume();
        assert!(
            (voxels - exact).abs() / exact < 0.1,
            "{name}: voxel volume {voxels} vs {exact}"
        );
    }
}

/// A thin rod's points, on its surface (`fill` false) or through it, symmetric through `centre`:
/// each point comes with its reflection.
fn symmetric_rod(centre: &Vector3<f64>, fill: bool) -> Vec<Vector3<f64>> {
    let axis = Vector3::new(1.0, 0.004, -0.003).normalize();
    let across = axis.cross(&Vector3::z()).normalize();
    let third = axis.cross(&across);
    let radii: &[f64] = if fill {
        &[0.0, 0.02, 0.035, 0.05]
    } else {
        &[0.05]
    };
    let mut points = Vec::new();
    for s in 0..=60 {
        let along = axis * (0.6 * s as f64 / 60.0);
        for &radius in radii {
            for t in 0..32 {
                let angle = std::f64::consts::TAU * (t as f64 + 0.3) / 32.0;
                let p = along + (across * angle.cos() + third * angle.sin()) * radius;
                points.extend([centre + p, centre - p]);
            }
        }
    }
    points
}

#[test]
fn a_filled_cloud_symmetric_through_its_centre_is_voxelized_symmetric_through_it() {
    let centre = Vector3::new(0.0123, -0.0077, 0.0051);
    let shape = |points| Shape::new(points, None, Vec::new()).unwrap();
    let (solid, surface) = (
        shape(symmetric_rod(&centre, true)),
        shape(symmetric_rod(&centre, false)),
    );
    let grid = VoxelGrid::from_filled_cloud(&solid, &surface, 64, &centre);
    // A cell corner at the centre: every cell has its reflection's cell.
    let corner = (centre - grid.origin) / grid.cell;
    assert!(
        corner.iter().all(|c| (c - c.round()).abs() < 1e-9),
        "{corner:?}"
    );
    let mut solid_cells = 0;
    for index in (0..grid.len()).filter(|&i| grid.solid[i]) {
        let mirrored = 2.0 * centre - grid.cell_center(grid.coords(index));
        assert!(
            grid.contains(&mirrored),
            "cell {index}'s reflection is not solid"
        );
        solid_cells += 1;
    }
    let offset = (grid.solid_centroid() - centre).norm();
    // Laid out from the cloud's corner instead (`from_shape`), the same points' solid was 7.6 mm
    // off the centre (printed).
    let unanchored = VoxelGrid::from_shape(&solid, 64, None).solid_centroid() - centre;
    println!(
        "{solid_cells} cells, centroid {offset:.2e} m off (from the corner {:.2e})",
        unanchored.norm()
    );
    assert!(
        offset < 1e-9,
        "the solid's centroid is {offset} m off the centre"
    );
}
