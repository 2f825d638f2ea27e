//! The corpus of bad inputs. Every entry goes through the node's own pipeline (a replay: the
//! same decoders, builder and stage) beside a good object. Each must get its own clear status
//! (matched by time and by the words that name the problem), nothing may panic or produce a
//! NaN, and the good object must be stepped and published on every tick throughout.

use std::path::PathBuf;

mod common;

use common::root;
use physskin::bag::{read_messages, BagWriter, RecordOptions};
use physskin::msg::{
    from_cdr, to_cdr, Header, Interaction, Mesh, MeshTriangle, Point, PointCloud2, PointField,
    QosProfile, RosMessage, Status, Time, TopicInfo, Vector3 as RosVector,
};
use physskin::replay::{replay, ReplayOptions};
use physskin::runtime::NodeParams;
use physskin::skinning::NeuralModel;

const POINTS: &str = "/physskin/points";
const MESH: &str = "/physskin/mesh";
const INTERACTION: &str = "/physskin/interaction";

fn scratch(name: &str) -> PathBuf {
    let dir = root().join("target/test-hard-inputs").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Points on the surface of a box of the given size centred at `center` (a sensor's view).
fn box_surface(size: [f64; 3], center: [f64; 3], per_side: usize) -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    let g = |i: usize| i as f64 / (per_side - 1) as f64 - 0.5;
    for axis in 0..3 {
        for side in [-0.5, 0.5] {
            for i in 0..per_side {
                for j in 0..per_side {
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = g(i);
                    p[(axis + 2) % 3] = g(j);
                    points.push([
                        center[0] + p[0] * size[0],
                        center[1] + p[1] * size[1],
                        center[2] + p[2] * size[2],
                    ]);
                }
            }
        }
    }
    points
}

fn field(name: &str, offset: u32, datatype: u8) -> PointField {
    PointField {
        name: name.into(),
        offset,
        datatype,
        count: 1,
    }
}

/// A float32 x, y, z cloud, little-endian unless `big`.
fn cloud(frame: &str, points: &[[f64; 3]], big: bool) -> PointCloud2 {
    let mut data = Vec::with_capacity(points.len() * 12);
    for p in points {
        for c in p {
            let v = *c as f32;
            data.extend(if big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            });
        }
    }
    PointCloud2 {
        header: Header {
            stamp: Time::default(),
            frame_id: frame.into(),
        },
        height: 1,
        width: points.len() as u32,
        fields: vec![field("x", 0, 7), field("y", 4, 7), field("z", 8, 7)],
        is_bigendian: big,
        point_step: 12,
        row_step: 12 * points.len() as u32,
        data,
        is_dense: true,
    }
}

/// A closed box mesh (12 triangles, outward), scaled and moved.
fn box_mesh(size: f64, center: [f64; 3]) -> Mesh {
    let shape = physskin::geometry::box_mesh(nalgebra::Vector3::repeat(size));
    Mesh {
        vertices: shape
            .positions
            .iter()
            .map(|p| Point {
                x: p.x + center[0],
                y: p.y + center[1],
                z: p.z + center[2],
            })
            .collect(),
        triangles: shape
            .triangles
            .iter()
            .map(|&vertex_indices| MeshTriangle { vertex_indices })
            .collect(),
    }
}

fn interaction(shape_id: u32, kind: u8, force: [f64; 3]) -> Interaction {
    Interaction {
        header: Header::default(),
        shape_id,
        kind,
        point: Point {
            x: 0.0,
            y: 0.0,
            z: 0.1,
        },
        force: RosVector {
            x: force[0],
            y: force[1],
            z: force[2],
        },
        duration: 0.1,
        radius: 0.05,
    }
}

