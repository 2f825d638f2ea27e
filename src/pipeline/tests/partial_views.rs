//! One camera's view of an object becomes the right solid: caps of a sphere and z-buffer scans
//! of the bundled shapes, completed from the viewpoint, against the volume of the whole object.

use crate::geometry::{
    bundled, capsule_mesh, complete_view, scan_points, sdf_mesh, Camera, Completion,
    CompletionError, Shape,
};
use crate::pipeline::{BodyOptions, SoftBody, Support};
use crate::skinning::NeuralModel;
use nalgebra::Vector3;

/// The volume enclosed by a closed, outward-wound mesh (divergence theorem).
fn mesh_volume(shape: &Shape) -> f64 {
    (0..shape.triangles.len())
        .map(|t| {
            let [a, b, c] = shape.triangle(t);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

/// Free bodies: nothing holds them, so the volume is the whole body's.
fn free_options() -> BodyOptions {
    BodyOptions {
        support: Support::Free,
        ..BodyOptions::default()
    }
}

/// The body the pipeline builds from `points` seen from `viewpoint`, and what its completion
/// did (None: no completion).
fn built_body(points: &[Vector3<f64>], viewpoint: &Vector3<f64>) -> (SoftBody, Option<Completion>) {
    let options = free_options();
    let model = NeuralModel::bundled().unwrap();
    let completed = complete_view(points, viewpoint, None).expect("completable");
    let body = match &completed {
        Some(view) => SoftBody::build_view(&model, view, points, &options),
        None => {
            let shape = Shape::new(points.to_vec(), None, Vec::new()).unwrap();
            SoftBody::build(&model, &shape, points, &options)
        }
    }
    .unwrap();
    println!("  {}", body.decision());
    (body, completed.map(|c| c.report))
}

/// The volume of the body the pipeline builds from `points` seen from `viewpoint`, and the
/// completion's observed fraction (None: no completion).
fn built_volume(points: &[Vector3<f64>], viewpoint: &Vector3<f64>) -> (f64, Option<f64>) {
    let (body, report) = built_body(points, viewpoint);
    let volume = body.mass() / free_options().sim.density;
    (volume, report.map(|r| r.observed_fraction))
}

/// The two sides `bench real` scans from.
const REAL_BENCH_SIDES: [Vector3<f64>; 2] =
    [Vector3::new(1.0, 0.6, 0.8), Vector3::new(-0.7, 1.0, 0.5)];

/// The camera scanning `shape` from `direction` as `bench real` does (160 x 120, 1.5 bounding
/// diagonals away), and the body built from its completed scan.
fn scanned_body(shape: &Shape, direction: Vector3<f64>) -> (Camera, SoftBody) {
    let camera = Camera::looking_at(shape, direction, 1.5, 160, 120);
    let points = scan_points(shape, &camera).unwrap();
    let (body, report) = built_body(&points, &camera.position);
    assert!(report.is_some(), "a scan is completed");
    (camera, body)
}

/// A torus: a 0.04 m tube round a 0.1 m ring, about the z axis.
fn ring() -> Shape {
    let (ring, tube) = (0.1, 0.04);
    sdf_mesh(
        &|p: &Vector3<f64>| {
            let around = (p.x * p.x + p.y * p.y).sqrt() - ring;
            (around * around + p.z * p.z).sqrt() - tube
        },
        0.16,
        48,
    )
}

/// `count` points spread evenly over the sphere of `radius` (a Fibonacci lattice).
fn sphere_points(radius: f64, count: usize) -> Vec<Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            Vector3::new(r * phi.cos(), r * phi.sin(), z) * radius
        })
        .collect()
}

#[test]
fn caps_of_a_ball_become_a_ball() {
    let radius: f64 = 0.1;
    let truth = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    let viewpoint = Vector3::new(0.0, 0.0, 0.52);
    let sphere = sphere_points(radius, 9000);
    let (whole, none) = built_volume(&sphere, &viewpoint);
    println!("whole: {:.3} of the ball's volume", whole / truth);
    assert!(none.is_none(), "a whole sphere needs no completion");
    // The camera-facing half and third (caps of height r and 2r/3).
    for height in [radius, 2.0 * radius / 3.0] {
        let cap: Vec<_> = sphere
            .iter()
            .filter(|p| p.z > radius - height)
            .cloned()
            .collect();
        let (volume, observed) = built_volume(&cap, &viewpoint);
        println!(
            "cap of height {height:.3}: {} points, {:.3} of the ball's volume, observed {:?}",
            cap.len(),
            volume / truth,
            observed
        );
        assert!(observed.is_some(), "a cap is completed");
        assert!(
            (volume / truth - 1.0).abs() <= 0.3,
            "the cap of height {height} became {:.3} of the ball",
            volume / truth
        );
    }
}

