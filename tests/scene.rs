//! Scenes: robot links that push, attachments that carry, friction, sleeping and waking,
//! cached inference, static objects, and sizes from the error budget, each checked against the
//! full-space FEM or a plain physical expectation.

use std::path::PathBuf;

mod common;

use nalgebra::Vector3;
use physskin::scene::{FieldCache, Scene, SceneFile, SceneOptions};
use physskin::skinning::NeuralModel;

/// A one-joint robot: a prismatic joint moving a 0.1 m cube (`pusher`) along -z from 0.5 m up,
/// and a revolute joint (about y, at 0.6 m up) turning a bare `hand` link 0.3 m out along x.
const ROBOT: &str = r#"<robot name="rig">
  <link name="base"/>
  <link name="pusher"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="hand"/>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="pusher"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 -1"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
  <joint name="swing" type="revolute"><parent link="base"/><child link="hand"/>
    <origin xyz="0.3 0 0.6"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>"#;

/// Writes the robot and a scene (YAML, `{urdf}` replaced by the robot's path) to a directory
/// of their own and loads the scene.
fn scene_file(name: &str, yaml: &str) -> SceneFile {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("scene-{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("rig.urdf"), ROBOT).unwrap();
    let path = dir.join("scene.yaml");
    std::fs::write(&path, yaml.replace("{urdf}", "rig.urdf")).unwrap();
    SceneFile::load(&path).unwrap()
}

fn build(file: &SceneFile, cache: &FieldCache) -> Scene {
    Scene::build(
        file,
        &NeuralModel::bundled().unwrap(),
        cache,
        &SceneOptions::default(),
    )
    .unwrap()
}

/// Lowest and highest z of an object's points now.
fn z_range(scene: &Scene, name: &str) -> (f64, f64) {
    let points = scene.points(name).unwrap();
    points
        .chunks(3)
        .map(|p| p[2] as f64)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        })
}

/// Where the material point at `rest` of a deformable object is now.
fn position_of(scene: &Scene, name: &str, rest: Vector3<f64>) -> Vector3<f64> {
    let body = scene.body(name).unwrap();
    let mut x = [0.0f32; 3];
    body.lifter_for(&[rest]).lift(body.state(), &mut x);
    Vector3::new(x[0] as f64, x[1] as f64, x[2] as f64)
}

/// Where `scene_file(name, ..)` wrote the scene.
fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("scene-{name}"))
        .join("scene.yaml")
}

/// The scene `name` run again by `physskin scene --reference` (the command a user runs), after
/// `settle_steps` steps with the robot still, for `seconds` of its motion; `object`'s error
/// against the full-space FEM, %.
fn fem_error_pct(name: &str, seconds: f64, settle_steps: usize, object: &str) -> f64 {
    let run = common::scene_against_fem(&scene_path(name), seconds, settle_steps);
    let errors = run["errors"].as_array().expect("the run reports errors");
    let error = errors.iter().find(|e| e["name"] == object);
    error
        .and_then(|e| e["error_pct"].as_f64())
        .unwrap_or_else(|| {
            panic!("no error reported for {object}: {errors:?}");
        })
}