/// What must become of an input.
#[derive(Clone, Copy, Debug)]
enum Expect {
    /// Refused: an ERROR status holding these words.
    Rejected(&'static str),
    /// Built: a `shape_ready` status holding these words.
    Built(&'static str),
    /// An interaction left aside: a WARN status holding these words.
    Ignored(&'static str),
}

struct Case {
    name: &'static str,
    topic: &'static str,
    bytes: Vec<u8>,
    expect: Expect,
}

fn case<M: serde::Serialize>(
    name: &'static str,
    topic: &'static str,
    m: &M,
    expect: Expect,
) -> Case {
    Case {
        name,
        topic,
        bytes: to_cdr(m),
        expect,
    }
}

/// The corpus: one entry per way an input can be wrong (or merely unusual).
fn corpus() -> Vec<Case> {
    use Expect::*;
    let cube = box_surface([0.2, 0.2, 0.2], [0.0, 0.0, 0.1], 14);
    let mut cases = Vec::new();
    let mut clouds = |name: &'static str, c: PointCloud2, expect| {
        cases.push(case(name, POINTS, &c, expect));
    };
    clouds(
        "empty",
        cloud("empty", &[], false),
        Rejected("holds no points"),
    );
    clouds(
        "one_point",
        cloud("one_point", &[[0.1, 0.2, 0.3]], false),
        Rejected("zero extent"),
    );
    let line: Vec<[f64; 3]> = (0..200).map(|i| [i as f64 * 1e-3, 0.0, 0.0]).collect();
    clouds(
        "collinear",
        cloud("collinear", &line, false),
        Rejected("on one line"),
    );
    let plane: Vec<[f64; 3]> = (0..400)
        .map(|i| [(i % 20) as f64 * 0.01, (i / 20) as f64 * 0.01, 0.05])
        .collect();
    clouds(
        "coplanar",
        cloud("coplanar", &plane, false),
        Rejected("on one plane"),
    );
    // One camera's view (optical frame: z forward): the near half of a 0.1 m ball 0.5 m away,
    // and a bumpy flat patch.
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let cap: Vec<[f64; 3]> = (0..6000)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 6000.0;
            let (r, phi) = ((1.0 - z * z).sqrt(), golden * i as f64);
            [0.1 * r * phi.cos(), 0.1 * r * phi.sin(), 0.5 + 0.1 * z]
        })
        .filter(|p| p[2] < 0.5)
        .collect();
    clouds(
        "camera_half_ball",
        cloud("camera_half_ball", &cap, false),
        Built("completed one view"),
    );
    let bumpy: Vec<[f64; 3]> = (0..900)
        .map(|i| {
            let (u, v) = ((i % 30) as f64 * 0.01, (i / 30) as f64 * 0.01);
            [u, v, 0.5 + 0.002 * ((i % 2) as f64)]
        })
        .collect();
    clouds(
        "camera_flat_patch",
        cloud("camera_flat_patch", &bumpy, false),
        Rejected("flat patch"),
    );
    let mut holes = cube.clone();
    for (i, p) in holes.iter_mut().enumerate().filter(|(i, _)| i % 7 == 0) {
        p[i % 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][i % 3];
    }
    // is_dense = true, yet NaN and Inf inside: the flag is not believed.
    clouds(
        "nan_inf_dense_lies",
        cloud("nan_inf_dense_lies", &holes, false),
        Built("NaN or Inf points dropped"),
    );
    clouds(
        "all_nan",
        cloud("all_nan", &[[f64::NAN; 3], [f64::INFINITY; 3]], false),
        Rejected("no finite point"),
    );
    let mut c = cloud("missing_z", &cube, false);
    c.fields.truncate(2);
    clouds("missing_z", c, Rejected("no `z` field"));
    let mut c = cloud("int16_x", &cube, false);
    c.fields[0].datatype = 3;
    clouds("int16_x", c, Rejected("datatype 3"));
    let mut c = cloud("datatype_99", &cube, false);
    c.fields[2].datatype = 99;
    clouds("datatype_99", c, Rejected("datatype 99"));
    let mut c = cloud("short_point_step", &cube, false);
    c.point_step = 8;
    c.row_step = 8 * c.width;
    c.data.truncate(c.row_step as usize);
    clouds(
        "short_point_step",
        c,
        Rejected("does not fit in point_step 8"),
    );
    let mut c = cloud("short_data", &cube, false);
    c.data.truncate(c.data.len() - 5);
    clouds("short_data", c, Rejected("data holds"));
    let mut c = cloud("row_step_short", &cube, false);
    c.row_step = 12;
    clouds("row_step_short", c, Rejected("row_step 12 is smaller"));
    let mut c = cloud("height_lies", &cube, false);
    c.height = 3;
    clouds("height_lies", c, Rejected("data holds"));
    clouds(
        "big_endian",
        cloud("big_endian", &cube, true),
        Built("1176 points"),
    );
    let over_cap: Vec<[f64; 3]> = (0..5000)
        .map(|i| {
            [
                (i % 17) as f64 * 0.01,
                (i % 13) as f64 * 0.01,
                (i % 11) as f64 * 0.01,
            ]
        })
        .collect();
    clouds(
        "over_cap",
        cloud("over_cap", &over_cap, false),
        Rejected("more than max_points = 4000"),
    );
    let tripled: Vec<[f64; 3]> = cube.iter().flat_map(|p| [*p, *p, *p]).collect();
    clouds(
        "duplicates",
        cloud("duplicates", &tripled, false),
        Built("3528 points"),
    );
    let tiny: Vec<[f64; 3]> = cube.iter().map(|p| p.map(|c| c * 1e-5)).collect();
    clouds(
        "micrometre",
        cloud("micrometre", &tiny, false),
        Rejected("smaller than"),
    );
    let huge: Vec<[f64; 3]> = cube.iter().map(|p| p.map(|c| c * 5e4)).collect();
    clouds(
        "ten_kilometres",
        cloud("ten_kilometres", &huge, false),
        Rejected("larger than"),
    );
    let far: Vec<[f64; 3]> = cube
        .iter()
        .map(|p| [p[0] + 1e4, p[1] - 1e4, p[2]])
        .collect();
    clouds(
        "far_from_origin",
        cloud("far_from_origin", &far, false),
        Built("1176 points"),
    );