#[test]
fn scans_of_the_bundled_shapes_have_their_volume() {
    let ball = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 40);
    let shapes = [
        ("ball", ball),
        ("box", bundled("box").unwrap()),
        ("creature", bundled("creature").unwrap()),
        ("rod", bundled("rod").unwrap()),
        ("bottle", capsule_mesh(0.3, 0.04)),
    ];
    for (name, shape) in shapes {
        let truth = mesh_volume(&shape);
        let whole = {
            let model = NeuralModel::bundled().unwrap();
            let options = BodyOptions::default();
            let body = SoftBody::build(&model, &shape, &shape.positions, &options).unwrap();
            body.mass() / options.sim.density
        };
        println!(
            "{name}: the whole mesh's body has {:.3} of the volume",
            whole / truth
        );
        for direction in [Vector3::new(1.0, 0.6, 0.8), Vector3::new(-0.7, 1.0, 0.5)] {
            let camera = Camera::looking_at(&shape, direction, 1.5, 240, 180);
            let points = scan_points(&shape, &camera).unwrap();
            let (volume, observed) = built_volume(&points, &camera.position);
            println!(
                "{name} from {direction:?}: {} points, {:.3} of the volume, observed {observed:?}",
                points.len(),
                volume / truth
            );
            assert!(observed.is_some(), "{name}: a scan is completed");
            assert!(
                (volume / truth - 1.0).abs() <= 0.3,
                "{name} seen from {direction:?} became {:.3} of its volume",
                volume / truth
            );
        }
    }
}

#[test]
fn flat_patches_and_few_points_are_refused_with_their_reason() {
    let viewpoint = Vector3::new(0.0, 0.0, 1.0);
    // The top of a plate: one view of a flat patch.
    let patch: Vec<_> = (0..40)
        .flat_map(|i| {
            (0..30).map(move |j| {
                Vector3::new(
                    i as f64 * 0.01,
                    j as f64 * 0.01,
                    0.001 * ((i + j) % 2) as f64,
                )
            })
        })
        .collect();
    let flat = complete_view(&patch, &viewpoint, None)
        .err()
        .expect("refused");
    assert!(matches!(flat, CompletionError::FlatPatch { .. }), "{flat}");
    assert!(flat.to_string().contains("flat patch"), "{flat}");
    // A cap of a ball with too few points.
    let cap: Vec<_> = sphere_points(0.1, 300)
        .into_iter()
        .filter(|p| p.z > 0.0)
        .collect();
    let few = complete_view(&cap, &Vector3::new(0.0, 0.0, 0.5), None)
        .err()
        .expect("refused");
    assert_eq!(few, CompletionError::TooFewPoints { count: cap.len() });
}

#[test]
fn collinear_coplanar_and_zero_area_inputs_are_refused() {
    let line: Vec<_> = (0..4)
        .map(|i| Vector3::new(i as f64 * 0.1, 0.0, 0.0))
        .collect();
    let plane: Vec<_> = (0..100)
        .map(|i| Vector3::new((i % 10) as f64 * 0.1, (i / 10) as f64 * 0.1, 0.0))
        .collect();
    for (points, triangles, why) in [
        (line.clone(), vec![], "one line"),
        (plane, vec![], "one plane"),
        (
            vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()],
            vec![[0, 0, 1], [2, 2, 2], [1, 3, 1]],
            "no area",
        ),
    ] {
        let shape = Shape::new(points, None, triangles).unwrap();
        let e = shape.check_solid().expect_err("refused").to_string();
        assert!(e.contains(why), "{e}");
    }
}

