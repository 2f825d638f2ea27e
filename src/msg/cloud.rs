//! sensor_msgs/PointCloud2 in and out. Producers differ in offsets, precision, byte order and
//! extra fields, so reading goes by field name and datatype, never by assumed layout.

use nalgebra::Vector3;

use super::messages::{Header, PointCloud2, PointField};

/// PointField datatype FLOAT32.
pub(crate) const FLOAT32: u8 = 7;
/// PointField datatype FLOAT64.
pub(crate) const FLOAT64: u8 = 8;

/// Why a PointCloud2 could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CloudError {
    /// No field of this name (x, y or z); the second part lists the fields there are.
    #[error("PointCloud2 has no `{0}` field (fields: {1})")]
    MissingField(&'static str, String),
    /// A coordinate field is neither FLOAT32 nor FLOAT64.
    #[error("PointCloud2 field `{name}` has datatype {datatype}; x, y and z must be FLOAT32 (7) or FLOAT64 (8)")]
    UnsupportedDatatype {
        /// The field: x, y or z.
        name: &'static str,
        /// Its datatype.
        datatype: u8,
    },
    /// A coordinate field does not fit inside the point record.
    #[error(
        "PointCloud2 field `{name}` at offset {offset} does not fit in point_step {point_step}"
    )]
    FieldOutsidePoint {
        /// The field: x, y or z.
        name: &'static str,
        /// Its offset in the record, bytes.
        offset: u32,
        /// The record's size, bytes.
        point_step: u32,
    },
    /// A row is shorter than its points.
    #[error(
        "PointCloud2 row_step {row_step} is smaller than width {width} x point_step {point_step}"
    )]
    RowTooShort {
        /// Bytes per row.
        row_step: u32,
        /// Points per row.
        width: u32,
        /// Bytes per point.
        point_step: u32,
    },
    /// `data` does not hold `row_step` x `height` bytes.
    #[error("PointCloud2 data holds {actual} bytes but row_step {row_step} x height {height} = {expected}")]
    DataLength {
        /// Bytes in `data`.
        actual: usize,
        /// `row_step` x `height`.
        expected: u64,
        /// Bytes per row.
        row_step: u32,
        /// Rows.
        height: u32,
    },
    /// More points than the limit.
    #[error("PointCloud2 holds {count} points, more than max_points = {cap}")]
    TooManyPoints {
        /// width x height.
        count: u64,
        /// The limit, `max_points`.
        cap: usize,
    },
    /// width x height is 0.
    #[error("PointCloud2 holds no points (width {width} x height {height})")]
    Empty {
        /// Points per row.
        width: u32,
        /// Rows.
        height: u32,
    },
    /// Every point has a NaN or infinite coordinate.
    #[error("PointCloud2 holds no finite point ({dropped} with NaN or Inf coordinates dropped)")]
    NoFinitePoints {
        /// The points dropped: all of them.
        dropped: usize,
    },
}

/// The finite points of a cloud, in order, and how many were dropped for NaN or Inf.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedCloud {
    /// The finite points, in the cloud's frame.
    pub points: Vec<Vector3<f64>>,
    /// Per point: its index among the cloud's width x height points (row-major), so that
    /// outputs can put it back in its place.
    pub pixels: Vec<u32>,
    /// Points dropped for a NaN or infinite coordinate.
    pub dropped: usize,
}

/// Where a coordinate sits in each point record.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Coordinate {
    pub offset: usize,
    pub double: bool,
}

impl Coordinate {
    /// Writes `value` at this coordinate of `record`, in the record's precision and byte order.
    pub fn write(&self, record: &mut [u8], value: f64, big: bool) {
        let at = &mut record[self.offset..];
        match (self.double, big) {
            (true, false) => at[..8].copy_from_slice(&value.to_le_bytes()),
            (true, true) => at[..8].copy_from_slice(&value.to_be_bytes()),
            (false, false) => at[..4].copy_from_slice(&(value as f32).to_le_bytes()),
            (false, true) => at[..4].copy_from_slice(&(value as f32).to_be_bytes()),
        }
    }
}

/// A one-value PointField: `name` at `offset` with `datatype` (FLOAT32 7, UINT16 4, ...).
pub(crate) fn point_field(name: &str, offset: u32, datatype: u8) -> PointField {
    PointField {
        name: name.into(),
        offset,
        datatype,
        count: 1,
    }
}

/// Bytes per value of a PointField datatype (INT8 1 ... FLOAT64 8); None for unknown ones.
pub(crate) fn datatype_size(datatype: u8) -> Option<usize> {
    match datatype {
        1 | 2 => Some(1),
        3 | 4 => Some(2),
        5..=7 => Some(4),
        8 => Some(8),
        _ => None,
    }
}

