//! Real sensors' clouds through the node's pipeline (a replay of a recording, in process): a
//! depth camera's organized, coloured, labelled cloud in its optical frame splits into one
//! object per instance id, keeps the ids across frames, drops an id after the timeout, and each
//! deformed cloud keeps the camera's fields, colours and ids, in input order; an unlabelled
//! organized cloud keeps its image shape with NaN pixels in place; objects of one cloud collide
//! with each other.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::Vector3;
use physskin::geometry::{sdf_mesh, Camera};
use physskin::msg::camera_cloud::{camera_cloud, SeenObject};
use physskin::msg::{from_cdr, Header, PointCloud2, SubspaceState, Time};
use physskin::runtime::NodeParams;
use serde_json::json;

mod common;

use common::scenes::{table_scene, OPTICAL_FRAME as FRAME};

fn instance_of(cloud: &PointCloud2, pixel: usize) -> u16 {
    let at = pixel * cloud.point_step as usize + 16;
    u16::from_le_bytes(cloud.data[at..at + 2].try_into().unwrap())
}

fn x_of(cloud: &PointCloud2, pixel: usize) -> f32 {
    let at = pixel * cloud.point_step as usize;
    f32::from_le_bytes(cloud.data[at..at + 4].try_into().unwrap())
}

/// Replays `clouds` (log time in s, cloud) with `params`, recording the outputs; returns them.
fn replay_clouds(
    name: &str,
    clouds: &[(f64, PointCloud2)],
    params: NodeParams,
) -> Vec<physskin::bag::BagMessage> {
    common::replay_clouds("test-labelled", name, clouds, params, 0.5).1
}

#[test]
fn a_labelled_scan_splits_into_objects_that_keep_ids_colours_and_layout() {
    let full = table_scene(128, 96);
    // After three frames the box leaves the segmenter's output: its pixels read background.
    let mut without_box = full.clone();
    for pixel in 0..(full.width * full.height) as usize {
        if instance_of(&full, pixel) == 2 {
            let at = pixel * 20 + 16;
            without_box.data[at..at + 2].copy_from_slice(&0u16.to_le_bytes());
        }
    }
    let mut clouds: Vec<(f64, PointCloud2)> =
        (1..=3).map(|i| (0.1 * i as f64, full.clone())).collect();
    clouds.extend((4..=16).map(|i| (0.1 * i as f64, without_box.clone())));
    let params = common::params(&[("object_timeout_s", json!(0.5))]);
    let out = replay_clouds("labelled", &clouds, params);

    let ready = common::statuses(&out, "shape_ready");
    for (_, s) in &ready {
        println!("{}", s.message);
    }
    assert_eq!(
        ready.len(),
        2,
        "one build per object, none again for unchanged frames"
    );
    assert!(ready.iter().any(|(_, s)| s.message.contains("instance 1")));
    assert!(ready.iter().any(|(_, s)| s.message.contains("instance 2")));
    assert!(
        ready
            .iter()
            .all(|(_, s)| s.message.contains("completed one view")),
        "one camera's view of each is completed"
    );
    let ids: BTreeSet<u32> = ready.iter().map(|(_, s)| s.shape_id).collect();
    let stepped: BTreeSet<u32> = out
        .iter()
        .filter(|m| m.topic == "/physskin/state")
        .map(|m| from_cdr::<SubspaceState>(&m.data).unwrap().shape_id)
        .collect();
    assert_eq!(stepped, ids, "the objects keep their ids across frames");

    let removed = common::statuses(&out, "shape_removed");
    assert_eq!(removed.len(), 1, "{removed:?}");
    let (removed_at, removal) = &removed[0];
    assert!(
        removal.message.contains("instance 2"),
        "{}",
        removal.message
    );
    assert!(
        *removed_at >= 800_000_000,
        "removed after the 0.5 s timeout, at {removed_at} ns"
    );

    let mut last_seen: BTreeMap<u16, i64> = BTreeMap::new();
    let pixels = (full.width * full.height) as usize;
    for m in out
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
    {
        let cloud: PointCloud2 = from_cdr(&m.data).unwrap();
        // One object of a labelled cloud: its own points, not the whole image.
        assert_eq!(cloud.height, 1);
        assert_eq!(cloud.fields, full.fields, "the camera's fields, in order");
        let label = instance_of(&cloud, 0);
        assert_ne!(label, 0, "background is not an object");
        let mine: Vec<usize> = (0..pixels)
            .filter(|p| instance_of(&full, *p) == label)
            .collect();
        assert_eq!(
            cloud.width as usize,
            mine.len(),
            "every point of object {label}, no other"
        );
        for (k, pixel) in mine.iter().enumerate() {
            let (out_at, in_at) = (k * 20, pixel * 20);
            assert_eq!(
                cloud.data[out_at + 12..out_at + 20],
                full.data[in_at + 12..in_at + 20],
                "rgb and id of pixel {pixel} unchanged, in input order"
            );
            assert!(x_of(&cloud, k).is_finite());
        }
        last_seen.insert(label, m.log_time);
    }
    assert!(
        last_seen[&2] <= *removed_at,
        "no cloud of the box after its removal"
    );
    assert!(
        last_seen[&1] > *removed_at + 300_000_000,
        "the ball goes on"
    );
}

