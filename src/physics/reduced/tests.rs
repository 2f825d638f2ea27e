//! Unit tests of the reduced solver's contact curvature (by blocks, and held through a turn),
//! held-matrix turn and refresh rule.

use nalgebra::{DMatrix, DVector, Vector3};

use super::curvature::Springs;
use super::held::{held_lower, turn_blocks};
use crate::linalg::tangents;
use crate::linalg::DenseCholesky;
use rand::{Rng, SeedableRng};

/// d(n . x)/dz for x = X + Z phi: the flat vector phi (x) n.
fn point_jacobian(phi: &DVector<f64>, n: &Vector3<f64>) -> DVector<f64> {
    DVector::from_fn(3 * phi.len(), |i, _| phi[i / 3] * n[i % 3])
}

fn random_vector(rng: &mut impl Rng, n: usize) -> DVector<f64> {
    DVector::from_fn(n, |_, _| rng.random::<f64>() * 2.0 - 1.0)
}

/// Contact springs on `points` random points (4K = `n4`), each along a direction drawn from
/// `directions` (all random when empty) and every other one with friction across it: the
/// springs and the sum of their rank-one terms.
fn random_springs(
    rng: &mut impl Rng,
    n4: usize,
    points: usize,
    directions: &[Vector3<f64>],
) -> (DMatrix<f64>, Springs, DMatrix<f64>) {
    let phis = DMatrix::from_fn(n4, points, |_, _| rng.random::<f64>() * 2.0 - 1.0);
    let mut springs = Springs::default();
    let mut expected = DMatrix::zeros(3 * n4, 3 * n4);
    for i in 0..points {
        let phi = phis.column(i).into_owned();
        let n = if directions.is_empty() {
            Vector3::new(rng.random(), rng.random(), rng.random()).normalize()
        } else {
            directions[i % directions.len()]
        };
        let s = 1e7 * rng.random::<f64>();
        springs.add_along(i, s, &n);
        let a = point_jacobian(&phi, &n);
        expected.ger(s, &a, &a, 1.0);
        if i % 2 == 0 {
            let t = tangents(&n);
            springs.add_across(i, 0.5 * s, &t);
            for t in &t {
                let a = point_jacobian(&phi, t);
                expected.ger(0.5 * s, &a, &a, 1.0);
            }
        }
    }
    (phis, springs, expected)
}

/// The contact curvature, grouped by direction (a floor, two fingers) or by pairs of axes
/// (springs pointing anywhere), equals the sum of its springs' rank-one terms, and the
/// preconditioner factored from it solves as a fresh factorization of the whole matrix does.
#[test]
fn contact_curvature_matches_rank_one_terms() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let n4 = 4 * 5;
    let floor = [Vector3::z()];
    let fingers = [Vector3::x(), -Vector3::x(), Vector3::new(0.0, 0.6, 0.8)];
    for directions in [&floor[..], &fingers[..], &[]] {
        let (phis, springs, expected) = random_springs(&mut rng, n4, 40, directions);
        // Friction's normals merge with the contact normals: one group per direction.
        let groups = springs.by_direction().map(|groups| groups.len());
        let expected_groups = (!directions.is_empty()).then_some(directions.len());
        assert_eq!(groups, expected_groups, "directions {directions:?}");
        let curvature = springs.curvature(&phis);
        assert!((&curvature - &expected).amax() <= 1e-9 * expected.amax());
        let base = DMatrix::from_diagonal_element(3 * n4, 3 * n4, 1e3);
        let rhs = random_vector(&mut rng, 3 * n4);
        let solve = |m: &DMatrix<f64>| {
            let mut x = rhs.clone();
            DenseCholesky::new(m.as_slice(), m.nrows())
                .expect("positive definite")
                .solve(x.as_mut_slice());
            x
        };
        let (fresh, held) = (solve(&(&base + &expected)), solve(&(&base + &curvature)));
        assert!((&held - &fresh).norm() <= 1e-9 * fresh.norm());
    }
}

