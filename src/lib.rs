//! physskin: physically based motion for any 3D object in real time.
//!
//! Geometry comes in (a mesh or a point cloud), a skinning weight field gives it a small set of
//! affine handles, and an implicit elastic simulation runs over the 12 numbers per handle. Every
//! stage is a plain library type without I/O; the CLI, the ROS 2 node and the recorders are thin
//! shells around them.

pub mod bench;
pub mod error;
pub mod geometry;
mod linalg;
pub mod physics;
pub mod skinning;

pub use error::{Error, Result};
