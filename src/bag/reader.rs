//! Reading recordings: every message of a file in log-time order, with its topic and type, and
//! `recover`, which rewrites what a killed recorder left behind as a complete file.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use mcap::read::Options;
use mcap::sans_io::LinearReaderOptions;

use super::qos::QosProfile;
use super::writer::{BagWriter, RecordOptions, RecordSummary, TopicInfo};
use super::BagError;

/// One message of a recording.
#[derive(Clone, Debug)]
pub struct BagMessage {
    pub topic: String,
    /// The schema's name ("pkg/msg/Type"); empty when the channel has no schema.
    pub type_name: String,
    pub encoding: String,
    pub log_time: i64,
    pub publish_time: i64,
    pub data: Vec<u8>,
}

/// Every message of an MCAP file in `bytes` (named `source` in errors), sorted by log time
/// (stable: equal times keep file order). Chunk CRCs are checked.
pub fn read_messages(bytes: &[u8], source: &str) -> Result<Vec<BagMessage>, BagError> {
    let bad = |message: String| BagError::Read {
        file: source.into(),
        message,
    };
    let stream = mcap::MessageStream::new_with_options(bytes, Options::ValidateChunkCrcs.into())
        .map_err(|e| bad(e.to_string()))?;
    let mut messages = Vec::new();
    for (index, m) in stream.enumerate() {
        let m = m.map_err(|e| bad(format!("after {index} messages: {e}")))?;
        messages.push(BagMessage {
            topic: m.channel.topic.clone(),
            type_name: m
                .channel
                .schema
                .as_ref()
                .map_or(String::new(), |s| s.name.clone()),
            encoding: m.channel.message_encoding.clone(),
            log_time: m.log_time as i64,
            publish_time: m.publish_time as i64,
            data: m.data.into_owned(),
        });
    }
    messages.sort_by_key(|m| m.log_time);
    Ok(messages)
}

/// What `recover` found.
#[derive(Clone, Debug)]
pub struct Recovered {
    pub summary: RecordSummary,
    /// Why reading stopped (None: the input was complete).
    pub stopped_by: Option<String>,
}

/// Rewrites every message readable from `input` (a file cut short by a crash, without its
/// summary) into `output`, a complete file with summary and rosbag2 metadata.
pub fn recover(input: &Path, output: &Path) -> Result<Recovered, BagError> {
    let file = File::open(input).map_err(|e| BagError::Io {
        path: input.into(),
        source: e,
    })?;
    let mut writer = BagWriter::create(RecordOptions {
        path: output.into(),
        ..Default::default()
    })?;
    let reader = mcap::io::MessageReader::new_with_options(
        BufReader::new(file),
        LinearReaderOptions::default().with_skip_end_magic(true),
    );
    let mut stopped_by = None;
    for m in reader {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                stopped_by = Some(e.to_string());
                break;
            }
        };
        let channel = &m.channel;
        let (type_name, schema) =
            channel
                .schema
                .as_ref()
                .map_or((String::new(), String::new()), |s| {
                    (
                        s.name.clone(),
                        String::from_utf8_lossy(&s.data).into_owned(),
                    )
                });
        writer.add_topic(TopicInfo {
            name: channel.topic.clone(),
            type_name,
            schema,
            qos: qos_of(&channel.metadata),
        })?;
        writer.write(
            &channel.topic,
            m.log_time as i64,
            m.publish_time as i64,
            &m.data,
        )?;
    }
    Ok(Recovered {
        summary: writer.finish()?,
        stopped_by,
    })
}

/// The QoS in a channel's `offered_qos_profiles` (words or rmw's numbers); sensor QoS if absent.
fn qos_of(metadata: &BTreeMap<String, String>) -> QosProfile {
    let Some(profile) = metadata
        .get("offered_qos_profiles")
        .and_then(|yaml| serde_yaml::from_str::<serde_yaml::Value>(yaml).ok())
        .and_then(|v| v.get(0).cloned())
    else {
        return QosProfile::sensor(5);
    };
    let is = |key: &str, word: &str, number: u64| {
        let v = &profile[key];
        v.as_str() == Some(word) || v.as_u64() == Some(number)
    };
    QosProfile {
        reliable: is("reliability", "reliable", 1),
        transient_local: is("durability", "transient_local", 1),
        depth: profile["depth"].as_u64().unwrap_or(5) as u32,
    }
}
