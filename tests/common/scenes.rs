//! Real-sensor inputs shared by tests: a segmenting RGB-D camera's view of objects on a table.

use nalgebra::Vector3;
use physskin::geometry::{box_mesh, sdf_mesh, Camera, Shape};
use physskin::msg::camera_cloud::{camera_cloud, SeenObject};
use physskin::msg::{Header, PointCloud2, Time};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// One mesh holding all of `shapes`, to aim a camera at them together.
fn merged(shapes: &[&Shape]) -> physskin::Result<Shape> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for shape in shapes {
        let base = positions.len() as u32;
        positions.extend_from_slice(&shape.positions);
        triangles.extend(shape.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    Shape::new(positions, None, triangles)
}

/// The optical frame the table scene's clouds are in.
pub const OPTICAL_FRAME: &str = "camera_color_optical_frame";

pub fn moved(shape: Shape, by: Vector3<f64>) -> Shape {
    let positions = shape.positions.iter().map(|p| p + by).collect();
    Shape::new(positions, None, shape.triangles.clone()).unwrap()
}

/// A 0.1 m ball (instance 1, red) and a 0.15 m box (instance 2, blue) on a table (background,
/// 0), seen by one camera 1.5 bounding diagonals away: an organized width x height cloud in the
/// camera's optical frame with float32 x, y, z, a packed rgb and a uint16 `instance`.
pub fn table_scene(width: usize, height: usize) -> PointCloud2 {
    let ball = moved(
        sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.1, 0.12, 32),
        Vector3::new(-0.15, 0.0, 0.1),
    );
    let block = moved(
        box_mesh(Vector3::new(0.15, 0.15, 0.15)),
        Vector3::new(0.15, 0.0, 0.075),
    );
    let aim = merged(&[&ball, &block]).unwrap();
    let camera = Camera::looking_at(&aim, Vector3::new(0.3, -1.0, 0.7), 1.5, width, height);
    let objects = vec![
        SeenObject {
            shape: &ball,
            instance: 1,
            rgb: [220, 30, 30],
        },
        SeenObject {
            shape: &block,
            instance: 2,
            rgb: [30, 30, 220],
        },
    ];
    on_a_table(objects, Vector3::new(1.0, 1.0, 0.02), &camera)
}

/// `objects` standing on a table of `size` (its top at z = 0; background, instance 0), as
/// `camera` sees them, in the optical frame.
fn on_a_table(objects: Vec<SeenObject>, size: Vector3<f64>, camera: &Camera) -> PointCloud2 {
    let table = moved(box_mesh(size), Vector3::new(0.0, 0.0, -size.z / 2.0));
    let background = SeenObject {
        shape: &table,
        instance: 0,
        rgb: [120, 100, 80],
    };
    let objects: Vec<SeenObject> = objects.into_iter().chain([background]).collect();
    let header = Header {
        stamp: Time::default(),
        frame_id: OPTICAL_FRAME.into(),
    };
    camera_cloud(&objects, camera, header).unwrap()
}

/// The frame of the streams' clouds (a camera's, its origin where the camera is).
pub const STREAM_FRAME: &str = "cam";

/// A 0.12 m ball at the origin.
pub fn stream_ball() -> Shape {
    sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.06, 0.08, 24)
}

/// A 0.2 m bar beside where the ball was: another object in its place.
pub fn stream_block() -> Shape {
    moved(
        box_mesh(Vector3::new(0.2, 0.05, 0.05)),
        Vector3::new(0.06, 0.1, 0.0),
    )
}

/// One camera 0.6 m from a 0.12 m ball (or a box beside where it was), in the camera's
/// optical frame, with 2 mm of depth noise at 1 m growing with the square of the depth.
pub fn noisy_view(object: &Shape, seed: u64) -> PointCloud2 {
    let camera = Camera::looking_at(&stream_ball(), Vector3::new(0.5, -1.0, 0.6), 3.5, 96, 72);
    let header = Header {
        stamp: Time::default(),
        frame_id: STREAM_FRAME.into(),
    };
    let seen = [SeenObject {
        shape: object,
        instance: 1,
        rgb: [200, 40, 40],
    }];
    let mut cloud = camera_cloud(&seen, &camera, header).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let step = cloud.point_step as usize;
    for pixel in cloud.data.chunks_exact_mut(step) {
        let xyz: Vec<f32> = (0..3)
            .map(|i| f32::from_le_bytes(pixel[4 * i..4 * i + 4].try_into().unwrap()))
            .collect();
        let depth = (xyz.iter().map(|c| c * c).sum::<f32>()).sqrt();
        if !depth.is_finite() {
            continue;
        }
        // Along the ray, which runs from the optical frame's origin.
        let scale = 1.0 + (unit.sample(&mut rng) * 0.002) as f32 * depth;
        for (i, c) in xyz.iter().enumerate() {
            pixel[4 * i..4 * i + 4].copy_from_slice(&(c * scale).to_le_bytes());
        }
    }
    cloud.fields.retain(|f| f.name != "instance");
    cloud
}

/// `count` objects in two rows on a table (background, 0), instance ids 1 to `count`: balls of
/// 0.08 m and cubes of 0.07 m by turns, 0.16 m apart, seen by one camera as `table_scene`'s.
pub fn objects_on_a_table(count: u16, width: usize, height: usize) -> PointCloud2 {
    let objects: Vec<Shape> = (0..count)
        .map(|i| {
            let at = Vector3::new(
                0.16 * f64::from(i / 2) - 0.08 * f64::from(count / 2),
                0.16 * f64::from(i % 2) - 0.08,
                0.04,
            );
            if i % 2 == 0 {
                moved(sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.04, 0.05, 20), at)
            } else {
                moved(
                    box_mesh(Vector3::new(0.07, 0.07, 0.07)),
                    at - Vector3::new(0.0, 0.0, 0.005),
                )
            }
        })
        .collect();
    let refs: Vec<&Shape> = objects.iter().collect();
    let aim = merged(&refs).unwrap();
    let camera = Camera::looking_at(&aim, Vector3::new(0.2, -1.0, 0.9), 1.3, width, height);
    let seen: Vec<SeenObject> = objects
        .iter()
        .zip(1u16..)
        .map(|(shape, instance)| SeenObject {
            shape,
            instance,
            rgb: [40 * (instance as u8 % 6), 200, 60],
        })
        .collect();
    on_a_table(seen, Vector3::new(2.0, 1.0, 0.02), &camera)
}
