//! The shipped neural skinning model: it loads by default, its last layer is orthonormal,
//! inference is deterministic and independent of the query batch, and it reproduces the
//! outputs recorded when it was committed (tests/data/model_golden.json; regenerate with
//! UPDATE_GOLDEN=1 after retraining).

use crate::geometry::{box_mesh, VoxelGrid};
use crate::pipeline::network_input;
use crate::skinning::{NeuralField, NeuralModel, SkinningField};
use nalgebra::Vector3;

fn box_field() -> NeuralField {
    let shape = box_mesh(Vector3::new(0.4, 0.3, 0.2));
    let mut grid = VoxelGrid::from_shape(&shape, 128, None);
    grid.keep_largest_component();
    let (_, surface, reference) = network_input(&shape, &grid, 4096, 4096);
    NeuralModel::bundled()
        .expect("the bundled model loads")
        .field(&surface, &reference, shape.normalization())
        .expect("a box has a field")
}

fn probe_points() -> Vec<Vector3<f64>> {
    (0..8)
        .map(|i| {
            let t = i as f64;
            Vector3::new(
                (0.7 * t).sin() * 0.9,
                (1.3 * t).cos() * 0.6,
                (0.4 * t).sin() * 0.4,
            )
        })
        .collect()
}

#[test]
fn the_bundled_model_has_an_orthonormal_last_layer() {
    let model = NeuralModel::bundled().unwrap();
    let w = model.network().head_weight().unwrap();
    let gram = w.matmul(&w.t().unwrap()).unwrap().to_vec2::<f32>().unwrap();
    for (i, row) in gram.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let expected = if i == j { 1.0 } else { 0.0 };
            assert!((v - expected).abs() < 1e-5, "W W^T[{i}][{j}] = {v}");
        }
    }
}

#[test]
fn inference_is_deterministic_and_independent_of_the_batch() {
    let field = box_field();
    let again = box_field();
    let k = field.handle_count();
    let points: Vec<Vector3<f64>> = (0..3000)
        .map(|i| {
            let t = i as f64 * 0.618;
            Vector3::new(
                (t * 1.1).sin() * 0.9,
                (t * 0.7).cos() * 0.6,
                (t * 2.3).sin() * 0.4,
            )
        })
        .collect();
    let mut all = vec![0.0; points.len() * k];
    field.evaluate(&points, &mut all, None);
    let mut repeated = vec![0.0; points.len() * k];
    again.evaluate(&points, &mut repeated, None);
    assert_eq!(all, repeated, "two encodings of the same input differ");
    for chunk in [1, 7, 500] {
        let mut pieces = Vec::new();
        for part in points.chunks(chunk) {
            let mut w = vec![0.0; part.len() * k];
            field.evaluate(part, &mut w, None);
            pieces.extend(w);
        }
        let worst = all
            .iter()
            .zip(&pieces)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-5,
            "batches of {chunk}: weights differ by {worst}"
        );
    }
    assert!(
        all.iter().step_by(k).all(|w| *w == 1.0),
        "column 0 is the constant handle"
    );
}

#[test]
fn the_bundled_model_reproduces_its_recorded_outputs() {
    let field = box_field();
    let points = probe_points();
    let k = field.handle_count();
    let mut weights = vec![0.0; points.len() * k];
    field.evaluate(&points, &mut weights, None);
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/model_golden.json");
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        let json = serde_json::json!({ "handles": k, "weights": weights });
        std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    }
    let golden: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(golden["handles"].as_u64().unwrap() as usize, k);
    let recorded: Vec<f64> = golden["weights"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(recorded.len(), weights.len());
    for (i, (a, b)) in weights.iter().zip(&recorded).enumerate() {
        assert!((a - b).abs() < 1e-4, "weight {i}: {a} now, {b} recorded");
    }
}