/// The value of a field of any numeric datatype at the start of `bytes`, as f64.
pub(crate) fn read_scalar(bytes: &[u8], datatype: u8, big: bool) -> f64 {
    macro_rules! read {
        ($t:ty, $n:expr) => {{
            let raw: [u8; $n] = bytes[..$n].try_into().expect("size checked by the caller");
            (if big {
                <$t>::from_be_bytes(raw)
            } else {
                <$t>::from_le_bytes(raw)
            }) as f64
        }};
    }
    match datatype {
        1 => read!(i8, 1),
        2 => read!(u8, 1),
        3 => read!(i16, 2),
        4 => read!(u16, 2),
        5 => read!(i32, 4),
        6 => read!(u32, 4),
        7 => read!(f32, 4),
        _ => read!(f64, 8),
    }
}

pub(crate) fn coordinate(
    cloud: &PointCloud2,
    name: &'static str,
) -> Result<Coordinate, CloudError> {
    let field = cloud
        .fields
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| {
            let names: Vec<_> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
            CloudError::MissingField(name, names.join(", "))
        })?;
    let size = match field.datatype {
        FLOAT32 => 4,
        FLOAT64 => 8,
        datatype => return Err(CloudError::UnsupportedDatatype { name, datatype }),
    };
    if field.offset as u64 + size > cloud.point_step as u64 {
        return Err(CloudError::FieldOutsidePoint {
            name,
            offset: field.offset,
            point_step: cloud.point_step,
        });
    }
    Ok(Coordinate {
        offset: field.offset as usize,
        double: size == 8,
    })
}

/// x, y and z of a cloud's point records.
pub(crate) fn coordinates(cloud: &PointCloud2) -> Result<[Coordinate; 3], CloudError> {
    Ok([
        coordinate(cloud, "x")?,
        coordinate(cloud, "y")?,
        coordinate(cloud, "z")?,
    ])
}

/// Reads x, y, z of every point, checks the layout against the data, and drops points with a
/// non-finite coordinate whatever `is_dense` claims. `max_points` caps the points accepted
/// before any work is done on them.
pub fn decode_cloud(cloud: &PointCloud2, max_points: usize) -> Result<DecodedCloud, CloudError> {
    let axes = coordinates(cloud)?;
    let (width, height) = (cloud.width as u64, cloud.height as u64);
    if (cloud.row_step as u64) < width * cloud.point_step as u64 {
        return Err(CloudError::RowTooShort {
            row_step: cloud.row_step,
            width: cloud.width,
            point_step: cloud.point_step,
        });
    }
    let expected = cloud.row_step as u64 * height;
    if cloud.data.len() as u64 != expected {
        return Err(CloudError::DataLength {
            actual: cloud.data.len(),
            expected,
            row_step: cloud.row_step,
            height: cloud.height,
        });
    }
    let count = width * height;
    if count == 0 {
        return Err(CloudError::Empty {
            width: cloud.width,
            height: cloud.height,
        });
    }
    if count > max_points as u64 {
        return Err(CloudError::TooManyPoints {
            count,
            cap: max_points,
        });
    }
    let big = cloud.is_bigendian;
    let read = |bytes: &[u8], axis: &Coordinate| -> f64 {
        let datatype = if axis.double { FLOAT64 } else { FLOAT32 };
        read_scalar(&bytes[axis.offset..], datatype, big)
    };
    let mut points = Vec::with_capacity(count as usize);
    let mut pixels = Vec::with_capacity(count as usize);
    let mut dropped = 0;
    for (pixel, bytes) in records(cloud).enumerate() {
        let point = Vector3::new(
            read(bytes, &axes[0]),
            read(bytes, &axes[1]),
            read(bytes, &axes[2]),
        );
        if point.iter().all(|c| c.is_finite()) {
            points.push(point);
            pixels.push(pixel as u32);
        } else {
            dropped += 1;
        }
    }
    if points.is_empty() {
        return Err(CloudError::NoFinitePoints { dropped });
    }
    Ok(DecodedCloud {
        points,
        pixels,
        dropped,
    })
}

/// Every point record of a cloud whose layout was checked against its data, row by row.
pub(crate) fn records(cloud: &PointCloud2) -> impl Iterator<Item = &[u8]> {
    let step = cloud.point_step as usize;
    let width = cloud.width as usize;
    cloud
        .data
        .chunks_exact(cloud.row_step.max(1) as usize)
        .flat_map(move |row| (0..width).map(move |p| &row[p * step..(p + 1) * step]))
}