#[test]
fn a_link_dents_a_soft_block_as_the_fem_does() {
    // The pusher comes down 0.17 m onto a 0.3 m block standing on the floor, holds, and goes
    // back up.
    let file = scene_file(
        "dent",
        "floor: 0\nrobots:\n  - name: rig\n    urdf: '{urdf}'\n    motion:\n      \
         - {at: 0, positions: {lift: 0}}\n      - {at: 0.6, positions: {lift: 0.17}}\n      \
         - {at: 1.0, positions: {lift: 0.17}}\n      - {at: 1.4, positions: {lift: 0}}\n\
         objects:\n  - name: block\n    shape: {box: [0.3, 0.3, 0.3]}\n    position: [0, 0, 0.15]\n    \
         material: {young: 1.0e5}\n    handles: 17\n    cubature: 128\n",
    );
    let cache = FieldCache::default();
    let mut scene = build(&file, &cache);
    // The middle of the block's top, where the pusher lands.
    let top_middle = |scene: &Scene| position_of(scene, "block", Vector3::new(0.0, 0.0, 0.3)).z;
    scene.settle(120);
    let at_rest = top_middle(&scene);
    let mut lowest = f64::INFINITY;
    for _ in 0..60 {
        scene.step();
        lowest = lowest.min(top_middle(&scene));
    }
    // The cube's bottom reaches 0.5 - 0.17 - 0.05 = 0.28 m: 2 cm into the block's top.
    assert!(
        (0.27..0.29).contains(&lowest),
        "the middle of the block's top went down to {lowest:.4} m, the pusher to 0.28"
    );
    for _ in 0..60 {
        scene.step();
    }
    let after = top_middle(&scene);
    assert!(
        (after - at_rest).abs() < 0.002,
        "the block did not spring back: the middle of its top at {after:.4} m, {at_rest:.4} \
         at rest (sagging under its weight)"
    );

    // The same motion in the full-space FEM, compared step by step.
    let error = fem_error_pct("dent", 1.6, 120, "block");
    assert!(error < 2.0, "block against the FEM: {error:.3} %");
}

#[test]
fn a_rigid_object_carried_by_a_link_pushes_like_a_link() {
    // A rigid plate hangs under the pusher and goes down with it, 5 cm into the block; it is
    // not simulated.
    let file = scene_file(
        "rigid",
        "floor: 0\nrobots:\n  - name: rig\n    urdf: '{urdf}'\n    motion:\n      \
         - {at: 0, positions: {lift: 0}}\n      - {at: 0.5, positions: {lift: 0.17}}\n\
         objects:\n  - name: plate\n    kind: rigid\n    shape: {box: [0.2, 0.2, 0.02]}\n    \
         position: [0, 0, 0.43]\n    attach: {robot: rig, link: pusher}\n  \
         - name: block\n    shape: {box: [0.3, 0.3, 0.3]}\n    position: [0, 0, 0.15]\n    \
         material: {young: 1.0e5}\n    handles: 9\n    cubature: 128\n",
    );
    let mut scene = build(&file, &FieldCache::default());
    assert!(
        scene.body("plate").is_none(),
        "a rigid object was simulated"
    );
    let plate_before = z_range(&scene, "plate");
    for _ in 0..45 {
        scene.step();
    }
    let plate_after = z_range(&scene, "plate");
    assert!(
        (plate_before.0 - plate_after.0 - 0.17).abs() < 1e-5,
        "the plate went from {plate_before:?} to {plate_after:?}, its link 0.17 m down"
    );
    // The plate's bottom is at 0.42 - 0.17 = 0.25 m.
    let top = position_of(&scene, "block", Vector3::new(0.0, 0.0, 0.3)).z;
    assert!(
        top < 0.265,
        "the middle of the block's top is at {top} m under a plate at 0.25"
    );
}

#[test]
fn an_attached_object_follows_its_link_as_the_fem_does() {
    // A bar held at one end by the hand, which turns 0.6 rad: the held end follows the hand's
    // arc, the free end swings after it.
    let file = scene_file(
        "attach",
        "robots:\n  - name: rig\n    urdf: '{urdf}'\n    motion:\n      \
         - {at: 0, positions: {swing: 0}}\n      - {at: 0.5, positions: {swing: 0.6}}\n\
         objects:\n  - name: bar\n    shape: {box: [0.06, 0.06, 0.4]}\n    position: [0.3, 0, 0.38]\n    \
         support: free\n    handles: 17\n    cubature: 256\n    \
         attach: {robot: rig, link: hand, center: [0.3, 0, 0.56], radius: 0.04}\n",
    );
    let cache = FieldCache::default();
    let mut scene = build(&file, &cache);
    for _ in 0..30 {
        scene.step();
    }
    // The hand turned 0.6 rad about y through (0.3, 0, 0.6): the held point (0.3, 0, 0.56)
    // is now at 0.04 (sin 0.6 * -1, ...) from the pivot: x = 0.3 - 0.04 sin(0.6).
    let got = position_of(&scene, "bar", Vector3::new(0.3, 0.0, 0.56));
    let expected = Vector3::new(0.3 - 0.04 * 0.6f64.sin(), 0.0, 0.6 - 0.04 * 0.6f64.cos());
    assert!(
        (got - expected).norm() < 0.01,
        "held point at {got:?}, the link holds it at {expected:?}"
    );
    let error = fem_error_pct("attach", 1.0, 30, "bar");
    assert!(error < 3.0, "bar against the FEM: {error:.3} %");
}

