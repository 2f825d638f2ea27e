//! MCAP recording and replay in the ROS 2 profile: what rosbag2, `ros2 bag` and Foxglove read.

mod metadata;
mod qos;
mod reader;
mod recorder;
mod replay;
mod schema;
mod writer;

use std::path::PathBuf;

pub use metadata::{FileSummary, TopicInfo};
pub use qos::QosProfile;
pub use reader::{read_messages, read_recording, recover, BagMessage, Recording, Recovered};
pub use recorder::{Recorder, RecorderHealth};
pub use replay::{replay, ReplayOptions, ReplaySummary, ShapeSummary, Tick};
pub use schema::schema_text;
pub use writer::{BagWriter, RecordOptions, RecordSummary};

/// What went wrong with a recording, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    #[error("i/o on {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("writing MCAP {path}: {message}")]
    Write { path: PathBuf, message: String },
    #[error("reading MCAP {file}: {message}")]
    Read { file: String, message: String },
    #[error("recording options: {0}")]
    Options(String),
    #[error("recording stopped: {0}")]
    Stopped(String),
    #[error("{file} at log time {log_time} ns, topic {topic}: {message}")]
    Message {
        file: String,
        topic: String,
        log_time: i64,
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
