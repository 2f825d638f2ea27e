//! A body a tracker finds far off where the camera sees it is moved there at once: its
//! shape and its speed are those it had, turned with it.

use crate::geometry::bundled;
use crate::skinning::NeuralModel;
use crate::{BodyOptions, SoftBody, Support};
use nalgebra::{DMatrix, Isometry3, Vector3};

/// The points `state` puts the body's own points at, less their rest places when `linear`.
fn lifted(body: &SoftBody, state: &DMatrix<f64>, linear: bool) -> Vec<Vector3<f64>> {
    let lifter = body.lifter();
    let mut out = vec![0f32; 3 * lifter.len()];
    lifter.lift(state, &mut out);
    let rest = lifter.rest_points();
    out.chunks_exact(3)
        .zip(rest)
        .map(|(p, r)| {
            let p = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            if linear {
                p - r
            } else {
                p
            }
        })
        .collect()
}

#[test]
fn a_body_moved_rigidly_keeps_its_shape_and_its_speed_turned() {
    let shape = bundled("box").unwrap();
    let options = BodyOptions {
        support: Support::Free,
        ..BodyOptions::default()
    };
    let model = NeuralModel::bundled().unwrap();
    let mut body = SoftBody::build(&model, &shape, &shape.positions, &options).unwrap();
    body.push(shape.positions[0], Vector3::new(3.0, 0.0, 1.0), 0.05);
    for _ in 0..6 {
        body.step();
    }
    let before = lifted(&body, body.state(), false);
    let speed = lifted(&body, &body.velocity(), true);
    assert!(speed.iter().any(|v| v.norm() > 0.05), "the body moves");
    let motion = Isometry3::new(
        Vector3::new(0.05, -0.02, 0.03),
        Vector3::new(0.1, 0.2, -0.3),
    );
    body.move_rigidly(&motion);
    let after = lifted(&body, body.state(), false);
    let speed_after = lifted(&body, &body.velocity(), true);
    for ((b, a), (v, w)) in before
        .iter()
        .zip(&after)
        .zip(speed.iter().zip(&speed_after))
    {
        assert!((motion.transform_point(&(*b).into()).coords - a).norm() < 1e-5);
        assert!((motion.rotation * v - w).norm() < 1e-4 * (1.0 + v.norm()));
    }
}
