//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in physskin, each variant naming what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A geometry file could not be read or parsed.
    #[error(transparent)]
    Load(#[from] crate::geometry::LoadError),
    /// The geometry cannot be simulated (no points, not finite, degenerate); the text says why.
    #[error("geometry: {0}")]
    Geometry(String),
    /// A parameter was out of its range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// What its value should have been.
        reason: String,
    },
    /// A factorization failed (a matrix not positive definite, a singular block).
    #[error("linear algebra: {0}")]
    LinearAlgebra(String),
    /// The skinning eigenmodes' iterative solve ran out of iterations before its tolerance.
    #[error("eigen-solve did not converge: {converged} of {wanted} modes after {iterations} iterations (largest residual {residual:e})")]
    EigenNotConverged {
        /// Modes that met the tolerance.
        converged: usize,
        /// Modes asked for.
        wanted: usize,
        /// Iterations run.
        iterations: usize,
        /// The largest relative residual of the wanted modes at the end.
        residual: f64,
    },
    /// A network model file or its weights could not be used.
    #[error("model {what}: {reason}")]
    Model {
        /// Which model or part: a path, "bundled", "weights".
        what: String,
        /// Why it was refused.
        reason: String,
    },
    /// Candle fails only on shape bugs or allocation failure; its message is kept.
    #[error("network computation: {0}")]
    Network(#[from] candle_core::Error),
    /// The ROS 2 node failed.
    #[error(transparent)]
    Node(#[from] NodeError),
    /// An MCAP recording could not be written or read.
    #[error(transparent)]
    Bag(#[from] crate::bag::BagError),
    /// The iceoryx2 shared-memory hand-off failed.
    #[error(transparent)]
    Shm(#[from] crate::shm::ShmError),
    /// A scene file or a robot in it could not be used.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// Node parameters were refused.
    #[error(transparent)]
    Params(#[from] ParamError),
    /// A peer program a benchmark runs (MuJoCo's Python script) failed or printed what was
    /// not expected; the text says which and why.
    #[error("peer: {0}")]
    Peer(String),
    /// A file could not be read or written.
    #[error("i/o on {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
}

/// The crate's result type, with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// Why parameters were refused.
#[derive(Debug, thiserror::Error)]
pub enum ParamError {
    /// The parameter file could not be read.
    #[error("cannot read parameter file {path}: {reason}")]
    File {
        /// The file.
        path: String,
        /// The operating system's error, in words.
        reason: String,
    },
    /// The file is not a ROS 2 parameter file (bad YAML, or not `node: ros__parameters:`).
    #[error("parameter file {path}: {reason}")]
    Format {
        /// The file, or `<text>` for YAML given as text.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A known parameter was given a value of the wrong type or out of its range.
    #[error("parameter `{name}`: {reason}")]
    Invalid {
        /// The parameter's dotted name (`material.young`).
        name: String,
        /// Why the value was refused.
        reason: String,
    },
    /// No parameter has this name.
    #[error("parameter `{name}`: no such parameter")]
    Unknown {
        /// The name given.
        name: String,
    },
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

/// Why the node could not start.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// DDS refused: a context, topic, publisher, subscription or server could not be made.
    #[error("DDS: {0}")]
    Dds(String),
    /// ros2_client refused a node, topic or service name.
    #[error("invalid node name: {0}")]
    Name(String),
    /// The parameters were refused.
    #[error(transparent)]
    Params(#[from] ParamError),
    /// The signal handler could not be installed.
    #[error("signal handler: {0}")]
    Signal(String),
    /// A name could not be expanded or remapped.
    #[error(transparent)]
    Names(#[from] crate::runtime::NameError),
    /// The `--ros-args` were refused.
    #[error(transparent)]
    RosArgs(#[from] crate::node::RosArgsError),
    /// The recording could not start.
    #[error(transparent)]
    Record(#[from] crate::bag::BagError),
    /// The scene file named by the `scene` parameter could not be read.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
}
