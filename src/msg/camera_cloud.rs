//! A depth camera's organized PointCloud2 of several objects, as a segmenting RGB-D driver
//! publishes it: in the camera's optical frame (z forward, x right, y down), float32 x, y, z,
//! a packed rgb as PCL lays it out, and a uint16 `instance` id per pixel (0: background or no
//! object), NaN where the ray meets nothing. Tests, benches and `physskin simulate` make their
//! real-sensor inputs with it.

use nalgebra::Vector3;

use super::cloud::{point_field, FLOAT32};
use super::messages::{Header, PointCloud2};
use crate::geometry::{scan, Camera, Shape};

/// PointField datatype UINT16.
const UINT16: u8 = 4;
/// x, y, z, rgb (4 bytes each), instance (2), padding (2).
const POINT_STEP: u32 = 20;

/// One object in front of the camera.
pub struct SeenObject<'a> {
    /// A closed mesh, in world coordinates.
    pub shape: &'a Shape,
    /// Its id in the cloud's `instance` field; 0 marks background.
    pub instance: u16,
    /// Its colour in the cloud's packed `rgb` field.
    pub rgb: [u8; 3],
}

/// The camera's image of `objects`: per pixel the nearest object's surface point, in the
/// optical frame, with that object's colour and id.
pub fn camera_cloud(
    objects: &[SeenObject],
    camera: &Camera,
    header: Header,
) -> crate::Result<PointCloud2> {
    let images = objects
        .iter()
        .map(|o| scan(o.shape, camera))
        .collect::<crate::Result<Vec<_>>>()?;
    let to_optical = camera.optical_pose().inverse();
    let pixels = camera.width * camera.height;
    let mut data = Vec::with_capacity(pixels * POINT_STEP as usize);
    for pixel in 0..pixels {
        let nearest = images
            .iter()
            .zip(objects)
            .filter_map(|(image, object)| image[pixel].map(|p| (object, p)))
            .min_by(|a, b| {
                let d = |p: &Vector3<f64>| (p - camera.position).norm_squared();
                d(&a.1).total_cmp(&d(&b.1))
            });
        let (xyz, rgb, instance) = match nearest {
            Some((object, p)) => {
                let q = to_optical * nalgebra::Point3::from(p);
                (
                    [q.x as f32, q.y as f32, q.z as f32],
                    object.rgb,
                    object.instance,
                )
            }
            None => ([f32::NAN; 3], [0; 3], 0),
        };
        xyz.iter()
            .for_each(|c| data.extend_from_slice(&c.to_le_bytes()));
        // PCL's packed rgb: 0x00RRGGBB in a float32's bytes, little-endian.
        data.extend_from_slice(&[rgb[2], rgb[1], rgb[0], 0]);
        data.extend_from_slice(&instance.to_le_bytes());
        data.extend_from_slice(&[0, 0]);
    }
    Ok(PointCloud2 {
        header,
        height: camera.height as u32,
        width: camera.width as u32,
        fields: vec![
            point_field("x", 0, FLOAT32),
            point_field("y", 4, FLOAT32),
            point_field("z", 8, FLOAT32),
            point_field("rgb", 12, FLOAT32),
            point_field("instance", 16, UINT16),
        ],
        is_bigendian: false,
        point_step: POINT_STEP,
        row_step: POINT_STEP * camera.width as u32,
        data,
        is_dense: false,
    })
}