/// Turning every block by R is the congruence by I (x) R: a quadratic form evaluated at
/// (I (x) R) v gives what the original gives at v.
#[test]
fn turned_blocks_are_the_rotated_quadratic_form() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    let n = 3 * 6;
    let a = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>());
    let h = &a * a.transpose();
    let r = *nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -1.1, 0.7)).matrix();
    let turned = turn_blocks(&h, &r);
    let v = random_vector(&mut rng, n);
    let mut rv = v.clone();
    for b in 0..n / 3 {
        let turned_block = r * Vector3::new(v[3 * b], v[3 * b + 1], v[3 * b + 2]);
        rv.fixed_rows_mut::<3>(3 * b).copy_from(&turned_block);
    }
    let (original, rotated) = (v.dot(&(&h * &v)), rv.dot(&(&turned * &rv)));
    assert!((original - rotated).abs() <= 1e-12 * original.abs());
}

/// The matrix a refactor factors is, in its lower triangle, the held matrix's blocks turned
/// plus Q (x) I, and zero above it; unturned, the held matrix itself plus Q (x) I.
#[test]
fn the_held_matrix_turned_in_one_pass_is_its_turned_blocks_plus_the_quadratic_part() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let n4 = 6;
    let a = DMatrix::from_fn(3 * n4, 3 * n4, |_, _| rng.random::<f64>());
    let h = &a * a.transpose();
    let b = DMatrix::from_fn(n4, n4, |_, _| rng.random::<f64>());
    let q = &b * b.transpose();
    let mut q_kron = DMatrix::zeros(3 * n4, 3 * n4);
    for (i, j) in (0..n4).flat_map(|i| (0..n4).map(move |j| (i, j))) {
        for d in 0..3 {
            q_kron[(3 * i + d, 3 * j + d)] = q[(i, j)];
        }
    }
    let r = *nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.3, -1.1, 0.7)).matrix();
    for (turn, expected) in [
        (r, turn_blocks(&h, &r) + &q_kron),
        (nalgebra::Matrix3::identity(), &h + &q_kron),
    ] {
        let lower = held_lower(&h, &turn, &q);
        for (i, j) in (0..3 * n4).flat_map(|i| (0..3 * n4).map(move |j| (i, j))) {
            if i / 3 >= j / 3 {
                assert!((lower[(i, j)] - expected[(i, j)]).abs() <= 1e-12 * expected.amax());
            } else {
                assert_eq!(lower[(i, j)], 0.0, "above the block diagonal");
            }
        }
    }
}

/// The refresh waits at most `REFRESH_GRACE` iterations, and only for a solve whose decrement
/// falls fast enough to reach the tolerance in that many.
#[test]
fn refresh_waits_only_for_a_solve_about_to_converge() {
    use super::held::refresh_due;
    use super::{REFRESH_AFTER_ITERATIONS as AFTER, REFRESH_GRACE as GRACE};
    let tolerance = 1e-5;
    // Falling tenfold an iteration to 2.7e-4: 2.7e-6 after two more.
    let fast: Vec<f64> = (0..AFTER)
        .map(|i| 2.7e-4 * 10f64.powi((AFTER - 1 - i) as i32))
        .collect();
    // Halving from 0.1: 9.8e-5 now (after 11), 2.4e-5 after two more.
    let slow: Vec<f64> = (0..AFTER).map(|i| 0.1 / 2f64.powi(i as i32)).collect();
    assert!(!refresh_due(AFTER, &fast, tolerance));
    assert!(refresh_due(AFTER, &slow, tolerance));
    assert!(refresh_due(AFTER, &[], tolerance), "no decrements: refresh");
    assert!(!refresh_due(AFTER - 1, &slow, tolerance));
    assert!(
        refresh_due(AFTER + GRACE, &fast, tolerance),
        "the grace ends"
    );
    assert!(!refresh_due(AFTER + GRACE - 1, &fast, tolerance));
}