#[test]
fn friction_holds_a_block_a_frictionless_floor_lets_slide() {
    let yaml = |friction: f64| {
        format!(
            "floor: 0\nfriction: {friction}\nsleep: null\nobjects:\n  - name: block\n    \
             shape: {{box: [0.2, 0.2, 0.1]}}\n    position: [0, 0, 0.05]\n    handles: 5\n    \
             cubature: 64\n"
        )
    };
    let slide = |friction: f64| {
        let file = SceneFile::parse(&yaml(friction)).unwrap();
        let mut scene = build(&file, &FieldCache::default());
        for _ in 0..30 {
            scene.step();
        }
        // A sideways push of a fifth of the block's weight (4 kg) for 0.5 s, at mid-height.
        scene
            .push(
                "block",
                Vector3::new(0.0, 0.0, 0.05),
                Vector3::new(7.8, 0.0, 0.0),
                0.5,
            )
            .unwrap();
        for _ in 0..30 {
            scene.step();
        }
        centroid(&scene, "block").x
    };
    let held = slide(0.5);
    let free = slide(0.0);
    // Frictionless: a = F/m = 1.95 m/s^2 for 0.5 s, 0.24 m (less the damping).
    assert!(free > 0.1, "frictionless block moved {free:.4} m");
    assert!(
        held.abs() < 0.005,
        "block on a floor with friction 0.5 moved {held:.4} m"
    );
}

/// Coulomb's law for a sliding block: pushed with twice its friction (mu m g = 19.6 N for 4 kg
/// at 0.5) it accelerates at mu g = 4.9 m/s^2, 0.6125 m in 0.5 s, and once let go slides as
/// far again before it stops (no damping: the scene's default would take 15 % off the push).
/// Friction springs left linear past the Coulomb limit resisted a slide with several times
/// that force, the more the faster it went.
#[test]
fn a_block_pushed_past_its_friction_slides_as_coulomb_says() {
    let file = SceneFile::parse(
        "floor: 0\nfriction: 0.5\ndamping: 0\nsleep: null\nobjects:\n  - name: block\n    \
         shape: {box: [0.2, 0.2, 0.1]}\n    position: [0, 0, 0.05]\n    handles: 5\n    \
         cubature: 64\n",
    )
    .unwrap();
    let mut scene = build(&file, &FieldCache::default());
    for _ in 0..30 {
        scene.step();
    }
    let start = centroid(&scene, "block").x;
    let weight = 4.0 * 9.81;
    scene
        .push(
            "block",
            Vector3::new(0.0, 0.0, 0.05),
            Vector3::new(weight, 0.0, 0.0),
            0.5,
        )
        .unwrap();
    let dt = scene.dt();
    let steps = |seconds: f64| (seconds / dt).round() as usize;
    for _ in 0..steps(0.5) {
        scene.step();
    }
    let pushed = centroid(&scene, "block").x - start;
    for _ in 0..steps(1.0) {
        scene.step();
    }
    let slid = centroid(&scene, "block").x - start;
    println!("pushed {pushed:.4} m in 0.5 s, slid {slid:.4} m");
    let (mu_g, t) = (0.5 * 9.81, 0.5);
    let expected = 0.5 * mu_g * t * t;
    assert!(
        (pushed / expected - 1.0).abs() < 0.15,
        "pushed {pushed:.4} m in 0.5 s, Coulomb says {expected:.4} m"
    );
    assert!(
        (slid / (2.0 * expected) - 1.0).abs() < 0.15,
        "slid {slid:.4} m in all, Coulomb says {:.4} m",
        2.0 * expected
    );
}

