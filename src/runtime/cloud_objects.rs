//! The objects of one input cloud and the clouds their deformed points go out as. A segmenter's
//! cloud carries an instance id per point: each id is an object (0 is background). Whatever
//! else a point carries (rgb, intensity, the id) goes back out unchanged, in the input's order
//! and layout, so that RViz and Foxglove colour the moving object as the camera saw it.

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use crate::msg::cloud::{
    coordinates, datatype_size, read_scalar, records, Coordinate, DecodedCloud,
};
use crate::msg::{Header, PointCloud2, PointField};

/// The names an instance field is looked up by when `instance_field` is left at its default.
pub const INSTANCE_FIELDS: [&str; 4] = ["instance", "label", "segment", "object_id"];

/// Why a cloud's instance field could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InstanceError {
    /// The field's datatype is not a PointField number type.
    #[error("instance field `{name}` has datatype {datatype}, not a number type (1 to 8)")]
    Datatype {
        /// The field's name.
        name: String,
        /// Its datatype.
        datatype: u8,
    },
    /// The field does not fit inside the point record.
    #[error("instance field `{name}` at offset {offset} does not fit in point_step {point_step}")]
    OutsidePoint {
        /// The field's name.
        name: String,
        /// Its offset in the record, bytes.
        offset: u32,
        /// The record's size, bytes.
        point_step: u32,
    },
    /// A point's id is fractional or infinite (NaN counts as background, 0).
    #[error("instance field `{name}` holds {value} at point {index}: ids are whole numbers")]
    NotWhole {
        /// The field's name.
        name: String,
        /// The value read.
        value: f64,
        /// The point's index among the cloud's width x height points (row-major).
        index: usize,
    },
}

/// The instance field of a cloud: `wanted` when the cloud has it; with `wanted` at its default
/// ("instance"), the first of [`INSTANCE_FIELDS`] it has. None: the cloud is one object.
pub fn instance_field<'a>(cloud: &'a PointCloud2, wanted: &str) -> Option<&'a PointField> {
    let names: &[&str] = if wanted == INSTANCE_FIELDS[0] {
        &INSTANCE_FIELDS
    } else {
        &[wanted]
    };
    names
        .iter()
        .find_map(|name| cloud.fields.iter().find(|f| f.name == *name))
}

/// The decoded points split by instance id (background, 0 and NaN, left out), each id's points
/// with their pixels in input order.
pub fn split_by_instance(
    cloud: &PointCloud2,
    field: &PointField,
    decoded: DecodedCloud,
) -> Result<BTreeMap<i64, DecodedCloud>, InstanceError> {
    let ids = instance_ids(cloud, field)?;
    let mut objects: BTreeMap<i64, DecodedCloud> = BTreeMap::new();
    for (point, pixel) in decoded.points.into_iter().zip(decoded.pixels) {
        let id = ids[pixel as usize];
        if id == 0 {
            continue;
        }
        let object = objects.entry(id).or_insert_with(|| DecodedCloud {
            points: Vec::new(),
            pixels: Vec::new(),
            dropped: 0,
        });
        object.points.push(point);
        object.pixels.push(pixel);
    }
    Ok(objects)
}

/// Every point's instance id (0 for NaN: no segment).
fn instance_ids(cloud: &PointCloud2, field: &PointField) -> Result<Vec<i64>, InstanceError> {
    let name = field.name.clone();
    let size = datatype_size(field.datatype).ok_or_else(|| InstanceError::Datatype {
        name: name.clone(),
        datatype: field.datatype,
    })?;
    if field.offset as u64 + size as u64 > cloud.point_step as u64 {
        return Err(InstanceError::OutsidePoint {
            name,
            offset: field.offset,
            point_step: cloud.point_step,
        });
    }
    let at = field.offset as usize;
    records(cloud)
        .enumerate()
        .map(|(index, record)| {
            let value = read_scalar(&record[at..], field.datatype, cloud.is_bigendian);
            if value.is_nan() {
                Ok(0)
            } else if value.fract() != 0.0 || !value.is_finite() {
                Err(InstanceError::NotWhole {
                    name: name.clone(),
                    value,
                    index,
                })
            } else {
                Ok(value as i64)
            }
        })
        .collect()
}

/// An input cloud's layout and bytes, shared by its objects.
struct Source {
    fields: Vec<PointField>,
    height: u32,
    width: u32,
    point_step: u32,
    row_step: u32,
    is_bigendian: bool,
    data: Vec<u8>,
    xyz: [Coordinate; 3],
}

