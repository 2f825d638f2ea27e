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

#[cfg(not(fuzzing))]
pub(crate) use completion::complete_view;
// The fuzz targets reach these through `crate::fuzzing`, built only under `cargo fuzz`.
#[cfg(fuzzing)]
pub use completion::complete_view;
#[cfg(test)]
pub(crate) use completion::CompletionError;
pub use completion::{Completed, Completion, Prior};
pub(crate) use contact_samples::{contact_samples, ContactSamples};
pub(crate) use cubature::stratified_subset;
pub use cubature::Cubature;
pub(crate) use downsample::{view_downsample, voxel_downsample};
pub use mesh_io::{load_geometry, LoadError, RawGeometry};
#[cfg(fuzzing)]
pub use mesh_io::{parse_obj, parse_ply, parse_stl};
pub(crate) use mesh_io::{write_obj, write_ply};
pub(crate) use point_index::{nearest_point, neighbourhood_plane, PointIndex};
pub(crate) use primitives::{box_grid_mesh, capsule_mesh, BUNDLED};
pub use primitives::{box_mesh, bundled, sdf_mesh};
pub(crate) use reference_mesh::{bottom_vertices, pinned_slab_top};
pub(crate) use reference_mesh::{reference_mesh, ReferenceMesh};
pub use sampling::SurfaceSamples;
pub(crate) use sampling::{sample_surface, SurfaceSampling};
pub(crate) use scan::scan;
pub(crate) use scan::scan_faces;
pub use scan::{scan_points, Camera};
pub(crate) use shape::content_hash;
pub use shape::{Normalization, Shape};
pub(crate) use tetmesh::TetLocation;
pub use tetmesh::TetMesh;
pub use voxel::VoxelGrid;

#[cfg(test)]
mod tests;