/// A 0.4 x 0.2 x 0.1 m box on a grid 8 cells across: its tet mesh, a two-mode eigenmode field
/// and 64 cubature points, the small body of the solver's unit tests.
struct SmallBox {
    shape: crate::geometry::Shape,
    mesh: crate::geometry::TetMesh,
    field: std::sync::Arc<crate::skinning::EigenmodeField>,
    cubature: crate::geometry::Cubature,
}

impl SmallBox {
    fn new() -> Self {
        use crate::geometry::{box_mesh, Cubature, TetMesh, VoxelGrid};
        use crate::skinning::{EigenmodeField, EigenmodeOptions};

        let shape = box_mesh(Vector3::new(0.4, 0.2, 0.1));
        let grid = VoxelGrid::from_shape(&shape, 64, None).resample(8);
        let mesh = TetMesh::from_grid(&grid);
        let options = EigenmodeOptions {
            modes: 2,
            ..Default::default()
        };
        let field = EigenmodeField::compute(mesh.clone(), shape.normalization(), &options).unwrap();
        let cubature = Cubature::stratified(&grid, 64, mesh.volume());
        Self {
            shape,
            mesh,
            field: std::sync::Arc::new(field),
            cubature,
        }
    }

    /// A quasi-Newton simulation of `subspace` with `params`, its tolerance taken on the box's
    /// diagonal.
    fn quasi_newton(
        &self,
        subspace: std::sync::Arc<crate::physics::Subspace>,
        params: crate::physics::SimParams,
    ) -> crate::physics::ReducedSim {
        let diagonal = 0.46;
        let solver = crate::physics::Solver::QuasiNewton;
        crate::physics::ReducedSim::new(subspace, params, solver, diagonal).unwrap()
    }

    /// The mesh vertices of the box's -x end (the last 5 cm), to pin.
    fn left_end(&self) -> Vec<Vector3<f64>> {
        let vertices = self.mesh.vertices.iter();
        vertices.filter(|v| v.x < -0.15).cloned().collect()
    }

    /// A new subspace of the box's field at its cubature (density 1000 kg/m^3).
    fn subspace(&self) -> std::sync::Arc<crate::physics::Subspace> {
        let map = self.shape.normalization();
        let field = self.field.clone();
        std::sync::Arc::new(crate::physics::Subspace::build(
            field,
            map,
            &self.cubature,
            1000.0,
        ))
    }
}

/// A body turned on the floor about the vertical keeps the same springs: its preconditioner is
/// refactored for the turn with the contact curvature it holds, which equals the one made
/// afresh at the turned state.
#[test]
fn a_body_turned_on_the_same_springs_reuses_its_contact_curvature() {
    use crate::physics::{Obstacle, SimParams};

    let body = SmallBox::new();
    let (mesh, subspace) = (&body.mesh, body.subspace());
    let params = SimParams {
        friction: 0.0,
        ..Default::default()
    };
    let mut sim = body.quasi_newton(subspace.clone(), params);
    let areas = vec![1e-3; mesh.vertices.len()];
    sim.add_contact_points(&mesh.vertices, &areas);
    // The bottom face 1 mm below the floor: its points touch, the others are far above it.
    sim.add_obstacle(Obstacle::floor(-0.049));
    sim.prepare();
    let turned_by = |angle: f64| {
        let turn = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), angle);
        subspace.rigid_state(turn.matrix(), &Vector3::zeros())
    };
    let (before, after) = (turned_by(0.0), turned_by(0.01));
    sim.find_candidates(&before);
    sim.hold_at(&before);
    let held_before = sim.held_contact.clone().expect("held");
    assert!(
        !held_before.0.touching.is_empty(),
        "the bottom face touches"
    );
    let factorizations = sim.factorizations;
    sim.find_candidates(&after);
    sim.hold_at(&after);
    assert_eq!(
        sim.factorizations,
        factorizations + 1,
        "refactored for the turn"
    );
    let (signature, held) = sim.held_contact.clone().expect("held");
    assert_eq!(signature, held_before.0, "the same springs");
    let fresh = sim
        .curvature_of(&sim.touching_at(&after))
        .expect("touching");
    let held = held.expect("touching");
    assert!((&held - &fresh).amax() <= 1e-12 * fresh.amax());
}