/// The cloud one object's deformed points go out as: its input cloud's layout and fields, with
/// its points' x, y, z replaced. The one object of an organized cloud (height > 1) keeps the
/// image's height and width, its NaN pixels NaN in place. An object of a labelled cloud, or of
/// an unorganized one, holds its own points only, in input order: one image per object would
/// multiply a camera's bandwidth by the number of objects.
#[derive(Clone)]
pub struct CloudTemplate {
    source: Arc<Source>,
    /// The object's pixels (row-major indices), in the order of its points.
    pixels: Arc<Vec<u32>>,
    /// The output is the whole image (an organized cloud's one object).
    whole_image: bool,
    /// The output's bytes before positions are written, and where each point's record starts;
    /// made on first use, off the executor.
    base: Arc<OnceLock<(Vec<u8>, Vec<usize>)>>,
}

impl std::fmt::Debug for CloudTemplate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.source;
        write!(
            f,
            "CloudTemplate({} of {} x {} points)",
            self.len(),
            s.width,
            s.height
        )
    }
}

impl CloudTemplate {
    /// Templates for the objects of `cloud`, one per entry of `pixels` (the objects' pixels);
    /// `labelled`: the cloud was split by instance id.
    pub fn for_objects(cloud: &PointCloud2, pixels: Vec<Vec<u32>>, labelled: bool) -> Vec<Self> {
        let whole_image = cloud.height > 1 && !labelled;
        let Ok(xyz) = coordinates(cloud) else {
            // Decoding checked x, y and z before any object exists.
            unreachable!("templates are made for decoded clouds only")
        };
        let source = Arc::new(Source {
            fields: cloud.fields.clone(),
            height: cloud.height,
            width: cloud.width,
            point_step: cloud.point_step,
            row_step: cloud.row_step,
            is_bigendian: cloud.is_bigendian,
            data: cloud.data.clone(),
            xyz,
        });
        pixels
            .into_iter()
            .map(|pixels| Self {
                source: source.clone(),
                pixels: Arc::new(pixels),
                whole_image,
                base: Arc::default(),
            })
            .collect()
    }

    /// The object's points in the output.
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    /// Whether the object has no points in the output.
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The object's deformed cloud: `deformed` holds x, y, z per point in input order.
    pub fn fill(&self, header: Header, deformed: &[f32]) -> PointCloud2 {
        assert_eq!(
            deformed.len(),
            3 * self.len(),
            "x, y, z per point of the object"
        );
        let s = &self.source;
        let (base, starts) = self.base.get_or_init(|| self.base_bytes());
        let mut data = base.clone();
        let step = s.point_step as usize;
        for (start, p) in starts.iter().zip(deformed.chunks_exact(3)) {
            let record = &mut data[*start..*start + step];
            for (axis, value) in s.xyz.iter().zip(p) {
                axis.write(record, *value as f64, s.is_bigendian);
            }
        }
        let organized = self.whole_image;
        let (height, width, row_step) = if organized {
            (s.height, s.width, s.row_step)
        } else {
            let width = self.len() as u32;
            (1, width, width * s.point_step)
        };
        PointCloud2 {
            header,
            height,
            width,
            fields: s.fields.clone(),
            is_bigendian: s.is_bigendian,
            point_step: s.point_step,
            row_step,
            data,
            is_dense: !organized || self.len() as u64 == s.height as u64 * s.width as u64,
        }
    }