/// A ring seen from above shows its hole: nothing lies in front of its centre, and its breadth
/// (its outer diameter) says nothing of how deep it is. Completed, it keeps about its volume
/// and its depth stays near its tube's thickness.
#[test]
fn a_ring_seen_through_its_hole_is_not_as_deep_as_it_is_broad() {
    let torus = ring();
    let truth = mesh_volume(&torus);
    let camera = Camera::looking_at(&torus, Vector3::new(0.3, 0.4, 1.0), 1.5, 240, 180);
    let points = scan_points(&torus, &camera).unwrap();
    let (body, report) = built_body(&points, &camera.position);
    let report = report.expect("one side's view");
    let volume = body.mass() / free_options().sim.density;
    println!(
        "ring from above: {} points, depth {:.3} m, {:.3} of its volume",
        points.len(),
        report.depth,
        volume / truth
    );
    // Seen 27 degrees off its axis, the ring spans about 2 (tube + ring sin 27) = 0.17 m along
    // the view, its centre about half that behind its nearest point; with its breadth's floor
    // (0.28 m across) the completion was 0.252 m deep and 2.441 times its volume.
    assert!(report.depth < 0.2, "depth {:.3} m", report.depth);
    assert!(
        (volume / truth - 1.0).abs() <= 0.3,
        "the ring became {:.3} of its volume",
        volume / truth
    );
}

/// A long object's completion is as symmetric about its centre as the prior: the rod's far end,
/// where pixels are fewest and nothing of the near end is reflected into the outline, is not
/// left short, so the body's centre of mass lies at the rod's middle. It lies round the rod's
/// axis too: the axis is fitted to the surface seen across the middle, not placed behind the
/// ridge by the outline's width, which pixels a pitch apart sample short.
#[test]
fn a_scanned_rod_keeps_its_mass_at_its_middle_and_round_its_axis() {
    let rod = bundled("rod").unwrap();
    let (lo, hi) = rod.bounds();
    let middle = (lo + hi) / 2.0;
    let axis = Vector3::x();
    for direction in REAL_BENCH_SIDES {
        let (camera, body) = scanned_body(&rod, direction);
        let grid = body.solid();
        let offset = grid.solid_centroid() - middle;
        let along = offset.dot(&axis);
        let across = offset - axis * along;
        let forward = (middle - camera.position).normalize();
        println!(
            "rod from {direction:?}: centre of mass {along:.4} m along its axis from its middle ({} cells of {:.4} m), {:.4} m off its axis, {:.4} m of that along the view",
            grid.solid_count(),
            grid.cell,
            across.norm(),
            across.dot(&forward)
        );
        assert!(along.abs() < 0.5 * grid.cell, "{along:.4} m off");
        assert!(across.norm() < 0.001, "{:.4} m off its axis", across.norm());
    }
}

/// A scanned box's body lies across the view where the box does: the rim's centroid is taken
/// per length of rim, not per pixel, which leaned towards the edges nearest the camera.
#[test]
fn a_scanned_box_is_centred_across_the_view() {
    let block = bundled("box").unwrap();
    let (lo, hi) = block.bounds();
    let (middle, diagonal) = ((lo + hi) / 2.0, (hi - lo).norm());
    for direction in REAL_BENCH_SIDES {
        let (camera, body) = scanned_body(&block, direction);
        let offset = body.solid().solid_centroid() - middle;
        let forward = (middle - camera.position).normalize();
        let across = (offset - forward * offset.dot(&forward)).norm();
        println!(
            "box from {direction:?}: centre of mass {across:.4} m across the view from the box's, {:.4} m along it",
            offset.dot(&forward)
        );
        // 0.0045 m and 0.0028 m; taken per pixel, 0.0212 m from the first side (printed).
        assert!(
            across < 0.02 * diagonal,
            "{across:.4} m off across the view"
        );
    }
}

/// A ring seen almost edge-on has a long outline, but the band across its middle reaches from
/// its near side to its far one: it is not a rod, and is not completed round across an axis.
#[test]
fn a_ring_seen_edge_on_is_not_taken_for_a_rod() {
    let torus = ring();
    let truth = mesh_volume(&torus);
    for (width, height) in [(160, 120), (240, 180)] {
        let camera = Camera::looking_at(&torus, Vector3::new(1.0, 0.1, 0.2), 1.5, width, height);
        let points = scan_points(&torus, &camera).unwrap();
        let (volume, _) = built_volume(&points, &camera.position);
        println!(
            "ring edge-on at {width} x {height}: {} points, {:.3} of its volume",
            points.len(),
            volume / truth
        );
        // Completed round across its long outline, it made 0.795 and 0.832 of its volume.
        assert!(
            (volume / truth - 1.0).abs() <= 0.1,
            "the ring seen edge-on at {width} x {height} became {:.3} of its volume",
            volume / truth
        );
    }
}