    let mut mesh = |name: &'static str, m: Mesh, expect| cases.push(case(name, MESH, &m, expect));
    let mut m = box_mesh(0.2, [0.0, 0.0, 0.1]);
    m.triangles[3].vertex_indices[1] = 500;
    mesh(
        "index_out_of_range",
        m,
        Rejected("indexes past the 8 vertices"),
    );
    mesh("no_vertices", Mesh::default(), Rejected("has no points"));
    let mut m = box_mesh(0.2, [0.0, 0.0, 0.1]);
    // Zero-area triangles: a repeated vertex and three on one edge.
    m.triangles.push(MeshTriangle {
        vertex_indices: [0, 0, 1],
    });
    m.triangles.push(MeshTriangle {
        vertex_indices: [2, 2, 2],
    });
    mesh("degenerate_triangles", m, Built("8 points"));
    let mut m = box_mesh(0.2, [0.0, 0.0, 0.1]);
    m.triangles.truncate(10);
    mesh("open_surface", m, Built("8 points"));
    // Two boxes sharing one edge: four triangles meet there.
    let mut m = box_mesh(0.2, [0.0, 0.0, 0.1]);
    let other = box_mesh(0.2, [0.2, 0.2, 0.1]);
    let base = m.vertices.len() as u32;
    m.vertices.extend(other.vertices);
    m.triangles
        .extend(other.triangles.iter().map(|t| MeshTriangle {
            vertex_indices: t.vertex_indices.map(|v| v + base),
        }));
    mesh("non_manifold", m, Built("16 points"));

    let mut raw = |name: &'static str, bytes, expect| {
        cases.push(Case {
            name,
            topic: POINTS,
            bytes,
            expect,
        })
    };
    let whole = to_cdr(&cloud("cut", &cube, false));
    raw(
        "cdr_cut_short",
        whole[..whole.len() / 2].to_vec(),
        Rejected(POINTS),
    );
    let mut odd = to_cdr(&cloud("odd", &cube, false));
    odd[1] = 0x07;
    raw(
        "cdr_unknown_representation",
        odd,
        Rejected("unknown CDR representation 0x07"),
    );
    let mut poke = |name: &'static str, i: Interaction, expect| {
        cases.push(case(name, INTERACTION, &i, expect))
    };
    poke(
        "nan_force",
        interaction(1, Interaction::FORCE, [f64::NAN, 0.0, 0.0]),
        Ignored("non-finite"),
    );
    poke(
        "unknown_shape",
        interaction(999, Interaction::FORCE, [1.0, 0.0, 0.0]),
        Ignored("no shape matches shape_id 999"),
    );
    poke(
        "unknown_kind",
        interaction(1, 9, [1.0, 0.0, 0.0]),
        Ignored("unknown kind 9"),
    );
    poke(
        "pin_in_empty_space",
        Interaction {
            point: Point {
                x: 5.0,
                y: 5.0,
                z: 5.0,
            },
            ..interaction(1, Interaction::PIN, [0.0; 3])
        },
        Ignored("no material within"),
    );
    cases
}