/// Mean of an object's points now.
fn centroid(scene: &Scene, name: &str) -> Vector3<f64> {
    let points = scene.points(name).unwrap();
    let sum = points.chunks(3).fold(Vector3::zeros(), |s, p| {
        s + Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    });
    sum / (points.len() / 3) as f64
}

#[test]
fn a_resting_ball_stays_put_and_a_push_still_rolls_it() {
    // The scene's default rolling friction (1 mm): without it this ball, with the sizes the
    // budget picks, rolls 5 cm in 2 s (`bench contact`).
    let file = SceneFile::parse(
        "floor: 0\nsleep: null\nobjects:\n  - name: ball\n    shape: {sphere: 0.1}\n    \
         position: [0, 0, 0.1]\n",
    )
    .unwrap();
    let mut scene = build(&file, &FieldCache::default());
    for _ in 0..30 {
        scene.step();
    }
    let start = centroid(&scene, "ball");
    let mut drift: f64 = 0.0;
    for _ in 0..120 {
        scene.step();
        drift = drift.max((centroid(&scene, "ball") - start).xy().norm());
    }
    assert!(drift < 2e-3, "resting ball moved {:.4} mm", drift * 1e3);
    // A push at the centre of a fifth of its weight (4.19 kg) for 0.5 s needs a torque far
    // above the limit to roll the ball without slipping: it rolls.
    scene
        .push(
            "ball",
            Vector3::new(0.0, 0.0, 0.1),
            Vector3::new(8.2, 0.0, 0.0),
            0.5,
        )
        .unwrap();
    for _ in 0..60 {
        scene.step();
    }
    let rolled = centroid(&scene, "ball").x - start.x;
    assert!(rolled > 0.1, "pushed ball moved {rolled:.4} m");
}

#[test]
fn still_objects_sleep_cost_nothing_and_wake_on_a_link_or_a_push() {
    let file = scene_file(
        "sleep",
        "floor: 0\nsleep: {speed: 0.001, after: 0.3}\nrobots:\n  - name: rig\n    urdf: '{urdf}'\n    \
         motion:\n      - {at: 0, positions: {lift: 0}}\n      - {at: 1.0, positions: {lift: 0}}\n      \
         - {at: 1.5, positions: {lift: 0.27}}\n\
         objects:\n  - name: under\n    shape: {box: [0.2, 0.2, 0.2]}\n    position: [0, 0, 0.1]\n    \
         handles: 5\n    cubature: 64\n  - name: aside\n    shape: {box: [0.2, 0.2, 0.2]}\n    \
         position: [1.0, 0, 0.1]\n    handles: 5\n    cubature: 64\n",
    );
    let mut scene = build(&file, &FieldCache::default());
    let settled = scene.settle(240);
    assert!(settled < 240, "still awake after 4 s: {:?}", scene.report());
    assert_eq!(scene.awake(), 0);
    let asleep = scene.points("under").unwrap();
    for _ in 0..30 {
        scene.step();
    }
    assert_eq!(
        scene.points("under").unwrap(),
        asleep,
        "a sleeping body moved"
    );
    // The pusher comes down on `under` from t = 1 s (2 cm into it at 1.5 s): `under` wakes,
    // `aside` sleeps on.
    for _ in 0..60 {
        scene.step();
    }
    let report = scene.report();
    let sleeping = |name: &str| report.iter().find(|o| o.name == name).unwrap().sleeping;
    assert!(
        !sleeping("under"),
        "the pusher came down on `under`, which slept on"
    );
    assert!(sleeping("aside"), "`aside` woke with nothing near it");
    scene
        .push(
            "aside",
            Vector3::new(1.0, 0.0, 0.2),
            Vector3::new(0.0, 0.0, -50.0),
            0.1,
        )
        .unwrap();
    scene.step();
    assert_eq!(scene.awake(), 2, "a push did not wake `aside`");
    let err = scene.push("nobody", Vector3::zeros(), Vector3::zeros(), 0.1);
    assert!(err.unwrap_err().contains("no deformable object `nobody`"));
}