/// A box lifted off the floor between steps (its bottom face's springs all lost): at a step's
/// start the factor keeps them (`hold_for_step`), within a solve it is made without them.
#[test]
fn springs_lost_at_a_steps_start_stay_in_the_factor() {
    use crate::physics::{Obstacle, SimParams};

    let body = SmallBox::new();
    let (mesh, subspace) = (&body.mesh, body.subspace());
    let params = SimParams {
        friction: 0.0,
        ..Default::default()
    };
    let mut sim = body.quasi_newton(subspace.clone(), params);
    sim.add_contact_points(&mesh.vertices, &vec![1e-3; mesh.vertices.len()]);
    sim.add_obstacle(Obstacle::floor(-0.049));
    sim.prepare();
    let turn = nalgebra::Matrix3::identity();
    let at_rest = subspace.rigid_state(&turn, &Vector3::zeros());
    let lifted = subspace.rigid_state(&turn, &Vector3::new(0.0, 0.0, 0.002));
    sim.find_candidates(&at_rest);
    sim.hold_at(&at_rest);
    let held = sim.factored_contact.clone().expect("factored");
    assert!(!held.touching.is_empty(), "the bottom face touches");
    sim.find_candidates(&lifted);
    assert!(sim.touching_at(&lifted).is_empty(), "lifted off");
    let factorizations = sim.factorizations;
    assert!(!sim.hold_for_step(&lifted), "kept at a step's start");
    assert_eq!(sim.factorizations, factorizations);
    assert_eq!(sim.factored_contact.as_ref(), Some(&held));
    assert!(sim.hold_at(&lifted), "made anew within a solve");
    assert!(sim
        .factored_contact
        .as_ref()
        .expect("factored")
        .touching
        .is_empty());
    // Springs gained at a step's start count: back on the floor, it is made with them.
    assert!(sim.hold_for_step(&at_rest));
}

