//! MCAP recording and replay in the ROS 2 profile: what rosbag2, `ros2 bag` and Foxglove read.

mod metadata;
mod reader;
mod recorder;
mod writer;

use std::path::PathBuf;

pub use metadata::FileSummary;
pub use reader::{read_messages, read_recording, recover, BagMessage, Recording, Recovered};
pub use recorder::{Recorder, RecorderHealth};
pub use writer::{BagWriter, RecordOptions, RecordSummary};

/// What went wrong with a recording, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// A file could not be created, read or written.
    #[error("i/o on {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The MCAP writer refused (a record could not be written or a file not finished).
    #[error("writing MCAP {path}: {message}")]
    Write {
        /// The file being written.
        path: PathBuf,
        /// The MCAP library's error, in words.
        message: String,
    },
    /// A recording could not be read: not MCAP at all, or (for a strict read) damaged.
    #[error("reading MCAP {file}: {message}")]
    Read {
        /// The recording's name as given by the caller.
        file: String,
        /// What is wrong with it.
        message: String,
    },
    /// Refused: an option out of range, a topic declared with two types, a message on an
    /// undeclared topic.
    #[error("recording options: {0}")]
    Options(String),
    /// The recording thread could not start or has ended (finished, failed, panicked).
    #[error("recording stopped: {0}")]
    Stopped(String),
    /// One recorded message could not be used.
    #[error("{file} at log time {log_time} ns, topic {topic}: {message}")]
    Message {
        /// The recording's name.
        file: String,
        /// The message's topic.
        topic: String,
        /// The message's log time, ns.
        log_time: i64,
        /// What is wrong with it.
        message: String,
    },
}

impl BagError {
    fn mcap(path: &std::path::Path, e: mcap::McapError) -> Self {
        BagError::Write {
            path: path.into(),
            message: e.to_string(),
        }
    }
}