#[test]
fn identical_geometry_is_inferred_once_and_static_objects_hold_what_rests_on_them() {
    let file = SceneFile::parse(
        "floor: 0\nobjects:\n  - {name: a, shape: {box: [0.2, 0.2, 0.2]}, position: [0, 0, 0.3], handles: 5, cubature: 64}\n  \
         - {name: b, shape: {box: [0.2, 0.2, 0.2]}, position: [1, 0, 0.1], handles: 5, cubature: 64}\n  \
         - {name: table, kind: static, shape: {box: [0.4, 0.4, 0.2]}, position: [0, 0, 0.1]}\n",
    )
    .unwrap();
    let cache = FieldCache::default();
    let mut scene = build(&file, &cache);
    use std::sync::atomic::Ordering::Relaxed;
    assert_eq!(
        (cache.misses.load(Relaxed), cache.hits.load(Relaxed)),
        (1, 1)
    );
    let (a, b) = (scene.body("a").unwrap(), scene.body("b").unwrap());
    let largest = a
        .weights()
        .iter()
        .zip(b.weights())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(
        largest < 1e-5,
        "the same geometry, weights apart by {largest}"
    );
    assert!(
        scene.body("table").is_none(),
        "a static object was simulated"
    );
    for _ in 0..90 {
        scene.step();
    }
    // `a` rests on the table's top (z = 0.2), not on the floor 0.2 m below.
    let (bottom, _) = z_range(&scene, "a");
    assert!(
        bottom > 0.19,
        "`a` sank into the static table: bottom at {bottom:.4} m"
    );
    let report = scene.report();
    assert!(report[0].decision.starts_with("static: not simulated"));
}

#[test]
fn auto_sizes_are_the_smallest_within_the_budget() {
    let yaml = |budget: f64| {
        format!(
            "error_budget_pct: {budget}\nobjects:\n  - name: post\n    shape: {{box: [0.1, 0.1, 0.5]}}\n    \
             position: [0, 0, 0.25]\n    support: pin_bottom\n"
        )
    };
    let cache = FieldCache::default();
    let loose = build(&SceneFile::parse(&yaml(5.0)).unwrap(), &cache);
    let strict = build(&SceneFile::parse(&yaml(0.001)).unwrap(), &cache);
    let (loose, strict) = (&loose.report()[0], &strict.report()[0]);
    assert!(
        loose.decision.contains("within the 5 % budget"),
        "{}",
        loose.decision
    );
    assert!(
        strict.decision.contains("no size meets the 0.001 % budget"),
        "{}",
        strict.decision
    );
    assert!(
        loose.handles * loose.handles * loose.cubature
            <= strict.handles * strict.handles * strict.cubature,
        "a looser budget chose a larger model: {loose:?} against {strict:?}"
    );
    // Inference ran once for both scenes; the budget's probe runs once per budget.
    use std::sync::atomic::Ordering::Relaxed;
    assert_eq!(cache.misses.load(Relaxed), 1);
}