    /// The output's bytes with every other pixel at NaN (organized) or the object's records
    /// gathered (unorganized), and where each of the object's records starts.
    fn base_bytes(&self) -> (Vec<u8>, Vec<usize>) {
        let s = &self.source;
        let step = s.point_step as usize;
        let start_of = |pixel: u32| {
            let (row, col) = (pixel / s.width, pixel % s.width);
            row as usize * s.row_step as usize + col as usize * step
        };
        if self.whole_image {
            let mut data = s.data.clone();
            let mut mine = vec![false; (s.height * s.width) as usize];
            self.pixels.iter().for_each(|p| mine[*p as usize] = true);
            for (pixel, _) in mine.iter().enumerate().filter(|(_, m)| !**m) {
                let at = start_of(pixel as u32);
                let record = &mut data[at..at + step];
                s.xyz
                    .iter()
                    .for_each(|axis| axis.write(record, f64::NAN, s.is_bigendian));
            }
            let starts = self.pixels.iter().map(|p| start_of(*p)).collect();
            (data, starts)
        } else {
            let mut data = Vec::with_capacity(self.len() * step);
            for p in self.pixels.iter() {
                let at = start_of(*p);
                data.extend_from_slice(&s.data[at..at + step]);
            }
            (data, (0..self.len()).map(|i| i * step).collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::cloud::{decode_cloud, point_field};

    /// An organized `w` x `h` cloud: float32 x, y, z, then rgb (4 bytes) and a uint16 label,
    /// padded to 20 bytes; pixel i is at (i, 0, 1), label `label(i)`, NaN where `nan(i)`.
    fn labelled(
        w: u32,
        h: u32,
        label: impl Fn(u32) -> u16,
        nan: impl Fn(u32) -> bool,
    ) -> PointCloud2 {
        let step = 20u32;
        let mut data = Vec::new();
        for i in 0..w * h {
            let x = if nan(i) { f32::NAN } else { i as f32 };
            for v in [x, 0.0, 1.0] {
                data.extend_from_slice(&v.to_le_bytes());
            }
            data.extend_from_slice(&[i as u8, 10, 20, 255]);
            data.extend_from_slice(&label(i).to_le_bytes());
            data.extend_from_slice(&[0, 0]);
        }
        PointCloud2 {
            header: Header::default(),
            height: h,
            width: w,
            fields: vec![
                point_field("x", 0, 7),
                point_field("y", 4, 7),
                point_field("z", 8, 7),
                point_field("rgb", 12, 6),
                point_field("label", 16, 4),
            ],
            is_bigendian: false,
            point_step: step,
            row_step: step * w,
            data,
            is_dense: false,
        }
    }

    #[test]
    fn splits_by_label_and_ignores_background() {
        let cloud = labelled(8, 1, |i| [0, 1, 2, 1, 0, 2, 2, 0][i as usize], |_| false);
        let field = instance_field(&cloud, "instance").expect("`label` is accepted");
        let decoded = decode_cloud(&cloud, 100).unwrap();
        let objects = split_by_instance(&cloud, field, decoded).unwrap();
        assert_eq!(objects.keys().copied().collect::<Vec<_>>(), vec![1, 2]);
        assert_eq!(objects[&1].pixels, vec![1, 3]);
        assert_eq!(objects[&2].pixels, vec![2, 5, 6]);
        assert_eq!(objects[&2].points[1].x, 5.0);
        assert!(
            instance_field(&cloud, "segment").is_none(),
            "a named field is the only one"
        );
    }

    #[test]
    fn unorganized_output_keeps_fields_bytes_and_order() {
        let cloud = labelled(6, 1, |i| (i % 2) as u16 + 1, |_| false);
        let field = instance_field(&cloud, "label").unwrap();
        let objects = split_by_instance(&cloud, field, decode_cloud(&cloud, 100).unwrap()).unwrap();
        let pixels: Vec<Vec<u32>> = objects.values().map(|o| o.pixels.clone()).collect();
        let templates = CloudTemplate::for_objects(&cloud, pixels, true);
        let out = templates[1].fill(
            Header::default(),
            &[9.0, 9.0, 9.0, 8.0, 8.0, 8.0, 7.0, 7.0, 7.0],
        );
        assert_eq!((out.height, out.width, out.point_step), (1, 3, 20));
        assert_eq!(out.fields, cloud.fields);
        for (k, pixel) in [1usize, 3, 5].into_iter().enumerate() {
            let record = &out.data[20 * k..20 * (k + 1)];
            assert_eq!(
                record[12..20],
                cloud.data[20 * pixel + 12..20 * pixel + 20],
                "rgb and label"
            );
            let x = f32::from_le_bytes(record[0..4].try_into().unwrap());
            assert_eq!(x, [9.0, 8.0, 7.0][k]);
        }
    }

    #[test]
    fn organized_output_keeps_shape_and_nan_in_place() {
        let (w, h) = (64, 48);
        let cloud = labelled(w, h, |_| 1, |i| i % 7 == 0);
        let decoded = decode_cloud(&cloud, 1 << 20).unwrap();
        let moved: Vec<f32> = decoded
            .points
            .iter()
            .flat_map(|p| [p.x as f32 + 0.5, 0.0, 1.0])
            .collect();
        let template =
            CloudTemplate::for_objects(&cloud, vec![decoded.pixels.clone()], false).remove(0);
        let out = template.fill(Header::default(), &moved);
        assert_eq!(
            (out.height, out.width, out.row_step),
            (h, w, cloud.row_step)
        );
        assert!(!out.is_dense);
        for i in 0..(w * h) as usize {
            let x = f32::from_le_bytes(out.data[20 * i..20 * i + 4].try_into().unwrap());
            if i % 7 == 0 {
                assert!(x.is_nan(), "pixel {i} stays NaN");
            } else {
                assert_eq!(x, i as f32 + 0.5, "pixel {i} moved in place");
            }
            assert_eq!(
                out.data[20 * i + 12..20 * i + 20],
                cloud.data[20 * i + 12..20 * i + 20]
            );
        }
    }

    #[test]
    fn fractional_ids_are_refused_with_the_point() {
        let mut cloud = labelled(3, 1, |_| 1, |_| false);
        cloud.fields[4] = point_field("instance", 12, 7);
        cloud.data[20 + 12..20 + 16].copy_from_slice(&2.5f32.to_le_bytes());
        let field = instance_field(&cloud, "instance").unwrap();
        let err = split_by_instance(&cloud, field, decode_cloud(&cloud, 10).unwrap()).unwrap_err();
        assert!(err.to_string().contains("2.5 at point 1"), "{err}");
    }
}