/// A box rocking off one end of its bottom face: the springs lost and the turn are updates of
/// the factor held, not a factorization, and it solves as the factor made afresh for the same
/// state does, to 1e-9 relative.
#[test]
fn a_body_rocking_on_the_floor_updates_its_factor_as_a_fresh_one_would_be() {
    use crate::physics::{Obstacle, ReducedSim, SimParams};

    let body = SmallBox::new();
    let subspace = body.subspace();
    let params = SimParams {
        friction: 0.0,
        ..Default::default()
    };
    // The bottom face's corners and two points between them, all 1 mm below the floor.
    let points: Vec<Vector3<f64>> = [(-0.2, -0.1), (-0.2, 0.1), (0.2, -0.1), (0.2, 0.1)]
        .into_iter()
        .chain([(-0.1, 0.0), (0.1, 0.0)])
        .map(|(x, y)| Vector3::new(x, y, -0.05))
        .collect();
    // Pinned by a top corner or free: a pinned body's springs are restricted to the
    // directions its pins leave free, as its factored matrix is.
    for pinned in [false, true] {
        let make = || {
            let mut sim = body.quasi_newton(subspace.clone(), params.clone());
            sim.add_contact_points(&points, &vec![1e-3; points.len()]);
            sim.add_obstacle(Obstacle::floor(-0.049));
            if pinned {
                sim.add_pins(&[Vector3::new(-0.2, -0.1, 0.05)], &[0.1]);
            }
            sim.prepare();
            sim
        };
        let at_rest = subspace.rigid_state(&nalgebra::Matrix3::identity(), &Vector3::zeros());
        // Tilted 0.015 rad about y: the points at x > 0 rise off the floor, the others stay in.
        let tilt = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), 0.015);
        let rocked = subspace.rigid_state(tilt.matrix(), &Vector3::zeros());
        let (mut updated, mut fresh) = (make(), make());
        for sim in [&mut updated, &mut fresh] {
            sim.find_candidates(&at_rest);
            sim.hold_at(&at_rest);
            assert_eq!(sim.touching_at(&at_rest).len(), 6, "the whole face touches");
            sim.find_candidates(&rocked);
        }
        assert_eq!(updated.touching_at(&rocked).len(), 3, "one end lifted");
        let (factorizations, updates) = (updated.factorizations, updated.factor_updates);
        assert!(updated.hold_at(&rocked), "the factor changed");
        assert_eq!(updated.factorizations, factorizations, "no factorization");
        assert_eq!(updated.factor_updates, updates + 1);
        // The same state from scratch: the factor is made anew.
        fresh.factored_contact = None;
        fresh.hold_at(&rocked);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        for _ in 0..3 {
            // The solver's right-hand sides (gradients) have no part along held directions.
            let mut rhs = random_vector(&mut rng, 3 * 4 * subspace.handles());
            if let Some(pinning) = updated.pinning.as_ref() {
                pinning.free_vector(&mut rhs);
            }
            let solve = |sim: &ReducedSim| {
                let mut x = rhs.clone();
                sim.preconditioner
                    .as_ref()
                    .expect("factored")
                    .solve(x.as_mut_slice());
                x
            };
            let (x, y) = (solve(&updated), solve(&fresh));
            assert!(
                (&x - &y).norm() <= 1e-9 * y.norm(),
                "{}",
                (&x - &y).norm() / y.norm()
            );
        }
    }
}

/// A rebased body's preconditioner holds the new subspace's rest Hessian, the one the subspace
/// keeps, and a twin prepared with the body's setup comes in as it was prepared (its factor
/// made off the stepping thread, its pins' targets taken over); one whose pins differ from the
/// body's now is set up anew. Either goes on stepping and converging.
#[test]
fn a_rebased_body_takes_its_prepared_twin_or_sets_one_up_anew() {
    use crate::physics::{ReducedSim, SimParams};

    let body = SmallBox::new();
    let build = || body.subspace();
    let params = SimParams::default();
    let mut sim = body.quasi_newton(build(), params.clone());
    let pinned = body.left_end();
    sim.add_pins(&pinned, &vec![0.01; pinned.len()]);
    let setup = sim.setup();
    for _ in 0..5 {
        sim.step();
    }
    let identity = DMatrix::identity(4 * sim.subspace().handles(), 4 * sim.subspace().handles());
    // Prepared with the body's setup: taken as it is, its factor already made.
    let twin = ReducedSim::prepared_twin(build(), &setup).unwrap();
    let factorizations = twin.factorizations;
    let kept = twin.subspace().rest_elastic_hessian(&params.material());
    sim.rebase(twin, &identity, Vec::new()).unwrap();
    assert_eq!(
        sim.factorizations, factorizations,
        "no factorization at the switch"
    );
    assert_eq!(sim.held.as_ref().expect("held"), &*kept);
    for _ in 0..5 {
        assert!(sim.step().converged);
    }
    // A pin released since the twin was prepared: set up anew, the same rest Hessian held.
    let twin = ReducedSim::prepared_twin(build(), &sim.setup()).unwrap();
    assert_eq!(sim.release_pins_within(&pinned[0], 1e-9), 1);
    let kept = twin.subspace().rest_elastic_hessian(&params.material());
    sim.rebase(twin, &identity, Vec::new()).unwrap();
    assert_eq!(sim.pin_count(), pinned.len() - 1);
    assert_eq!(sim.held.as_ref().expect("held"), &*kept);
    for _ in 0..5 {
        assert!(sim.step().converged);
    }
}