#[test]
fn a_joint_state_reaches_every_robot_on_its_topic() {
    // Two robots on one topic: each takes the joints it has; only a name neither has is wrong.
    let file = scene_file(
        "two-robots",
        "robots:\n  - {name: left, urdf: '{urdf}'}\n  - {name: right, urdf: '{urdf}', base: {xyz: [1, 0, 0]}}\n\
         objects:\n  - {name: bar, shape: {box: [0.06, 0.06, 0.4]}, position: [0.3, 0, 0.38], handles: 5, cubature: 64}\n",
    );
    let mut scene = build(&file, &FieldCache::default());
    let robots = ["left".to_string(), "right".to_string()];
    let names = ["lift".to_string(), "swing".to_string()];
    scene
        .set_joint_positions(&robots, &names, &[0.1, 0.2])
        .unwrap();
    let err = scene
        .set_joint_positions(&robots, &["lift".into(), "elbow".into()], &[0.1, 0.2])
        .unwrap_err();
    assert!(
        err.contains("has joint elbow") && !err.contains("lift"),
        "{err}"
    );
    let err = scene
        .set_joint_positions(&robots, &names, &[0.1])
        .unwrap_err();
    assert!(err.contains("2 joint names but 1 positions"), "{err}");
}

#[test]
fn scene_mistakes_name_the_object_and_the_problem() {
    let file = scene_file(
        "mistakes",
        "robots:\n  - name: rig\n    urdf: '{urdf}'\nobjects:\n  - name: bar\n    \
         shape: {box: [0.06, 0.06, 0.4]}\n    attach: {robot: rig, link: wrist, center: [0, 0, 0], radius: 0.04}\n",
    );
    let err = Scene::build(
        &file,
        &NeuralModel::bundled().unwrap(),
        &FieldCache::default(),
        &SceneOptions::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        err.contains("`bar`") && err.contains("no link `wrist`"),
        "{err}"
    );
    let missing = SceneFile::load(std::path::Path::new("no/such/scene.yaml"))
        .err()
        .unwrap()
        .to_string();
    assert!(missing.contains("no/such/scene.yaml"), "{missing}");
}

/// A press holds the block down long enough for it to fall asleep, then jumps away in one
/// step: the block must wake and spring back, not stay dented.
#[test]
fn a_link_lifting_off_a_sleeping_body_wakes_it() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = SceneFile::load(&root.join("tests/data/press/press.yaml")).unwrap();
    let options = SceneOptions {
        scripted: false,
        ..Default::default()
    };
    let model = NeuralModel::bundled().unwrap();
    let mut scene = Scene::build(&file, &model, &FieldCache::default(), &options).unwrap();
    let top = |scene: &Scene| {
        let p = scene.points("block").unwrap();
        p.chunks(3)
            .filter(|q| q[0].abs() < 0.04 && q[1].abs() < 0.04 && q[2] > 0.2)
            .map(|q| q[2] as f64)
            .fold(0.0, f64::max)
    };
    let (robots, names) = (vec!["press".to_string()], vec!["lift".to_string()]);
    let run = |scene: &mut Scene, lift: &dyn Fn(f64) -> f64, steps: usize| {
        for i in 0..steps {
            let position = lift(i as f64 / 60.0);
            scene
                .set_joint_positions(&robots, &names, &[position])
                .unwrap();
            scene.step();
        }
    };
    run(&mut scene, &|_| 0.0, 60);
    let rest = top(&scene);
    run(&mut scene, &|t| (0.17 * t).min(0.17), 120);
    let pressed = top(&scene);
    assert!(
        rest - pressed > 0.005,
        "pressed {pressed:.4} from {rest:.4}"
    );
    assert!(
        scene.body("block").unwrap().is_sleeping(),
        "asleep under the press"
    );
    run(&mut scene, &|_| 0.0, 60);
    let released = top(&scene);
    assert!(
        (released - rest).abs() < 0.002,
        "after the press lifted: {released:.4} m, at rest {rest:.4} m"
    );
}