#[test]
fn an_organized_cloud_keeps_its_shape_with_nan_pixels_in_place() {
    let ball = sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 32);
    let camera = Camera::looking_at(&ball, Vector3::new(0.0, -1.0, 0.5), 1.5, 64, 48);
    let object = [SeenObject {
        shape: &ball,
        instance: 0,
        rgb: [10, 200, 10],
    }];
    let header = Header {
        stamp: Time::default(),
        frame_id: FRAME.into(),
    };
    let cloud = camera_cloud(&object, &camera, header).unwrap();
    let pixels = 64 * 48;
    let misses = (0..pixels).filter(|p| x_of(&cloud, *p).is_nan()).count();
    assert!(
        misses > 0 && misses < pixels - 200,
        "{misses} of {pixels} pixels miss the ball"
    );
    // No instance field by this name: the whole cloud is one object. It is read from a
    // downsampled copy of 300 points, every point still deformed, and its deformed clouds go
    // out at 15 Hz while it steps at 60.
    let params = common::params(&[
        ("instance_field", json!("segment_id")),
        ("inference.max_build_points", json!(300)),
        ("publish.rate_hz", json!(15.0)),
    ]);
    let seen = pixels - misses;
    assert!(seen > 350, "{seen} points: more than the build reads");
    let out = replay_clouds("organized", &[(0.1, cloud.clone())], params);
    let ready = common::statuses(&out, "shape_ready");
    assert!(
        ready[0].1.message.contains(&format!(
            "{seen} points (its shape read from a voxel-downsampled"
        )),
        "{}",
        ready[0].1.message
    );
    let deformed: Vec<PointCloud2> = out
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .map(|m| from_cdr(&m.data).unwrap())
        .collect();
    let steps = out.iter().filter(|m| m.topic == "/physskin/state").count();
    assert!(
        deformed.len() * 4 >= steps - 4 && deformed.len() * 4 <= steps + 4,
        "{} deformed clouds for {steps} steps at 15 of 60 Hz",
        deformed.len()
    );
    assert!(deformed.len() >= 5);
    for d in &deformed {
        assert_eq!((d.height, d.width, d.row_step), (48, 64, cloud.row_step));
        assert!(!d.is_dense);
        for p in 0..pixels {
            assert_eq!(
                x_of(d, p).is_nan(),
                x_of(&cloud, p).is_nan(),
                "pixel {p} keeps its place"
            );
        }
    }
}

/// Two objects of one labelled cloud touch each other in the node as in a scene: a 0.16 m
/// block 5 mm above a 0.2 m one, both on the floor of the fixed frame, comes to rest on the
/// bottom one. Stepped apart, it would fall through it to the floor.
/// The lattice points on the surface of a cube of `side` centered at the origin, about
/// `spacing` apart: what a scanner sees of a block from every side.
fn cube_surface(side: f64, spacing: f64) -> Vec<Vector3<f64>> {
    let n = (side / spacing).round() as i32;
    let at = |i: i32| side * (i as f64 / n as f64 - 0.5);
    let mut points = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            for k in 0..=n {
                if [i, j, k].iter().any(|&c| c == 0 || c == n) {
                    points.push(Vector3::new(at(i), at(j), at(k)));
                }
            }
        }
    }
    points
}