/// A refresh asked for ahead of a step holds the elastic Hessian at the state that step
/// starts from (the constant-velocity prediction), not at the state the last step ended in:
/// a swinging body's Hessian changes within a step.
#[test]
fn a_refresh_ahead_holds_the_hessian_at_the_next_steps_start() {
    use super::hessian::HessianUse;
    use crate::physics::SimParams;

    let body = SmallBox::new();
    let subspace = body.subspace();
    let mut sim = body.quasi_newton(subspace.clone(), SimParams::default());
    sim.prepare();
    let k = subspace.handles();
    // Bent and moving: the last step ended in `now`, one step after `before`.
    let bent = |scale: f64| DMatrix::from_fn(3, 4 * k, |d, a| scale * ((d + 3 * a) as f64).sin());
    let (before, now) = (bent(0.02), bent(0.05));
    sim.set_state(now.clone(), Some(before.clone()));
    sim.refresh_due = true;
    assert_eq!(sim.refresh_if_due(), 1);
    let next_start = &now * 2.0 - &before;
    let expected = sim.held_elastic_at(&next_start, HessianUse::Refresh).matrix;
    let at_end = sim.held_elastic_at(&now, HessianUse::Refresh).matrix;
    let held = sim.held.as_ref().expect("refreshed");
    assert!((held - &expected).amax() <= 1e-12 * expected.amax());
    assert!(
        (&at_end - &expected).amax() > 1e-3 * expected.amax(),
        "the two states' Hessians differ, so the test tells them apart"
    );
    assert!((sim.held_rotation - subspace.mean_rotation(&next_start)).amax() < 1e-12);
}

/// A solve's pin watch answers as placing every pin would, along a path whose drift crosses
/// the tolerance both ways, and places the pins only where its bound cannot answer: not for a
/// small move from where it last placed them.
#[test]
fn the_pin_watch_answers_as_placing_every_pin_would() {
    use super::pins::PinWatch;
    use crate::physics::SimParams;

    let body = SmallBox::new();
    let subspace = body.subspace();
    let mut sim = body.quasi_newton(subspace.clone(), SimParams::default());
    let pinned = body.left_end();
    sim.add_pins(&pinned, &vec![0.01; pinned.len()]);
    let k = subspace.handles();
    let pattern = DMatrix::from_fn(3, 4 * k, |d, a| ((d + 3 * a) as f64 * 0.7).cos());
    let tolerance = 5e-3;
    let mut watch = PinWatch::default();
    let (mut inside, mut outside) = (0, 0);
    for t in (0..=80)
        .chain((0..80).rev())
        .map(|i| 2e-5 * (i as f64).powf(1.5))
    {
        let z = &pattern * t;
        let exact = sim.pins_within(&z, tolerance);
        assert_eq!(
            sim.pins_still_within(&z, tolerance, &mut watch),
            exact,
            "at t = {t}"
        );
        if exact {
            inside += 1
        } else {
            outside += 1
        }
    }
    assert!(
        inside > 10 && outside > 10,
        "{inside} within, {outside} beyond"
    );
    let placed = watch.placed_at().expect("placed on the way").clone();
    let nearby = &placed + &pattern * 1e-9;
    sim.pins_still_within(&nearby, 1.0, &mut watch);
    assert_eq!(
        watch.placed_at(),
        Some(&placed),
        "a small move is bounded, not placed"
    );
}

