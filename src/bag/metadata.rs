//! The `rosbag2` metadata record (key `serialized_metadata`): the bag's description in the
//! YAML of rosbag2's metadata.yaml, version 9, which rosbag2 writes into every MCAP file.
//! Also what that description is made of: each recorded topic and what each file holds.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use crate::msg::TopicInfo;

/// What one file holds.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FileSummary {
    /// The file.
    pub path: PathBuf,
    /// Messages written to it.
    pub messages: u64,
    /// Log time of the first and last message, ns (0 when empty).
    pub start_ns: i64,
    /// Log time of the last message, ns (0 when empty).
    pub end_ns: i64,
    /// Messages per topic name.
    pub per_topic: BTreeMap<String, u64>,
}

#[derive(Serialize)]
struct Nanoseconds {
    nanoseconds: i64,
}

#[derive(Serialize)]
struct SinceEpoch {
    nanoseconds_since_epoch: i64,
}

#[derive(Serialize)]
struct TopicMetadata {
    name: String,
    #[serde(rename = "type")]
    type_name: String,
    serialization_format: &'static str,
    offered_qos_profiles: String,
    type_description_hash: &'static str,
}

#[derive(Serialize)]
struct TopicCount {
    topic_metadata: TopicMetadata,
    message_count: u64,
}

#[derive(Serialize)]
struct FileInformation {
    path: String,
    starting_time: SinceEpoch,
    duration: Nanoseconds,
    message_count: u64,
}

#[derive(Serialize)]
struct BagInformation {
    version: u32,
    storage_identifier: &'static str,
    duration: Nanoseconds,
    starting_time: SinceEpoch,
    message_count: u64,
    topics_with_message_count: Vec<TopicCount>,
    compression_format: &'static str,
    compression_mode: &'static str,
    relative_file_paths: Vec<String>,
    files: Vec<FileInformation>,
    custom_data: std::collections::BTreeMap<String, String>,
    ros_distro: &'static str,
}

#[derive(Serialize)]
struct Document {
    rosbag2_bagfile_information: BagInformation,
}

/// The metadata of one file (`file_name`, relative) holding `summary` of `topics`.
pub fn bag_metadata(file_name: &str, summary: &FileSummary, topics: &[TopicInfo]) -> String {
    let duration = Nanoseconds {
        nanoseconds: summary.end_ns - summary.start_ns,
    };
    let start = || SinceEpoch {
        nanoseconds_since_epoch: summary.start_ns,
    };
    let info = BagInformation {
        version: 9,
        storage_identifier: "mcap",
        duration: Nanoseconds {
            nanoseconds: duration.nanoseconds,
        },
        starting_time: start(),
        message_count: summary.messages,
        topics_with_message_count: topics
            .iter()
            .map(|t| TopicCount {
                topic_metadata: TopicMetadata {
                    name: t.name.clone(),
                    type_name: t.type_name.clone(),
                    serialization_format: "cdr",
                    offered_qos_profiles: t.qos.to_yaml(),
                    type_description_hash: "",
                },
                message_count: summary.per_topic.get(&t.name).copied().unwrap_or(0),
            })
            .collect(),
        compression_format: "",
        compression_mode: "",
        relative_file_paths: vec![file_name.into()],
        files: vec![FileInformation {
            path: file_name.into(),
            starting_time: start(),
            duration,
            message_count: summary.messages,
        }],
        custom_data: Default::default(),
        ros_distro: "jazzy",
    };
    serde_yaml::to_string(&Document {
        rosbag2_bagfile_information: info,
    })
    .expect("plain structs serialize")
}