/// When case `k` is sent: 0.5 s + k * 0.25 s (off the tick grid, so its statuses are its own).
fn case_time(k: usize) -> i64 {
    500_000_000 + k as i64 * 250_000_000 + 1_234
}

/// A recording of the node's input topics holding the good cube (`per_side`^2 points a face)
/// at t = 0.
fn writer_with_good_cube(path: &std::path::Path, per_side: usize) -> BagWriter {
    let mut writer = BagWriter::create(RecordOptions {
        path: path.into(),
        ..Default::default()
    })
    .unwrap();
    writer
        .add_topic(TopicInfo::of::<PointCloud2>(POINTS, QosProfile::sensor(5)))
        .unwrap();
    writer
        .add_topic(TopicInfo::of::<Mesh>(MESH, QosProfile::sensor(5)))
        .unwrap();
    writer
        .add_topic(TopicInfo::of::<Interaction>(
            INTERACTION,
            QosProfile::reliable(10, false),
        ))
        .unwrap();
    let good = box_surface([0.2, 0.2, 0.2], [0.0, 0.0, 0.1], per_side);
    writer
        .write(POINTS, 0, 0, &to_cdr(&cloud("good", &good, false)))
        .unwrap();
    writer
}

/// The bag: the good cube at t = 0, a push on it every 0.5 s, and the cases.
fn corpus_bag(path: &std::path::Path, cases: &[Case]) {
    let mut writer = writer_with_good_cube(path, 14);
    let end = case_time(cases.len());
    for (n, t) in (1..).zip((250_000_000..end).step_by(500_000_000)) {
        let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
        let push = interaction(1, Interaction::FORCE, [sign * 5.0, 0.0, 0.0]);
        writer.write(INTERACTION, t, t, &to_cdr(&push)).unwrap();
    }
    for (k, c) in cases.iter().enumerate() {
        let t = case_time(k);
        writer.write(c.topic, t, t, &c.bytes).unwrap();
    }
    writer.finish().unwrap();
}

