//! Meshes in: shape_msgs/Mesh and physskin/MeshStamped as CDR, then the shape checks; and the
//! same bytes as OBJ, PLY and STL files.
#![no_main]

use libfuzzer_sys::fuzz_target;
use physskin::fuzzing::{parse_obj, parse_ply, parse_stl, BuildRequest};
use physskin::geometry::Shape;
use physskin::msg::{from_cdr, Mesh, MeshStamped};

fn shape_of(mesh: &Mesh) {
    if let Ok(request) = BuildRequest::from_mesh(mesh, "fuzz", 0, 100_000) {
        let _ = Shape::new(request.points, None, request.triangles);
    }
}

fuzz_target!(|bytes: &[u8]| {
    if let Ok(mesh) = from_cdr::<Mesh>(bytes) {
        shape_of(&mesh);
    }
    if let Ok(stamped) = from_cdr::<MeshStamped>(bytes) {
        shape_of(&stamped.mesh);
    }
    for geometry in [parse_obj(bytes), parse_ply(bytes), parse_stl(bytes)]
        .into_iter()
        .flatten()
    {
        {
            let _ = Shape::from_raw(geometry);
        }
    }
});