/// The bundled grasp (config/scenes/grasp.yaml): two fingers close on a soft block, squeeze it
/// and lift it 0.2 m; with friction 0.5 it rises with them and stays in the grip for 10 s;
/// without friction it stays on the floor.
#[test]
fn a_gripper_lifts_a_soft_block_and_holds_it() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/config/scenes/grasp.yaml");
    let run = |friction: f64| {
        let mut file = SceneFile::load(std::path::Path::new(path)).unwrap();
        file.friction = friction;
        let mut scene = build(&file, &FieldCache::default());
        let dt = scene.dt();
        let steps = |seconds: f64| (seconds / dt).round() as usize;
        for _ in 0..steps(2.5) {
            scene.step();
        }
        let lifted = centroid(&scene, "block");
        let mut drift: f64 = 0.0;
        let mut unconverged = 0;
        for _ in 0..steps(10.0) {
            scene.step();
            drift = drift.max((centroid(&scene, "block") - lifted).norm());
            let report = scene.body("block").unwrap().last_step().unwrap();
            unconverged += usize::from(!report.converged || report.fallback);
        }
        println!(
            "friction {friction}: block at {lifted:?} after the lift, drift {:.4} mm",
            drift * 1e3
        );
        (lifted, drift, unconverged)
    };
    let (held, drift, unconverged) = run(0.5);
    // Squeezed by two boxes, a thousand points touch: their depth in f32 made the contact
    // energy too noisy for the line search (4 unconverged steps in 12.5 s before).
    assert_eq!(
        unconverged, 0,
        "steps unconverged or handed to Newton while held"
    );
    assert!(
        held.z > 0.05 + 0.19,
        "block centre at {:.4} m after the lift",
        held.z
    );
    assert!(
        drift < 1e-3,
        "block drifted {:.4} mm in the grip",
        drift * 1e3
    );
    let (slipped, _, _) = run(0.0);
    assert!(
        slipped.z < 0.06,
        "frictionless block lifted to {:.4} m",
        slipped.z
    );
}

#[test]
fn objects_with_all_their_handles_get_the_refined_field_the_same_every_build() {
    // 17 handles is the field's full count: refined 8 iterations. 5 is a cut: the network's.
    let file = SceneFile::parse(
        "floor: 0\nobjects:\n  - {name: full, shape: {box: [0.2, 0.1, 0.1]}, position: [0, 0, 0.05], handles: 17, cubature: 64}\n  \
         - {name: cut, shape: {box: [0.1, 0.1, 0.3]}, position: [1, 0, 0.15], handles: 5, cubature: 64}\n",
    )
    .unwrap();
    let first = build(&file, &FieldCache::default());
    let report = first.report();
    assert!(
        report[0]
            .decision
            .ends_with("refined toward the eigenmodes (8 iterations)"),
        "{}",
        report[0].decision
    );
    assert!(
        !report[1].decision.contains("refined"),
        "{}",
        report[1].decision
    );
    // An iteration count, not a time: a second build in a fresh cache gives the same weights.
    let second = build(&file, &FieldCache::default());
    let (a, b) = (first.body("full").unwrap(), second.body("full").unwrap());
    assert_eq!(
        a.weights(),
        b.weights(),
        "two builds of the refined field differ"
    );
}

/// A column pinned at its base, the base a millimetre into the floor it stands on: the pinned
/// material's surface does not collide with that floor (its pins hold it), so its steps carry
/// no contact springs, while a free block set the same way does.
#[test]
fn a_base_pinned_into_the_floor_holds_no_contact_springs() {
    let yaml = |support: &str| {
        format!(
            "floor: 0\nsleep: null\nobjects:\n  - name: column\n    \
             shape: {{box: [0.1, 0.1, 0.3]}}\n    position: [0, 0, 0.149]\n    handles: 5\n    \
             cubature: 64\n    support: {support}\n"
        )
    };
    let contacts_after_settling = |support: &str| {
        let file = SceneFile::parse(&yaml(support)).unwrap();
        let mut scene = build(&file, &FieldCache::default());
        for _ in 0..10 {
            scene.step();
        }
        let body = scene.body("column").unwrap();
        body.last_step().expect("stepped").contacts
    };
    assert_eq!(contacts_after_settling("pin_bottom"), 0);
    assert!(
        contacts_after_settling("floor") > 0,
        "a free column stands on the floor"
    );
}
