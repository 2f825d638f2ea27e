//! Soft against soft: deformable objects of a scene collide with each other (each one's
//! contact points against the others' hulls, inside its own solve), and so do their FEM
//! references, so the error can be measured. Without it a block set on another sinks through
//! it to the floor.

mod common;

use std::path::PathBuf;

use serde_json::Value;

/// Writes `yaml` as a scene of its own and runs `physskin scene --reference` on it (the
/// command a user runs) for `seconds` after `settle_steps` steps.
fn run_scene(name: &str, yaml: &str, seconds: f64, settle_steps: usize) -> Value {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("soft-{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.yaml");
    std::fs::write(&path, yaml).unwrap();
    common::scene_against_fem(&path, seconds, settle_steps)
}

/// (error %, sag m, FEM sag m) of `object`.
fn object(run: &Value, object: &str) -> (f64, f64, f64) {
    let errors = run["errors"].as_array().expect("the run reports errors");
    let e = errors
        .iter()
        .find(|e| e["name"] == object)
        .unwrap_or_else(|| panic!("no error reported for {object}: {errors:?}"));
    let number = |key: &str| e[key].as_f64().unwrap_or_else(|| panic!("{key} of {e}"));
    (number("error_pct"), number("sag_m"), number("fem_sag_m"))
}

#[test]
fn a_soft_block_rests_on_another_as_in_the_fem() {
    // The top block starts 5 mm above the bottom one: it falls those 5 mm, then both give a
    // little. Through the bottom block it would fall 0.2 m.
    let run = run_scene(
        "stack",
        "floor: 0\nobjects:\n  \
         - {name: bottom, shape: {box: [0.2, 0.2, 0.2]}, position: [0, 0, 0.1], material: {young: 1.0e5}, handles: 17, cubature: 256}\n  \
         - {name: top, shape: {box: [0.16, 0.16, 0.16]}, position: [0, 0, 0.285], material: {young: 1.0e5}, handles: 17, cubature: 256}\n",
        1.0,
        60,
    );
    let (error, sag, fem_sag) = object(&run, "top");
    println!("top block: sag {sag:.5} m, FEM {fem_sag:.5} m, error {error:.3} %");
    assert!(
        (0.004..0.015).contains(&sag),
        "the top block sank {sag} m (5 mm gap, then a few mm of give)"
    );
    assert!(
        (0.002..0.015).contains(&fem_sag),
        "the FEM's top block sank {fem_sag} m: it does not rest on the bottom block"
    );
    assert!(error < 3.0, "top block against the FEM: {error:.3} %");
    let sag_error = (sag - fem_sag).abs() / fem_sag * 100.0;
    assert!(
        sag_error < 5.0,
        "the top block's sag is {sag_error:.2} % off the FEM's (at most 5 %)"
    );
    let (error, sag, fem_sag) = object(&run, "bottom");
    println!("bottom block: sag {sag:.5} m, FEM {fem_sag:.5} m, error {error:.3} %");
    assert!(error < 1.0, "bottom block against the FEM: {error:.3} %");
}

#[test]
fn a_ball_dropped_on_a_soft_slab_stays_on_it() {
    // A 5 cm ball falls 9 cm onto a 6 cm slab on the floor. Through the slab it would fall 15.
    let run = run_scene(
        "slab",
        "floor: 0\nobjects:\n  \
         - {name: slab, shape: {box: [0.4, 0.4, 0.06]}, position: [0, 0, 0.03], material: {young: 3.0e4}, handles: 17, cubature: 256}\n  \
         - {name: ball, shape: {sphere: 0.05}, position: [0, 0, 0.2], material: {young: 1.0e5}, handles: 17, cubature: 256}\n",
        1.5,
        0,
    );
    let (error, sag, fem_sag) = object(&run, "ball");
    println!("ball on the slab: sag {sag:.5} m, FEM {fem_sag:.5} m, error {error:.3} %");
    assert!(
        (0.08..0.11).contains(&sag) && (0.07..0.11).contains(&fem_sag),
        "the ball fell {sag} m ({fem_sag} m in the FEM): 0.09 m puts it on the slab"
    );
    assert!(error < 8.0, "ball against the FEM: {error:.3} %");
    // The same ball on a rigid floor at the slab's top: landing on soft material may cost at
    // most twice the error of landing on a rigid one.
    let rigid = run_scene(
        "rigid",
        "floor: 0.06\nobjects:\n  \
         - {name: ball, shape: {sphere: 0.05}, position: [0, 0, 0.2], material: {young: 1.0e5}, handles: 17, cubature: 256}\n",
        1.5,
        0,
    );
    let (rigid_error, _, _) = object(&rigid, "ball");
    println!("ball on a rigid floor: error {rigid_error:.3} %");
    assert!(
        error < 2.0 * rigid_error,
        "ball on the slab {error:.3} % against {rigid_error:.3} % on a rigid floor (at most 2x)"
    );
}
