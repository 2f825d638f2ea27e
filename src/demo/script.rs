//! The demo scene, written down once: which shapes arrive when (as clouds and meshes), and
//! which pokes follow. `write_demo_bag` turns it into `bags/demo.mcap`; the demo's FEM reference
//! reads the same script, so both sides see the same forces.

use std::path::Path;

use nalgebra::Vector3;
use rand::distr::weighted::WeightedIndex;
use rand::distr::Distribution;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::bag::{BagError, BagWriter, RecordOptions, RecordSummary};
use crate::geometry::{bundled, sdf_mesh, Shape};
use crate::msg::cloud::encode_cloud;
use crate::msg::{
    encode, to_cdr, Header, Interaction, Mesh, MeshStamped, MeshTriangle, Point, Time,
    Vector3 as RosVector3,
};
use crate::runtime::topic_table;

/// Log time of the demo's first message: 2026-01-01T00:00:00Z, ns.
pub const DEMO_START_NS: i64 = 1_767_225_600_000_000_000;

/// How a shape reaches the node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Delivery {
    /// sensor_msgs/PointCloud2 of this many points sampled from the surface.
    Cloud(usize),
    /// physskin/MeshStamped (a mesh with its frame).
    MeshStamped,
    /// shape_msgs/Mesh (in the node's `mesh_frame`, "world").
    Mesh,
}

/// One object of the demo.
#[derive(Clone, Debug)]
pub struct DemoShape {
    /// The object's name; the picture's labels show it beside a frame of another name.
    pub name: &'static str,
    /// Its frame (the object's identity in the node).
    pub frame: &'static str,
    /// How it reaches the node.
    pub delivery: Delivery,
    /// Arrival, s after the start.
    pub at_s: f64,
    /// Its geometry in world units, already placed in the scene.
    pub shape: Shape,
}

/// A force on a material point of a shape.
#[derive(Clone, Debug)]
pub struct DemoPoke {
    /// The frame of the shape it pokes.
    pub frame: &'static str,
    /// When it starts, s after the recording's start ([`DEMO_START_NS`]).
    pub at_s: f64,
    /// Rest position of the material point, world units.
    pub point: Vector3<f64>,
    /// The force, N.
    pub force: Vector3<f64>,
    /// How long it acts, s.
    pub duration_s: f64,
}

/// The demo: three shapes, three ways in, nine pokes.
pub struct DemoScript {
    /// The objects, in order of arrival.
    pub shapes: Vec<DemoShape>,
    /// The pokes, in order of time.
    pub pokes: Vec<DemoPoke>,
}

fn moved(shape: Shape, offset: Vector3<f64>) -> Shape {
    Shape {
        positions: shape.positions.iter().map(|p| p + offset).collect(),
        ..shape
    }
}

/// The topmost point of a shape, nudged to the side by `side`.
fn top(shape: &Shape, side: Vector3<f64>) -> Vector3<f64> {
    let p = shape
        .positions
        .iter()
        .max_by(|a, b| (a.z + a.dot(&side)).total_cmp(&(b.z + b.dot(&side))))
        .expect("a shape has points");
    *p
}

impl DemoScript {
    /// The demo: the creature as a 3,000-point cloud at 0 s, a ball as a stamped mesh at
    /// 0.2 s, a rounded block as a mesh at 0.4 s, then nine 0.2 s pokes from 0.8 s to 6 s.
    pub fn new() -> Self {
        let creature = moved(
            bundled("creature").expect("a bundled shape"),
            Vector3::new(0.0, 0.0, 0.35),
        );
        let ball = moved(
            sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.2, 0.25, 24),
            Vector3::new(0.9, 0.0, 0.2),
        );
        // A box with rounded edges, fine enough that its deformed vertices show the motion.
        let block = moved(
            sdf_mesh(
                &|p: &Vector3<f64>| {
                    let q = p.abs() - Vector3::new(0.1, 0.1, 0.22);
                    q.sup(&Vector3::zeros()).norm() + q.max().min(0.0) - 0.025
                },
                0.3,
                24,
            ),
            Vector3::new(1.6, 0.0, 0.25),
        );
        // Pokes of about half the object's weight (1000 kg/m^3), each on a point of its top.
        let poke = |frame, at_s, shape: &Shape, side: [f64; 3], force: [f64; 3]| DemoPoke {
            frame,
            at_s,
            point: top(shape, Vector3::from(side)),
            force: Vector3::from(force),
            duration_s: 0.2,
        };
        let pokes = vec![
            poke(
                "creature",
                0.8,
                &creature,
                [0.5, 0.0, 0.0],
                [0.0, 300.0, 0.0],
            ),
            poke("ball", 1.3, &ball, [0.0; 3], [200.0, 0.0, 0.0]),
            poke("world", 1.8, &block, [0.1, 0.1, 0.0], [-150.0, 100.0, 0.0]),
            poke(
                "creature",
                2.5,
                &creature,
                [-0.5, 0.0, 0.0],
                [0.0, -250.0, -100.0],
            ),
            poke("ball", 3.2, &ball, [0.2, 0.0, 0.0], [-150.0, 150.0, -50.0]),
            poke("world", 3.9, &block, [-0.1, 0.0, 0.0], [120.0, 0.0, 0.0]),
            poke(
                "creature",
                4.6,
                &creature,
                [0.3, 0.2, 0.0],
                [200.0, 0.0, 150.0],
            ),
            poke("ball", 5.3, &ball, [0.0, -0.2, 0.0], [0.0, 200.0, 0.0]),
            poke("world", 6.0, &block, [0.0, 0.1, 0.0], [0.0, -150.0, 0.0]),
        ];
        Self {
            shapes: vec![
                DemoShape {
                    name: "creature",
                    frame: "creature",
                    delivery: Delivery::Cloud(3000),
                    at_s: 0.0,
                    shape: creature,
                },
                DemoShape {
                    name: "ball",
                    frame: "ball",
                    delivery: Delivery::MeshStamped,
                    at_s: 0.2,
                    shape: ball,
                },
                DemoShape {
                    name: "block",
                    frame: "world",
                    delivery: Delivery::Mesh,
                    at_s: 0.4,
                    shape: block,
                },
            ],
            pokes,
        }
    }

    /// Log time of `s` seconds after the start, ns.
    pub fn time_ns(s: f64) -> i64 {
        DEMO_START_NS + (s * 1e9).round() as i64
    }
}