#[test]
fn objects_of_one_cloud_rest_on_each_other() {
    use physskin::msg::PointField;
    let blocks = [(1u16, 0.2, 0.1), (2u16, 0.16, 0.285)];
    let mut data = Vec::new();
    for (instance, side, height) in blocks {
        for p in &cube_surface(side, 0.01) {
            for c in [p.x, p.y, p.z + height] {
                data.extend_from_slice(&(c as f32).to_le_bytes());
            }
            data.extend_from_slice(&instance.to_le_bytes());
            data.extend_from_slice(&[0, 0]);
        }
    }
    let cloud = PointCloud2 {
        header: Header {
            stamp: Time::default(),
            frame_id: "world".into(),
        },
        height: 1,
        width: (data.len() / 16) as u32,
        fields: [("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("instance", 12, 4)] // FLOAT32, UINT16
            .map(|(name, offset, datatype)| PointField {
                name: name.into(),
                offset,
                datatype,
                count: 1,
            })
            .to_vec(),
        is_bigendian: false,
        point_step: 16,
        row_step: data.len() as u32,
        data,
        is_dense: true,
    };
    let params = common::params(&[
        ("fixed_frame", json!("world")),
        ("floor_z", json!(0.0)),
        ("simulation.support", json!("floor")),
    ]);
    let out = replay_clouds("stacked", &[(0.1, cloud)], params);
    let lowest_of_top = out
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .map(|m| from_cdr::<PointCloud2>(&m.data).unwrap())
        .rfind(|c| u16::from_le_bytes(c.data[12..14].try_into().unwrap()) == 2)
        .map(|c| {
            (0..c.width as usize)
                .map(|i| f32::from_le_bytes(c.data[i * 16 + 8..i * 16 + 12].try_into().unwrap()))
                .fold(f32::INFINITY, f32::min)
        })
        .expect("the top block's deformed clouds");
    println!("the top block's lowest point after 1 s: {lowest_of_top:.4} m");
    assert!(
        (0.19..0.205).contains(&lowest_of_top),
        "the top block should rest on the bottom one's top face at 0.2 m, not sink: {lowest_of_top} m"
    );
}

/// Two instances that split the objects (`instances.shard` 0/2 and 1/2) take one camera's
/// eight labelled objects four each, by id modulo 2, each object once; their shape ids never
/// meet, and each build names its shard.
#[test]
fn two_shards_take_the_objects_of_one_cloud_once_each() {
    let cloud = common::scenes::objects_on_a_table(8, 320, 240);
    let clouds: Vec<(f64, PointCloud2)> =
        (1..=2).map(|i| (0.1 * i as f64, cloud.clone())).collect();
    let mut taken: BTreeMap<i64, u32> = BTreeMap::new();
    for k in 0..2u32 {
        let params = common::params(&[("instances.shard", json!(format!("{k}/2")))]);
        let out = replay_clouds(&format!("shard-{k}"), &clouds, params);
        let ready = common::statuses(&out, "shape_ready");
        assert_eq!(ready.len(), 4, "four objects each: {ready:?}");
        for (_, s) in &ready {
            assert!(
                s.message.contains(&format!("(shard {k}/2)")),
                "{}",
                s.message
            );
            assert_eq!((s.shape_id - 1) % 2, k, "ids k + 1 + 2 j: {}", s.shape_id);
            let label: i64 = s
                .message
                .split("instance ")
                .nth(1)
                .and_then(|rest| rest.split(|c: char| !c.is_ascii_digit()).next())
                .and_then(|id| id.parse().ok())
                .unwrap_or_else(|| panic!("no instance in {}", s.message));
            assert_eq!(label % 2, i64::from(k), "{}", s.message);
            assert!(
                taken.insert(label, s.shape_id).is_none(),
                "{label} taken twice"
            );
        }
    }
    assert_eq!(
        taken.keys().copied().collect::<Vec<_>>(),
        (1..=8).collect::<Vec<_>>()
    );
    let ids: BTreeSet<u32> = taken.values().copied().collect();
    assert_eq!(ids.len(), 8, "no shape id twice: {taken:?}");
}
