//! Scenes: several objects, a floor, robots from URDF that push and hold them, and the
//! decisions that keep a scene from paying for what it does not need (model size from an error
//! budget, sleeping, cached inference, static and rigid objects left out of the simulation).

mod budget;
mod file;
mod reference;
mod robot;
mod world;

use std::path::PathBuf;

pub use budget::{choose_resolution, Choice};
pub use file::{
    Attachment, Keyframe, MaterialSpec, ObjectKind, ObjectSpec, PoseSpec, Region, Resolution,
    RobotSpec, SceneFile, ShapeSpec, Source, DEFAULT_ROLLING_FRICTION,
};
pub use reference::{reference_errors, ObjectError, Recorder};
pub use robot::Robot;
pub use world::{FieldCache, ObjectReport, Scene, SceneOptions};

/// What is wrong with a scene or a robot description.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("scene {path}: {reason}")]
    Invalid { path: PathBuf, reason: String },
    #[error("URDF {path}: {reason}")]
    Urdf { path: PathBuf, reason: String },
    #[error("scene object `{object}`: {reason}")]
    Object { object: String, reason: String },
}
