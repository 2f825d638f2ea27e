//! PointCloud2 in: the CDR bytes as DDS delivers them, and (first byte odd) a cloud laid out
//! from the bytes field by field, so that the decoder's layout checks are reached without
//! having to get CDR right first.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::fuzzing::BuildRequest;
use physskin::msg::{from_cdr, PointCloud2, PointField};

const CAP: usize = 100_000;

fn structured(bytes: &[u8]) -> Option<PointCloud2> {
    let (head, data) = bytes.split_at_checked(12)?;
    let names = ["x", "y", "z", "rgb", "instance"];
    let fields = (0..head[0] % 5)
        .map(|i| PointField {
            name: names[(head[1 + i as usize] % 5) as usize].into(),
            offset: u32::from(head[5 + i as usize] % 32),
            datatype: head[9] % 10,
            count: 1,
        })
        .collect();
    Some(PointCloud2 {
        height: u32::from(head[10] % 4),
        width: u32::from(head[11]),
        fields,
        is_bigendian: head[0] & 0x80 != 0,
        point_step: u32::from(head[1] % 40),
        row_step: u32::from(head[2]) * 4,
        data: data.to_vec(),
        is_dense: head[3] & 1 == 1,
        ..PointCloud2::default()
    })
}

fuzz_target!(|bytes: &[u8]| {
    let cloud = match bytes.first() {
        Some(b) if b & 1 == 1 => structured(&bytes[1..]),
        _ => from_cdr::<PointCloud2>(bytes).ok(),
    };
    if let Some(cloud) = cloud {
        let requests = BuildRequest::from_cloud(&cloud, CAP, "instance").unwrap_or_default();
        for request in requests {
            assert!(request.points.iter().all(|p| p.iter().all(|c| c.is_finite())));
            // The deformed cloud in the input's layout: the rest pose must fit it.
            let rest: Vec<f32> = request
                .points
                .iter()
                .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect();
            let template = request.template.as_ref().expect("clouds carry their layout");
            let out = template.fill(Default::default(), &rest);
            assert_eq!(out.data.len() as u64, out.row_step as u64 * out.height as u64);
            // Taken as one camera's view from the frame's origin, as the node does.
            let viewpoint = Default::default();
            let _ = physskin::fuzzing::complete_view(&request.points, &viewpoint, Some(0.0));
            let _ = physskin::geometry::Shape::new(request.points, None, Vec::new());
        }
    }
});