/// A base pinned on the floor it stands on: the surface samples of its pinned slab touch
/// nothing, the material above the slab still collides, and released pins free the slab.
#[test]
fn a_pinned_slab_on_the_floor_does_not_collide_and_the_rest_does() {
    use crate::physics::{Obstacle, SimParams};

    let body = SmallBox::new();
    let (mesh, subspace) = (&body.mesh, body.subspace());
    let mut sim = body.quasi_newton(subspace.clone(), SimParams::default());
    let slab_top = -0.03;
    let slab: Vec<Vector3<f64>> = mesh
        .vertices
        .iter()
        .filter(|v| v.z <= slab_top)
        .cloned()
        .collect();
    sim.add_pins(&slab, &vec![1e-3; slab.len()]);
    sim.hold_contacts_beyond(Vector3::z(), slab_top);
    sim.add_contact_points(&mesh.vertices, &vec![1e-3; mesh.vertices.len()]);
    // The bottom face (z = -0.05) 1 mm into the floor.
    sim.add_obstacle(Obstacle::floor(-0.049));
    let turn = nalgebra::Matrix3::identity();
    let touching_when_sunk = |sim: &mut super::ReducedSim, depth: f64| -> Vec<usize> {
        let z = subspace.rigid_state(&turn, &Vector3::new(0.0, 0.0, -depth));
        sim.find_candidates(&z);
        sim.touching_at(&z).iter().map(|&(c, _, _)| c).collect()
    };
    let in_floor_when_sunk = |depth: f64, rule: &dyn Fn(f64) -> bool| -> Vec<usize> {
        let vertices = mesh.vertices.iter().enumerate();
        let sunk = vertices.filter(|(_, v)| v.z - depth < -0.049 && rule(v.z));
        sunk.map(|(c, _)| c).collect()
    };
    assert!(
        touching_when_sunk(&mut sim, 0.0).is_empty(),
        "the pinned face touches nothing"
    );
    let above_slab = in_floor_when_sunk(0.06, &|z| z > slab_top);
    assert!(!above_slab.is_empty());
    assert_eq!(
        touching_when_sunk(&mut sim, 0.06),
        above_slab,
        "what is above the slab collides"
    );
    sim.release_pins_within(&Vector3::zeros(), 1.0);
    let bottom_face = in_floor_when_sunk(0.0, &|_| true);
    assert!(!bottom_face.is_empty());
    assert_eq!(
        touching_when_sunk(&mut sim, 0.0),
        bottom_face,
        "released, the slab collides"
    );
}

/// An observation pulls a free body onto what was seen: the box observed 2 cm along x at its
/// mesh vertices gets there within a few steps (quasi-Newton and Newton alike, the held factor
/// made anew with the springs), and once the observation is forgotten the body keeps the
/// momentum it gained, as physics alone says.
#[test]
fn an_observation_pulls_the_body_onto_what_was_seen_and_forgetting_it_leaves_physics() {
    let small = SmallBox::new();
    let params = crate::physics::SimParams {
        gravity: Vector3::zeros(),
        young: 1e5,
        ..Default::default()
    };
    let shift = Vector3::new(0.02, 0.0, 0.0);
    for solver in [super::Solver::QuasiNewton, super::Solver::Newton] {
        let mut sim =
            super::ReducedSim::new(small.subspace(), params.clone(), solver, 0.46).unwrap();
        let seen = &small.mesh.vertices;
        let phis = sim.subspace().phis(seen);
        let rows = phis[0].len();
        let mass = sim.subspace().total_mass();
        let term = super::ObservationTerm {
            phis: DMatrix::from_fn(rows, seen.len(), |a, i| phis[i][a]),
            rests: DMatrix::from_fn(3, seen.len(), |d, i| seen[i][d]),
            targets: DMatrix::from_fn(3, seen.len(), |d, i| seen[i][d] + shift[d]),
            weights: vec![mass / seen.len() as f64; seen.len()],
            stiffness: 4.0 / (params.dt * params.dt),
            unmodelled: None,
        };
        sim.observe(&term).unwrap();
        assert!(sim.is_observed());
        for _ in 0..10 {
            assert!(sim.step().converged);
        }
        let moved = sim.position_of(&seen[0]) - seen[0];
        assert!(
            (moved - shift).norm() < 1e-3,
            "{solver:?}: moved {moved:?}, seen at {shift:?}"
        );
        // Pulled for one step, then left alone: the body goes on at the speed it gained.
        let mut sim =
            super::ReducedSim::new(small.subspace(), params.clone(), solver, 0.46).unwrap();
        sim.observe(&term).unwrap();
        sim.step();
        sim.forget_observation();
        let v = sim.velocity();
        let before = sim.position_of(&seen[0]);
        sim.step();
        let drift = sim.position_of(&seen[0]) - before;
        // The constant handle's translation column carries the rigid velocity.
        let expected = Vector3::new(v[(0, 3)], v[(1, 3)], v[(2, 3)]) * params.dt;
        assert!(
            expected.x > 1e-3,
            "{solver:?}: the pull moved the body ({expected:?})"
        );
        assert!(
            (drift - expected).norm() <= 0.1 * expected.norm(),
            "{drift:?} against {expected:?}"
        );
    }
    let mut sim = small.quasi_newton(small.subspace(), params);
    let bad = super::ObservationTerm {
        phis: DMatrix::zeros(3, 1),
        rests: DMatrix::zeros(3, 1),
        targets: DMatrix::zeros(3, 1),
        weights: vec![1.0],
        stiffness: 1.0,
        unmodelled: None,
    };
    assert!(
        sim.observe(&bad).is_err(),
        "a term of the wrong shape is refused"
    );
    assert!(!sim.is_observed());
}