impl Default for DemoScript {
    fn default() -> Self {
        Self::new()
    }
}

/// `count` points spread over a mesh's surface by area, as a depth sensor would see it all
/// (fixed seed).
pub fn cloud_points(shape: &Shape, count: usize) -> Vec<Vector3<f64>> {
    let areas: Vec<f64> = (0..shape.triangles.len())
        .map(|t| {
            let [a, b, c] = shape.triangle(t);
            (b - a).cross(&(c - a)).norm() / 2.0
        })
        .collect();
    let Ok(pick) = WeightedIndex::new(&areas) else {
        return shape.positions.clone();
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    (0..count)
        .map(|_| {
            let [a, b, c] = shape.triangle(pick.sample(&mut rng));
            let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            a + (b - a) * u + (c - a) * v
        })
        .collect()
}

/// Writes the script's inputs as an MCAP recording, as the node would have recorded them.
pub fn write_demo_bag(script: &DemoScript, path: &Path) -> Result<RecordSummary, BagError> {
    let t = &crate::runtime::Topics::default_resolved();
    let mut writer = BagWriter::create(RecordOptions {
        path: path.into(),
        ..Default::default()
    })?;
    for topic in topic_table(t) {
        if [&t.points, &t.mesh, &t.mesh_stamped, &t.interaction].contains(&&topic.name) {
            writer.add_topic(topic)?;
        }
    }
    let header = |frame: &str, ns: i64| Header {
        stamp: Time::from_nanos(ns),
        frame_id: frame.into(),
    };
    let mut entries: Vec<(i64, &str, Vec<u8>)> = Vec::new();
    for s in &script.shapes {
        let ns = DemoScript::time_ns(s.at_s);
        let mesh = || Mesh {
            triangles: s
                .shape
                .triangles
                .iter()
                .map(|t| MeshTriangle { vertex_indices: *t })
                .collect(),
            vertices: s
                .shape
                .positions
                .iter()
                .map(|p| Point {
                    x: p.x,
                    y: p.y,
                    z: p.z,
                })
                .collect(),
        };
        let (topic, data) = match s.delivery {
            Delivery::Cloud(count) => {
                let xyz: Vec<f32> = cloud_points(&s.shape, count)
                    .iter()
                    .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                    .collect();
                (
                    &t.points,
                    encode(&encode_cloud(header(s.frame, ns), &xyz, &[], &[])),
                )
            }
            Delivery::MeshStamped => (
                &t.mesh_stamped,
                to_cdr(&MeshStamped {
                    header: header(s.frame, ns),
                    mesh: mesh(),
                }),
            ),
            Delivery::Mesh => (&t.mesh, to_cdr(&mesh())),
        };
        entries.push((ns, topic, data));
    }
    for p in &script.pokes {
        let ns = DemoScript::time_ns(p.at_s);
        let poke = Interaction {
            header: header(p.frame, ns),
            shape_id: 0,
            kind: Interaction::FORCE,
            point: Point {
                x: p.point.x,
                y: p.point.y,
                z: p.point.z,
            },
            force: RosVector3 {
                x: p.force.x,
                y: p.force.y,
                z: p.force.z,
            },
            duration: p.duration_s,
            radius: 0.0,
        };
        entries.push((ns, &t.interaction, to_cdr(&poke)));
    }
    entries.sort_by_key(|e| e.0);
    for (ns, topic, data) in entries {
        writer.write(topic, ns, ns, &data)?;
    }
    writer.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::read_messages;

    #[test]
    fn the_demo_bag_is_what_its_script_writes() {
        let path = std::env::temp_dir().join(format!("physskin-demo-{}.mcap", std::process::id()));
        write_demo_bag(&DemoScript::new(), &path).unwrap();
        let fresh = read_messages(&std::fs::read(&path).unwrap(), "fresh").unwrap();
        std::fs::remove_file(&path).unwrap();
        let bundled = read_messages(super::super::DEMO_BAG, "bags/demo.mcap").unwrap();
        assert_eq!(fresh.len(), bundled.len());
        for (a, b) in fresh.iter().zip(&bundled) {
            assert_eq!(
                (&a.topic, a.log_time, &a.data),
                (&b.topic, b.log_time, &b.data)
            );
        }
    }
}