/// The volume of the body built from `shape` scanned from `direction` (as `bench real` scans:
/// 160 x 120, 1.5 bounding diagonals away), over `truth`.
fn scanned_volume_ratio(shape: &Shape, truth: f64, direction: Vector3<f64>) -> f64 {
    let camera = Camera::looking_at(shape, direction, 1.5, 160, 120);
    let points = scan_points(shape, &camera).unwrap();
    let (volume, _) = built_volume(&points, &camera.position);
    println!(
        "seen from {direction:?}: {} points, {:.3} of its volume",
        points.len(),
        volume / truth
    );
    volume / truth
}

/// `shape` (`what`, for the message) scanned from each of `directions` as `bench real` scans
/// is built within `tolerance` of its volume.
fn assert_volume_from(shape: &Shape, what: &str, directions: &[Vector3<f64>], tolerance: f64) {
    let truth = mesh_volume(shape);
    for &direction in directions {
        let ratio = scanned_volume_ratio(shape, truth, direction);
        assert!(
            (ratio - 1.0).abs() <= tolerance,
            "{what} seen from {direction:?} became {ratio:.3} of its volume"
        );
    }
}

/// An ellipsoid turned from every coordinate axis, semi-axes `radii`: its outline is long
/// from many sides, and its section across that axis is an ellipse, not a circle.
fn turned_ellipsoid(radii: [f64; 3], turn: (f64, f64, f64)) -> Shape {
    let turned = nalgebra::Rotation3::from_euler_angles(turn.0, turn.1, turn.2).inverse();
    let smallest = radii.iter().cloned().fold(f64::INFINITY, f64::min);
    sdf_mesh(
        &move |p: &Vector3<f64>| {
            let q = turned * p;
            (Vector3::new(q.x / radii[0], q.y / radii[1], q.z / radii[2]).norm() - 1.0) * smallest
        },
        radii.iter().cloned().fold(0.0, f64::max) * 1.25,
        48,
    )
}

/// Long outlines whose section is elliptic keep their depth: completed round across their
/// axis, `bench views`' turned ellipsoid (0.16, 0.09, 0.06 m) had been 0.537 to 0.728 of its
/// volume from two sides. Checked on two others, turned otherwise, not tuned on.
#[test]
fn a_long_elliptic_object_keeps_its_depth() {
    let shapes = [
        ([0.16, 0.09, 0.06], (0.3, 0.2, 0.5)),
        ([0.15, 0.05, 0.08], (-0.4, 0.3, 1.1)),
        ([0.12, 0.07, 0.045], (0.9, -0.2, 0.1)),
    ];
    for (radii, turn) in shapes {
        assert_volume_from(
            &turned_ellipsoid(radii, turn),
            &format!("the ellipsoid {radii:?}"),
            &[Vector3::new(-0.7, 1.0, 0.5), Vector3::new(0.2, -1.0, 0.3)],
            0.3,
        );
    }
}

/// A box turned from every coordinate axis, seen with two or three faces, is completed to its
/// own extents. Centred on its rim, `bench views`' turned box (another) seen from (0.3, 0.4, 1)
/// had been completed 1.426 and 1.472 times its volume (printed). This one from (0.3, 0.4, 1),
/// its second face seen edge-on, completes to 0.85 of its volume (0.851 with every point's
/// normals, 0.849 with the fit's 2000 thinned points): within 20 %, the others within 15 %.
#[test]
fn a_turned_box_seen_from_two_faces_keeps_its_volume() {
    let turn = nalgebra::Rotation3::from_euler_angles(-0.2, 0.5, 0.9).inverse();
    let half = Vector3::new(0.1, 0.07, 0.045);
    let shape = sdf_mesh(
        &move |p: &Vector3<f64>| {
            let q = (turn * p).abs() - half;
            q.map(|x| x.max(0.0)).norm() + q.max().min(0.0)
        },
        0.15,
        48,
    );
    for (direction, tolerance) in [
        (Vector3::new(1.0, 0.6, 0.8), 0.15),
        (Vector3::new(0.3, 0.4, 1.0), 0.2),
    ] {
        assert_volume_from(&shape, "the turned box", &[direction], tolerance);
    }
}