/// A force nothing modelled, as a frame estimated it, acts in the steps after the frame and
/// fades with its memory: set to carry the body's weight, it holds a free body up where
/// gravity alone drops it; with a short memory the body soon falls at g again.
#[test]
fn an_unmodelled_force_acts_between_frames_and_fades() {
    let small = SmallBox::new();
    let params = crate::physics::SimParams {
        young: 1e5,
        ..Default::default()
    };
    let rows = 4 * small.subspace().handles();
    let weight = DMatrix::from_fn(3, rows, |d, a| {
        -params.gravity[d] * small.subspace().mass_moment()[a]
    });
    let term = |memory_s: f64| super::ObservationTerm {
        phis: DMatrix::zeros(rows, 0),
        rests: DMatrix::zeros(3, 0),
        targets: DMatrix::zeros(3, 0),
        weights: vec![],
        stiffness: 0.0,
        unmodelled: Some(super::UnmodelledForce {
            force: weight.clone(),
            memory_s,
        }),
    };
    let centre = small.mesh.vertices[0];
    // The vertical acceleration over the three steps after `skip` steps of a body that took
    // the term of `memory_s` (None: no term), m/s^2.
    let acceleration = |memory_s: Option<f64>, skip: usize| {
        let mut sim = small.quasi_newton(small.subspace(), params.clone());
        if let Some(memory_s) = memory_s {
            sim.observe(&term(memory_s)).unwrap();
            sim.forget_observation();
        }
        for _ in 0..skip {
            sim.step();
        }
        let mut z = [0.0; 3];
        for height in &mut z {
            sim.step();
            *height = sim.position_of(&centre).z;
        }
        (z[2] - 2.0 * z[1] + z[0]) / (params.dt * params.dt)
    };
    let g = params.gravity.z;
    let free = acceleration(None, 0);
    assert!(
        (free - g).abs() < 0.01 * g.abs(),
        "free fall at {free} m/s^2"
    );
    let held = acceleration(Some(1e6), 5);
    assert!(
        held.abs() < 0.01 * g.abs(),
        "held, it falls at {held} m/s^2"
    );
    let faded = acceleration(Some(params.dt), 10);
    assert!(
        (faded - g).abs() < 0.01 * g.abs(),
        "faded, it falls at {faded} m/s^2"
    );
}