#[test]
fn every_bad_input_gets_its_own_clear_status_and_the_good_object_runs_on() {
    let dir = scratch("corpus");
    let cases = corpus();
    corpus_bag(&dir.join("in.mcap"), &cases);
    let model = NeuralModel::bundled().unwrap();
    let params = common::params(&[("max_points", serde_json::json!(4000))]);
    let options = ReplayOptions {
        params,
        record: Some(RecordOptions {
            path: dir.join("out.mcap"),
            ..Default::default()
        }),
        tail_s: 0.5,
        ..Default::default()
    };
    let bytes = std::fs::read(dir.join("in.mcap")).unwrap();
    let (mut ticks_with_good, mut non_finite) = (0, Vec::new());
    let summary = replay(&bytes, "corpus", &model, &options, &mut |tick| {
        for b in tick.stage.bodies() {
            if b.frame == "good" {
                ticks_with_good += 1;
            }
            if !b.body.deformed().iter().all(|c| c.is_finite()) {
                non_finite.push((tick.time_ns, b.frame.clone()));
            }
        }
    })
    .expect("a replay of bad inputs completes");
    assert!(non_finite.is_empty(), "NaN or Inf in {non_finite:?}");
    assert_eq!(
        ticks_with_good, summary.ticks,
        "the good object was on stage every tick"
    );

    let recorded = read_messages(&std::fs::read(dir.join("out.mcap")).unwrap(), "out").unwrap();
    let statuses: Vec<Status> = recorded
        .iter()
        .filter(|m| m.topic == "/physskin/status")
        .map(|m| from_cdr(&m.data).unwrap())
        .collect();
    let good_frames = recorded
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .filter(|m| from_cdr::<PointCloud2>(&m.data).unwrap().header.frame_id == "good")
        .count();
    assert!(
        good_frames as u64 + 1 >= summary.ticks,
        "the good object was published on every tick: {good_frames} frames in {} ticks",
        summary.ticks
    );

    let mut failures = Vec::new();
    let mut rejected = 0;
    for (k, c) in cases.iter().enumerate() {
        let at: Vec<&Status> = statuses
            .iter()
            .filter(|s| s.header.stamp.nanos() == case_time(k))
            .collect();
        let (level, words) = match c.expect {
            Expect::Rejected(words) => {
                rejected += 1;
                (Status::ERROR, words)
            }
            Expect::Built(words) => (Status::INFO, words),
            Expect::Ignored(words) => (Status::WARN, words),
        };
        let told: Vec<String> = at
            .iter()
            .map(|s| format!("[{} {}] {}", s.level, s.event, s.message))
            .collect();
        if !at
            .iter()
            .any(|s| s.level == level && s.message.contains(words))
        {
            failures.push(format!("{}: expected {:?}, got {told:?}", c.name, c.expect));
        } else {
            eprintln!("{}: {}", c.name, told.join(" | "));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(summary.rejected, rejected, "every rejection counted once");
}

#[test]
fn ten_million_points_are_refused_before_any_work_under_the_cap() {
    let count = 10_000_000usize;
    let mut c = cloud("huge", &[], false);
    c.width = count as u32;
    c.row_step = 12 * c.width;
    c.data = vec![0u8; 12 * count];
    // The node's cap, read by its ROS name; the node decodes every cloud with it first.
    let cap = NodeParams::default()
        .flattened()
        .into_iter()
        .find_map(|(name, value)| (name == "max_points").then(|| value.as_u64()).flatten())
        .expect("max_points") as usize;
    let refused = physskin::msg::cloud::decode_cloud(&c, cap)
        .expect_err("refused")
        .to_string();
    assert!(
        refused.contains("10000000 points, more than max_points = 1000000"),
        "{refused}"
    );
}

/// A recording of the good cube, then one push per chunk (each flushed as its own chunk).
fn chunked_bag(path: &std::path::Path, pushes: usize) {
    let mut writer = writer_with_good_cube(path, 10);
    writer.flush().unwrap();
    for k in 1..=pushes as i64 {
        let push = interaction(1, Interaction::FORCE, [1.0, 0.0, 0.0]);
        writer
            .write(INTERACTION, k * 100_000_000, 0, &to_cdr(&push))
            .unwrap();
        writer.flush().unwrap();
    }
    writer.finish().unwrap();
}

fn replay_damaged(bytes: &[u8]) -> physskin::replay::ReplaySummary {
    let model = NeuralModel::bundled().unwrap();
    replay(
        bytes,
        "damaged",
        &model,
        &ReplayOptions::default(),
        &mut |_| {},
    )
    .expect("a damaged recording still replays what is intact")
}

#[test]
fn a_chunk_with_a_bad_crc_costs_only_its_own_messages() {
    let dir = scratch("bad-crc");
    chunked_bag(&dir.join("in.mcap"), 4);
    let mut bytes = std::fs::read(dir.join("in.mcap")).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    assert_eq!(summary.chunk_indexes.len(), 5);
    // Flip one byte inside the third chunk's records.
    let third = &summary.chunk_indexes[2];
    let at = (third.chunk_start_offset + third.chunk_length - 3) as usize;
    bytes[at] ^= 0x5a;

    let recording = physskin::bag::read_recording(&bytes, "flipped").unwrap();
    assert_eq!(recording.messages.len(), 4, "5 messages, 1 lost");
    assert_eq!(recording.damage.len(), 1, "{:?}", recording.damage);
    assert!(
        recording.damage[0].contains(&format!("chunk at byte {}", third.chunk_start_offset)),
        "{:?}",
        recording.damage
    );
    assert!(
        read_messages(&bytes, "flipped")
            .unwrap_err()
            .to_string()
            .contains("chunk at byte"),
        "strict reading refuses it"
    );
    let replayed = replay_damaged(&bytes);
    assert_eq!(replayed.input_messages, 4);
    assert_eq!(replayed.shapes.len(), 1);
    assert_eq!(replayed.damage.len(), 1);
    assert!(
        replayed.damage[0].starts_with("damaged: chunk at byte"),
        "{:?}",
        replayed.damage
    );
}

#[test]
fn a_recording_cut_short_replays_up_to_the_cut() {
    let dir = scratch("cut");
    chunked_bag(&dir.join("in.mcap"), 4);
    let bytes = std::fs::read(dir.join("in.mcap")).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    // Cut inside the fourth chunk: the first three are whole.
    let fourth = &summary.chunk_indexes[3];
    let cut = &bytes[..(fourth.chunk_start_offset + fourth.chunk_length / 2) as usize];
    let recording = physskin::bag::read_recording(cut, "cut").unwrap();
    assert_eq!(recording.messages.len(), 3);
    assert!(
        recording.damage[0].contains("ends inside a record")
            && recording.damage[0].contains("3 messages read before"),
        "{:?}",
        recording.damage
    );
    let replayed = replay_damaged(cut);
    assert_eq!(replayed.input_messages, 3);
    assert_eq!(replayed.shapes.len(), 1);
    // The strict reader refuses the cut file, naming it once.
    let strict = physskin::bag::read_messages(cut, "cut.mcap")
        .unwrap_err()
        .to_string();
    assert!(
        strict.starts_with("reading MCAP cut.mcap: the file ends inside a record")
            && strict.matches("cut.mcap").count() == 1,
        "{strict}"
    );
    // Not MCAP at all: an error naming the file.
    let refused = physskin::bag::read_recording(b"PLY\nformat ascii", "notes.txt").unwrap_err();
    assert!(
        refused.to_string().contains("notes.txt: not an MCAP file"),
        "{refused}"
    );
}

/// One MCAP record: opcode, length, body.
fn record(opcode: u8, body: &[u8]) -> Vec<u8> {
    let mut r = vec![opcode];
    r.extend((body.len() as u64).to_le_bytes());
    r.extend(body);
    r
}

fn string(s: &str) -> Vec<u8> {
    let mut b = (s.len() as u32).to_le_bytes().to_vec();
    b.extend(s.as_bytes());
    b
}

fn channel(id: u16, schema_id: u16, topic: &str) -> Vec<u8> {
    let mut body = id.to_le_bytes().to_vec();
    body.extend(schema_id.to_le_bytes());
    body.extend(string(topic));
    body.extend(string("cdr"));
    body.extend(0u32.to_le_bytes()); // no metadata
    record(0x04, &body)
}

fn message(channel_id: u16, log_time: u64, data: &[u8]) -> Vec<u8> {
    let mut body = channel_id.to_le_bytes().to_vec();
    body.extend(0u32.to_le_bytes());
    body.extend(log_time.to_le_bytes());
    body.extend(log_time.to_le_bytes());
    body.extend(data);
    record(0x05, &body)
}

#[test]
fn a_channel_without_its_schema_is_named_and_the_others_replay() {
    // Written by hand: no writer we have would produce it.
    let good = to_cdr(&cloud(
        "good",
        &box_surface([0.2, 0.2, 0.2], [0.0, 0.0, 0.1], 10),
        false,
    ));
    let mut schema = 1u16.to_le_bytes().to_vec();
    schema.extend(string(&PointCloud2::type_name()));
    schema.extend(string("ros2msg"));
    schema.extend(string(&physskin::msg::schema_text::<PointCloud2>()));
    let mut header = string("ros2");
    header.extend(string("hand"));
    let mut bytes = mcap::MAGIC.to_vec();
    bytes.extend(record(0x01, &header));
    bytes.extend(record(0x03, &schema));
    bytes.extend(channel(1, 1, POINTS));
    bytes.extend(channel(2, 7, INTERACTION));
    bytes.extend(message(1, 0, &good));
    bytes.extend(message(
        2,
        50_000_000,
        &to_cdr(&interaction(1, Interaction::FORCE, [1.0, 0.0, 0.0])),
    ));
    bytes.extend(message(9, 60_000_000, b"orphan"));
    bytes.extend(record(0x0F, &0u32.to_le_bytes()));
    bytes.extend(record(0x02, &[0u8; 20]));
    bytes.extend(mcap::MAGIC);

    let recording = physskin::bag::read_recording(&bytes, "hand.mcap").unwrap();
    assert_eq!(recording.messages.len(), 2);
    let damage = recording.damage.join("\n");
    assert!(
        damage.contains("channel 2 (/physskin/interaction) names schema 7"),
        "{damage}"
    );
    assert!(damage.contains("1 messages name a channel"), "{damage}");
    let replayed = replay_damaged(&bytes);
    assert_eq!(
        replayed.shapes.len(),
        1,
        "the cloud with its schema is built"
    );
    assert_eq!(replayed.rejected, 1, "the push without a type is refused");
}

#[test]
fn bad_parameters_are_refused_by_name_and_leave_the_old_ones() {
    use serde_json::Value;
    let params = NodeParams::default();
    let bad: [(&str, Value); 9] = [
        ("material.young", Value::from(-5.0)),
        ("material.poisson", Value::from(0.5)),
        ("material.density", Value::from(f64::NAN)),
        ("rate_hz", Value::from(0.0)),
        ("max_points", Value::from(2)),
        ("simulation.damping", Value::from(-1.0)),
        ("simulation.solver", Value::from("magic")),
        ("no_such_parameter", Value::from(1)),
        ("rate_hz", Value::from("fast")),
    ];
    for (name, value) in bad {
        let refused = params
            .with(name, value.clone())
            .err()
            .unwrap_or_else(|| panic!("{name} = {value:?} was accepted"));
        let text = refused.to_string();
        let leaf = name.rsplit('.').next().unwrap();
        assert!(text.contains(leaf), "{name}: {text}");
    }
    for (text, words) in [
        (
            "physskin:\n  ros__parameters:\n    rate_hz: [1, 2]\n",
            "rate_hz",
        ),
        (
            "physskin:\n  ros__parameters:\n    materiel: {}\n",
            "materiel",
        ),
        ("physskin: [unclosed\n", "line 1"),
    ] {
        let refused = NodeParams::from_yaml(text, "/physskin")
            .unwrap_err()
            .to_string();
        assert!(refused.contains(words), "{text:?}: {refused}");
    }
}

#[test]
fn a_chunk_claiming_an_absurd_size_is_skipped_not_allocated() {
    // Found by the mcap_replay fuzz target: the decompressor reserved the claimed size up
    // front, and 2^57 bytes aborted the process.
    let dir = scratch("absurd-size");
    chunked_bag(&dir.join("in.mcap"), 2);
    let mut bytes = std::fs::read(dir.join("in.mcap")).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let second = summary.chunk_indexes[1].chunk_start_offset as usize;
    // Record header (9 bytes), then start and end times; the uncompressed size follows.
    bytes[second + 9 + 16..second + 9 + 24].copy_from_slice(&(1u64 << 57).to_le_bytes());
    let recording = physskin::bag::read_recording(&bytes, "absurd").unwrap();
    assert_eq!(recording.messages.len(), 2, "the other chunks are read");
    assert!(
        recording.damage[0].contains(&format!("chunk at byte {second} skipped"))
            && recording.damage[0].contains("claims 144115188075855872 bytes"),
        "{:?}",
        recording.damage
    );
}

#[test]
fn what_the_fuzzer_found_in_recordings_is_read_around() {
    // The mcap_replay fuzz target's finds, kept as its seeds: a record inside an intact-looking
    // chunk claiming 73 GB (the chunk reader zero-filled that much), an attachment shorter
    // than its own header (mcap's parser sliced past it and panicked), and a record running
    // past the end of an uncompressed chunk (mcap's count of what is left wrapped below zero).
    // Each aborted the fuzzer.
    for (file, words) in [
        ("inner-record-claims-73-gb.mcap", "chunk at byte"),
        (
            "attachment-shorter-than-header.mcap",
            "ends inside a record",
        ),
        (
            "record-past-chunk-end.mcap",
            "a record inside it runs past the chunk's end",
        ),
    ] {
        let bytes = std::fs::read(root().join("fuzz/seeds/mcap_replay").join(file)).unwrap();
        let recording = physskin::bag::read_recording(&bytes, file).unwrap();
        assert!(
            recording.damage.iter().any(|d| d.contains(words)),
            "{file}: the damage is named: {:?}",
            recording.damage
        );
    }
}