/// A block seen from one side, standing on a known floor, rests on its whole completed bottom:
/// the points the camera saw settle by about the FEM's sag under its weight (0.38 mm in `bench
/// track`), instead of sinking until enough of an uneven bottom's lowest points carry it (0.390
/// mm, and 0.763 mm with the bottom as completed, printed).
#[test]
fn a_scanned_block_on_the_floor_rests_on_its_whole_bottom() {
    let mut block = crate::geometry::box_mesh(Vector3::new(0.24, 0.16, 0.12));
    block.positions.iter_mut().for_each(|p| p.z += 0.06);
    let camera = Camera::looking_at(&block, Vector3::new(1.0, 0.6, 0.8), 1.5, 160, 120);
    let points = scan_points(&block, &camera).unwrap();
    let options = BodyOptions {
        support: Support::Floor,
        floor_z: Some(0.0),
        ..BodyOptions::default()
    };
    let model = NeuralModel::bundled().unwrap();
    let view = complete_view(&points, &camera.position, Some(0.0))
        .unwrap()
        .expect("a scan is completed");
    let mut body = SoftBody::build_view(&model, &view, &points, &options).unwrap();
    for _ in 0..30 {
        body.step();
    }
    let sink = points
        .iter()
        .zip(body.deformed().chunks_exact(3))
        .map(|(p, q)| p.z - q[2] as f64)
        .sum::<f64>()
        / points.len() as f64;
    println!("the seen points sank {:.3} mm", 1e3 * sink);
    assert!(sink < 5e-4, "sank {:.3} mm", 1e3 * sink);
}

/// A six-legged body (an ellipsoid with three pairs of legs, 1 cm thick, spread sideways and
/// down): its outline is mostly legs, from any side.
fn insect() -> Shape {
    let capsule = |p: &Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>, r: f64| {
        let ab = b - a;
        let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
        (p - a - ab * t).norm() - r
    };
    sdf_mesh(
        &move |p: &Vector3<f64>| {
            let body = (Vector3::new(p.x / 0.1, p.y / 0.035, p.z / 0.03).norm() - 1.0) * 0.03;
            let legs = [-0.06, 0.0, 0.06].iter().flat_map(|&x| {
                [-1.0, 1.0].map(|side: f64| {
                    let hip = Vector3::new(x, side * 0.02, 0.0);
                    let knee = Vector3::new(x * 1.6, side * 0.1, 0.03);
                    let foot = Vector3::new(x * 2.0, side * 0.16, -0.05);
                    capsule(p, hip, knee, 0.01).min(capsule(p, knee, foot, 0.008))
                })
            });
            legs.fold(body, f64::min)
        },
        0.2,
        64,
    )
}

/// A body with limbs is as deep as its limbs are thick, not as its outline is broad (see
/// `completion::midsurface`): reflected through one centre, with the coarse fill behind its
/// near legs, this one had been built 2.666, 5.922 and 2.225 times its volume from these
/// sides, now 1.014, 0.952 and 1.374 (printed); `bench views`' ant, 1.5 to 3.2 times.
#[test]
fn a_body_with_legs_is_as_deep_as_its_legs() {
    let shape = insect();
    let sides = [
        Vector3::new(1.0, 0.6, 0.8),
        Vector3::new(0.3, 0.4, 1.0),
        Vector3::new(-0.7, 1.0, 0.5),
    ];
    assert_volume_from(&shape, "the insect", &sides, 0.4);
    // And the completion says so.
    let camera = Camera::looking_at(&shape, Vector3::new(1.0, 0.6, 0.8), 1.5, 160, 120);
    let points = scan_points(&shape, &camera).unwrap();
    let view = complete_view(&points, &camera.position, None).unwrap();
    assert_eq!(view.expect("completed").report.prior.name(), "limbs");
}

/// A long block with rounded edges, seen with its broad face nearly square to the camera, is
/// completed to its box, not round across its long axis: this one had been built 1.221 times
/// its volume from the first side, now 0.856 and 0.845 (printed); `bench views`' golf club head
/// (a block 0.47 x 0.11 x 0.15 m), 1.48 to 1.70 times from two sides.
#[test]
fn a_long_block_is_not_taken_round() {
    let (half, round) = (Vector3::new(0.2, 0.045, 0.06), 0.012);
    let shape = sdf_mesh(
        &move |p: &Vector3<f64>| {
            let q = p.abs() - half + Vector3::repeat(round);
            q.map(|x| x.max(0.0)).norm() + q.max().min(0.0) - round
        },
        0.22,
        64,
    );
    let sides = [Vector3::new(-0.7, 1.0, 0.5), Vector3::new(0.2, -1.0, 0.3)];
    assert_volume_from(&shape, "the block", &sides, 0.2);
}
