//! Scenes: several objects, a floor, robots from URDF that push and hold them, and the
//! decisions that keep a scene from paying for what it does not need (model size from an error
//! budget, sleeping, cached inference, static and rigid objects left out of the simulation).

mod budget;
mod file;
mod reference;
mod robot;
mod urdf_geometry;
mod world;

use std::path::PathBuf;

pub use file::SceneFile;
pub(crate) use file::{ObjectKind, DEFAULT_FRICTION, DEFAULT_ROLLING_FRICTION};
pub(crate) use reference::{reference_errors, ObjectError, Recorder};
pub(crate) use robot::Robot;
pub(crate) use urdf_geometry::MeshLookup;
pub use world::{FieldCache, ObjectReport, Scene, SceneOptions};

/// What is wrong with a scene or a robot description.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A scene or URDF file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The scene file is not valid YAML for a scene, or a value in it is out of range.
    #[error("scene {path}: {reason}")]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The key and what is wrong with it.
        reason: String,
    },
    /// A robot's URDF could not be used.
    #[error("URDF {path}: {reason}")]
    Urdf {
        /// The URDF file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// One object could not be built (its geometry, its attachment, its simulation).
    #[error("scene object `{object}`: {reason}")]
    Object {
        /// The object's name.
        object: String,
        /// Why.
        reason: String,
    },
}
