//! Geometry in: loaders, the normalized frame, surface and interior sampling, the voxel inside
//! test, cubature and tetrahedral meshes of the interior.

mod completion;
mod contact_samples;
mod cubature;
mod downsample;
mod islands;
mod mesh_io;
mod point_index;
mod primitives;
mod reference_mesh;
mod sampling;
mod scan;
mod shape;
mod tetmesh;
mod voxel;

pub use completion::{complete_view, Completed, Completion, CompletionError};
pub use contact_samples::{contact_samples, ContactSamples};
pub use cubature::{stratified_subset, Cubature};
pub use downsample::voxel_downsample;
pub use mesh_io::{
    load_geometry, parse_obj, parse_ply, parse_stl, write_obj, write_ply, LoadError, RawGeometry,
};
pub use point_index::median_spacing;
pub use point_index::PointIndex;
pub use primitives::{box_grid_mesh, box_mesh, bundled, capsule_mesh, sdf_mesh, BUNDLED};
pub use reference_mesh::{bottom_vertices, pinned_slab_top, reference_mesh, ReferenceMesh};
pub use sampling::{sample_surface, SurfaceSamples, SurfaceSampling};
pub use scan::{scan, scan_faces, scan_points, Camera};
pub use shape::{content_hash, Normalization, Shape};
pub use tetmesh::{TetLocation, TetMesh};
pub use voxel::{Stretch, VoxelGrid};
