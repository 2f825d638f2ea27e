//! physskin: physically based motion for any 3D object in real time.
//!
//! Geometry comes in (a mesh or a point cloud), a skinning weight field gives it a small set of
//! affine handles, and an implicit elastic simulation runs over the 12 numbers per handle. Every
//! stage is a plain library type without I/O; the CLI, the ROS 2 node, the MCAP replayer and
//! the iceoryx2 publisher are thin shells around them.
//!
//! # Embedding
//!
//! [`SoftBody`] is the whole pipeline in one value: geometry in, stepped at the caller's rate,
//! weights and deformed positions handed back as borrowed slices (no copy).
//!
//! ```
//! use physskin::{BodyOptions, SoftBody};
//!
//! # fn main() -> physskin::Result<()> {
//! // A cloud of 2000 points on a 30 cm ball (x, y, z per point, metres).
//! let points: Vec<f32> = (0..2000)
//!     .flat_map(|i| {
//!         let (t, z) = (i as f32 * 2.39996, 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0);
//!         let r = (1.0 - z * z).sqrt();
//!         [0.15 * r * t.cos(), 0.15 * r * t.sin(), 0.15 * z]
//!     })
//!     .collect();
//! // The bundled network infers its skinning field in one pass; the default support pins its
//! // lowest 10 % and lets gravity act.
//! let mut body = SoftBody::from_points(&points, &[], &BodyOptions::default())?;
//! for _ in 0..30 {
//!     let report = body.step(); // one implicit Euler step of 1/60 s
//!     assert!(report.converged);
//! }
//! let weights: &[f32] = body.weights(); // points x handles, row-major
//! let deformed: &[f32] = body.deformed(); // x, y, z per point, after the last step
//! assert_eq!(weights.len(), 2000 * body.handles());
//! assert_eq!(deformed.len(), points.len());
//! // The top of the ball sags under gravity; the pinned bottom stays.
//! let top = (0..2000).max_by(|&a, &b| points[3 * a + 2].total_cmp(&points[3 * b + 2])).unwrap();
//! assert!(deformed[3 * top + 2] < points[3 * top + 2]);
//! # Ok(())
//! # }
//! ```
//!
//! To hand the slices to other processes without a copy, publish them with
//! [`shm::ShmPublisher`]; `examples/embed.rs` does both.
//!
//! # The node, the replay and the recordings
//!
//! [`node::run`] runs the ROS 2 node in this process until a flag is set ([`node::NodeConfig`]
//! carries its parameters, names and DDS domain). [`replay::replay`] feeds a recording's
//! inputs through the same runtime on the log's time and records the outputs; two replays give
//! identical bytes. [`bag`] reads and writes MCAP in rosbag2's profile, [`msg`] holds the ROS 2
//! message types and their CDR codec.
//!
//! ```
//! use physskin::replay::{replay, ReplayOptions};
//! use physskin::skinning::NeuralModel;
//!
//! # fn main() -> physskin::Result<()> {
//! let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/demo.mcap");
//! let bytes = std::fs::read(demo).expect("the bundled demo recording");
//! let options = ReplayOptions { tail_s: 0.0, ..Default::default() };
//! let model = NeuralModel::bundled()?;
//! let summary = replay(&bytes, "demo.mcap", &model, &options, &mut |_tick| {})?;
//! // A creature (a cloud), a ball and a rounded block (meshes), built and stepped.
//! assert_eq!(summary.shapes.len(), 3);
//! assert_eq!(summary.rejected, 0);
//! # Ok(())
//! # }
//! ```
//!
//! # The layers underneath
//!
//! ```
//! use std::sync::Arc;
//! use nalgebra::Vector3;
//! use physskin::geometry::{box_mesh, Cubature, TetMesh, VoxelGrid};
//! use physskin::physics::{Lifter, ReducedSim, SimParams, Solver, Subspace};
//! use physskin::skinning::{EigenmodeField, EigenmodeOptions};
//!
//! # fn main() -> physskin::Result<()> {
//! // A 1 m bar, its interior voxelized, tetrahedralized, and its 8 lowest skinning eigenmodes.
//! let shape = box_mesh(Vector3::new(1.0, 0.2, 0.2));
//! let grid = VoxelGrid::from_shape(&shape, 128, None).resample(20);
//! let mesh = TetMesh::from_grid(&grid);
//! let field = EigenmodeField::compute(
//!     mesh.clone(),
//!     shape.normalization(),
//!     &EigenmodeOptions { modes: 8, ..Default::default() },
//! )?;
//! let field = Arc::new(field);
//!
//! // The subspace sampled at 256 cubature points, and the simulator over it.
//! let params = SimParams { young: 1e6, ..Default::default() };
//! let cubature = Cubature::stratified(&grid, 256, mesh.volume());
//! let subspace = Arc::new(Subspace::build(field.clone(), shape.normalization(), &cubature, params.density));
//! let mut sim = ReducedSim::new(subspace, params.clone(), Solver::QuasiNewton, 1.04)?;
//!
//! // Hold the left end, let gravity act for half a second.
//! let left: Vec<_> = mesh.vertices.iter().copied().filter(|v| v.x < -0.45).collect();
//! let masses = vec![params.density * mesh.volume() / mesh.vertices.len() as f64; left.len()];
//! sim.add_pins(&left, &masses);
//! for _ in 0..30 {
//!     let report = sim.step();
//!     assert!(report.converged);
//! }
//!
//! // Deformed positions of any point set: here the input mesh's corners.
//! let lifter = Lifter::new(field.as_ref(), &shape.normalization(), &shape.positions);
//! let mut deformed = vec![0.0f32; 3 * lifter.len()];
//! lifter.lift(sim.state(), &mut deformed);
//! let tip_z = deformed[3 * 7 + 2]; // corner (+x, +y, +z)
//! assert!(tip_z < 0.1, "the free end sags below its rest height of 0.1 m");
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]

pub mod bag;
mod bench;
pub mod cli;
mod demo;
pub mod error;
pub mod geometry;
mod io;
mod linalg;
pub mod msg;
pub mod node;
pub mod physics;
pub mod pipeline;
pub mod replay;
pub mod runtime;
pub mod scene;
pub mod shm;
pub mod skinning;
mod training;

pub use error::{Error, Result};
pub use pipeline::{BodyOptions, SoftBody, Support};

/// What the fuzz targets reach beyond the public API: the decoders the node runs on its inputs
/// before it builds anything. Only in `cargo fuzz` builds, which set `--cfg fuzzing`.
#[cfg(fuzzing)]
pub mod fuzzing {
    pub use crate::geometry::{complete_view, parse_obj, parse_ply, parse_stl};
    pub use crate::runtime::{BuildRequest, TfBuffer};
}