/// An unordered (height 1), dense, little-endian cloud of float32 x, y, z followed by one float32
/// field per name in `channels`; `values` holds those channels point by point.
pub fn encode_cloud(
    header: Header,
    xyz: &[f32],
    channels: &[String],
    values: &[f32],
) -> PointCloud2 {
    assert_eq!(xyz.len() % 3, 0, "xyz holds 3 floats per point");
    let count = xyz.len() / 3;
    let c = channels.len();
    assert_eq!(
        values.len(),
        count * c,
        "values hold one float per point and channel"
    );
    let names = ["x", "y", "z"]
        .into_iter()
        .map(String::from)
        .chain(channels.iter().cloned());
    let fields: Vec<PointField> = names
        .enumerate()
        .map(|(i, name)| point_field(&name, 4 * i as u32, FLOAT32))
        .collect();
    let point_step = 4 * (3 + c);
    let mut data = Vec::with_capacity(count * point_step);
    for p in 0..count {
        for v in xyz[3 * p..3 * p + 3]
            .iter()
            .chain(&values[p * c..(p + 1) * c])
        {
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    PointCloud2 {
        header,
        height: 1,
        width: count as u32,
        fields,
        is_bigendian: false,
        point_step: point_step as u32,
        row_step: (point_step * count) as u32,
        data,
        is_dense: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use super::point_field as field;

    /// A cloud laid out like many drivers: float64 z first, padding, intensity, then x and y.
    fn odd_cloud(points: &[[f64; 3]], big: bool) -> PointCloud2 {
        let step = 32u32;
        let mut data = Vec::new();
        for p in points {
            let mut rec = vec![0u8; step as usize];
            let put64 = |rec: &mut Vec<u8>, at: usize, v: f64| {
                let b = if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                };
                rec[at..at + 8].copy_from_slice(&b);
            };
            let put32 = |rec: &mut Vec<u8>, at: usize, v: f32| {
                let b = if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                };
                rec[at..at + 4].copy_from_slice(&b);
            };
            put64(&mut rec, 0, p[2]);
            put32(&mut rec, 12, 7.5); // intensity, ignored
            put32(&mut rec, 16, p[0] as f32);
            put64(&mut rec, 24, p[1]);
            data.extend(rec);
        }
        PointCloud2 {
            header: Header::default(),
            height: 1,
            width: points.len() as u32,
            fields: vec![
                field("z", 0, FLOAT64),
                field("intensity", 12, FLOAT32),
                field("x", 16, FLOAT32),
                field("y", 24, FLOAT64),
            ],
            is_bigendian: big,
            point_step: step,
            row_step: step * points.len() as u32,
            data,
            is_dense: true, // it lies below: one point is NaN
        }
    }

    #[test]
    fn reads_by_name_any_offset_precision_and_byte_order() {
        let points = [[1.5, -2.0, 3.25], [f64::NAN, 0.0, 1.0], [0.5, 0.25, -4.0]];
        for big in [false, true] {
            let decoded = decode_cloud(&odd_cloud(&points, big), 100).unwrap();
            assert_eq!(
                decoded.dropped, 1,
                "the NaN point is dropped although is_dense says true"
            );
            assert_eq!(
                decoded.points,
                vec![Vector3::new(1.5, -2.0, 3.25), Vector3::new(0.5, 0.25, -4.0)]
            );
        }
    }

    #[test]
    fn round_trips_our_own_clouds_with_extra_channels() {
        let xyz = [0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0];
        let channels = vec!["w0".to_string(), "w1".to_string()];
        let cloud = encode_cloud(Header::default(), &xyz, &channels, &[1.0, 0.5, 1.0, -0.5]);
        assert_eq!(cloud.point_step, 20);
        assert_eq!(cloud.data.len(), 40);
        let decoded = decode_cloud(&cloud, 10).unwrap();
        assert_eq!(decoded.points[1], Vector3::new(3.0, 4.0, 5.0));
    }

    #[test]
    fn names_what_is_wrong() {
        let good = odd_cloud(&[[1.0, 2.0, 3.0]], false);
        let mut missing = good.clone();
        missing.fields.retain(|f| f.name != "z");
        assert!(matches!(
            decode_cloud(&missing, 10),
            Err(CloudError::MissingField("z", _))
        ));
        let mut ints = good.clone();
        ints.fields[2].datatype = 5;
        assert_eq!(
            decode_cloud(&ints, 10),
            Err(CloudError::UnsupportedDatatype {
                name: "x",
                datatype: 5
            })
        );
        let mut short_step = good.clone();
        short_step.point_step = 24;
        assert!(matches!(
            decode_cloud(&short_step, 10),
            Err(CloudError::FieldOutsidePoint { name: "y", .. })
        ));
        let mut short_data = good.clone();
        short_data.data.pop();
        assert!(matches!(
            decode_cloud(&short_data, 10),
            Err(CloudError::DataLength { .. })
        ));
        assert!(matches!(
            decode_cloud(&good, 0),
            Err(CloudError::TooManyPoints { count: 1, cap: 0 })
        ));
        let nan = odd_cloud(&[[f64::INFINITY, 0.0, 0.0]], false);
        assert_eq!(
            decode_cloud(&nan, 10),
            Err(CloudError::NoFinitePoints { dropped: 1 })
        );
    }
}
