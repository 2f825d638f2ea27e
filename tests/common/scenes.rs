//! Real-sensor inputs shared by tests: a segmenting RGB-D camera's view of objects on a table.

use nalgebra::Vector3;
use physskin::geometry::{box_mesh, sdf_mesh, Camera, Shape};
use physskin::ros::camera_cloud::{camera_cloud, merged, SeenObject};
use physskin::ros::messages::{Header, PointCloud2, Time};

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
    let table = moved(
        box_mesh(Vector3::new(1.0, 1.0, 0.02)),
        Vector3::new(0.0, 0.0, -0.01),
    );
    let aim = merged(&[&ball, &block]).unwrap();
    let camera = Camera::looking_at(&aim, Vector3::new(0.3, -1.0, 0.7), 1.5, width, height);
    let objects = [
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
        SeenObject {
            shape: &table,
            instance: 0,
            rgb: [120, 100, 80],
        },
    ];
    let header = Header {
        stamp: Time::default(),
        frame_id: OPTICAL_FRAME.into(),
    };
    camera_cloud(&objects, &camera, header).unwrap()
}
