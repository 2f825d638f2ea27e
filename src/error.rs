//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in physskin, each variant naming what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Load(#[from] crate::geometry::LoadError),
    #[error("geometry: {0}")]
    Geometry(String),
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter { name: &'static str, reason: String },
    #[error("linear algebra: {0}")]
    LinearAlgebra(String),
    #[error("eigen-solve did not converge: {converged} of {wanted} modes after {iterations} iterations (largest residual {residual:e})")]
    EigenNotConverged {
        converged: usize,
        wanted: usize,
        iterations: usize,
        residual: f64,
    },
    #[error("model {what}: {reason}")]
    Model { what: String, reason: String },
    /// Candle fails only on shape bugs or allocation failure; its message is kept.
    #[error("network computation: {0}")]
    Network(#[from] candle_core::Error),
    #[error(transparent)]
    Node(#[from] crate::ros::NodeError),
    #[error(transparent)]
    Bag(#[from] crate::bag::BagError),
    #[error(transparent)]
    Shm(#[from] crate::shm::ShmError),
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error("i/o on {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

pub type Result<T> = std::result::Result<T, Error>;

/// Why parameters were refused.
#[derive(Debug, thiserror::Error)]
pub enum ParamError {
    #[error("cannot read parameter file {path}: {reason}")]
    File { path: String, reason: String },
    #[error("parameter file {path}: {reason}")]
    Format { path: String, reason: String },
    #[error("parameter `{name}`: {reason}")]
    Invalid { name: String, reason: String },
    #[error("parameter `{name}`: no such parameter")]
    Unknown { name: String },
}

/// Shorthand for a parameter check that fails with a message naming the parameter.
pub(crate) fn ensure(ok: bool, name: &'static str, reason: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            reason: reason(),
        })
    }
}
