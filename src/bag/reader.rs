//! Reading recordings: every message of a file in log-time order, with its topic and type, and
//! `recover`, which rewrites what a killed recorder left behind as a complete file.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use mcap::sans_io::LinearReaderOptions;

use super::writer::{BagWriter, RecordOptions, RecordSummary};
use super::BagError;
use crate::msg::{QosProfile, TopicInfo};

/// One message of a recording.
#[derive(Clone, Debug)]
pub struct BagMessage {
    /// The topic it was recorded on.
    pub topic: String,
    /// The schema's name ("pkg/msg/Type"); empty when the channel has no schema.
    pub type_name: String,
    /// The channel's message encoding ("cdr" for ROS 2).
    pub encoding: String,
    /// When it was recorded, ns.
    pub log_time: i64,
    /// Publish time as recorded, ns.
    pub publish_time: i64,
    /// The serialized message (for "cdr": CDR with its 4-byte encapsulation header).
    pub data: Vec<u8>,
}

/// Every message of an MCAP file in `bytes` (named `source` in errors), sorted by log time
/// (stable: equal times keep file order). Chunk CRCs are checked. Any damage is an error; a
/// replay reads with [`read_recording`], which keeps what is intact.
pub fn read_messages(bytes: &[u8], source: &str) -> Result<Vec<BagMessage>, BagError> {
    let recording = read_recording(bytes, source)?;
    match recording.damage.first() {
        None => Ok(recording.messages),
        // The damage line already starts with the file's name, which the error names too.
        Some(first) => Err(BagError::Read {
            file: source.into(),
            message: first
                .strip_prefix(&format!("{source}: "))
                .unwrap_or(first)
                .into(),
        }),
    }
}

/// What could be read from a recording, and what could not.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// The intact messages, sorted by log time (stable).
    pub messages: Vec<BagMessage>,
    /// One line per damaged part (a chunk with a bad CRC, a channel whose schema is missing, a
    /// cut-off end), naming where it is and what was lost.
    pub damage: Vec<String>,
}

/// Reads every intact message of the MCAP file in `bytes`: a chunk that fails its CRC or does not
/// decompress is skipped with its messages, and reading goes on with the next record; a file cut
/// short keeps everything before the cut. Only a file that is not MCAP at all is an error.
pub fn read_recording(bytes: &[u8], source: &str) -> Result<Recording, BagError> {
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(BagError::Read {
            file: source.into(),
            message: "not an MCAP file (no magic bytes at the start)".into(),
        });
    }
    let mut tables = Tables::default();
    let mut recording = Recording::default();
    let mut at = mcap::MAGIC.len();
    // Records are framed as opcode (1 byte), length (u64 LE), body; walking the frames ourselves
    // lets a damaged record be skipped instead of ending the read.
    while at < bytes.len() {
        let Some((opcode, body)) = frame(bytes, at) else {
            if bytes[at..] != *mcap::MAGIC {
                recording.damage.push(format!(
                    "the file ends inside a record at byte {at} of {} (cut short; {} messages read before)",
                    bytes.len(),
                    recording.messages.len()
                ));
            }
            break;
        };
        let next = at + 9 + body.len();
        match opcode {
            mcap::records::op::CHUNK => {
                // A damaged length would have the decompressor reserve it up front.
                let (claimed, overrun) = match mcap::parse_record(opcode, body) {
                    Ok(mcap::records::Record::Chunk { header, data }) => (
                        header.uncompressed_size,
                        header.compression.is_empty() && !frames_tile(&data),
                    ),
                    _ => (u64::MAX, false),
                };
                if claimed > MAX_RECORD_BYTES as u64 {
                    recording.damage.push(format!(
                        "chunk at byte {at} skipped: its header is unreadable or claims {claimed} bytes (at most {MAX_RECORD_BYTES})"
                    ));
                    at = next;
                    continue;
                }
                // mcap 0.26 subtracts an uncompressed chunk's inner record lengths from what is
                // left of it without a check: a record running past the chunk's end wraps that
                // count (a panic where overflow is checked) and reads on past the chunk.
                if overrun {
                    recording.damage.push(format!(
                        "chunk at byte {at} skipped: a record inside it runs past the chunk's end"
                    ));
                    at = next;
                    continue;
                }
                // The chunk is read alone (a file of just this record), so that its CRC is
                // checked and a bad one costs only this chunk.
                let mut alone = mcap::MAGIC.to_vec();
                alone.extend_from_slice(&bytes[at..next]);
                let records = chunk_records(&alone, claimed as usize);
                match records {
                    Ok(records) => {
                        for record in records {
                            tables.take(record, &mut recording);
                        }
                    }
                    Err(e) => recording
                        .damage
                        .push(format!("chunk at byte {at} skipped with its messages: {e}")),
                }
            }
            mcap::records::op::DATA_END | mcap::records::op::FOOTER => break,
            op if !WANTED.contains(&op) => {}
            _ => match mcap::parse_record(opcode, body) {
                Ok(record) => tables.take(record, &mut recording),
                Err(e) => recording
                    .damage
                    .push(format!("record {opcode:#04x} at byte {at} skipped: {e}")),
            },
        }
        at = next;
    }
    if tables.unknown_channel > 0 {
        recording.damage.push(format!(
            "{} messages name a channel the file does not define; they are skipped",
            tables.unknown_channel
        ));
    }
    for (id, (topic, schema_id)) in &tables.missing_schema {
        recording.damage.push(format!(
            "channel {id} ({topic}) names schema {schema_id}, which the file does not define; \
             its messages carry no type"
        ));
    }
    let source = source.to_string();
    recording
        .damage
        .iter_mut()
        .for_each(|d| *d = format!("{source}: {d}"));
    recording.messages.sort_by_key(|m| m.log_time);
    Ok(recording)
}

/// The records a replay needs. Others (attachments, metadata, indexes) are skipped unparsed:
/// mcap 0.26's parser panics on some damaged ones (an attachment shorter than its header).
const WANTED: [u8; 3] = [
    mcap::records::op::SCHEMA,
    mcap::records::op::CHANNEL,
    mcap::records::op::MESSAGE,
];

/// The largest record (a decompressed chunk) read: 1 GiB.
const MAX_RECORD_BYTES: usize = 1 << 30;

/// The records of a file holding one chunk, its CRC checked before any is read. No record
/// may claim more than the chunk's own (checked) size: lengths are what fuzzing attacks.
fn chunk_records(
    alone: &[u8],
    uncompressed: usize,
) -> Result<Vec<mcap::records::Record<'static>>, mcap::McapError> {
    use mcap::sans_io::LinearReadEvent;
    let mut reader = mcap::sans_io::LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(uncompressed.max(alone.len())),
    );
    let mut rest = alone;
    let mut records = Vec::new();
    while let Some(event) = reader.next_event() {
        match event? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(rest.len());
                reader.insert(n).copy_from_slice(&rest[..n]);
                reader.notify_read(n);
                rest = &rest[n..];
            }
            LinearReadEvent::Record { data, opcode } if WANTED.contains(&opcode) => {
                records.push(mcap::parse_record(opcode, data)?.into_owned());
            }
            LinearReadEvent::Record { .. } => {}
        }
    }
    Ok(records)
}

/// The record at `at`: opcode and body, or None when the file ends inside it.
fn frame(bytes: &[u8], at: usize) -> Option<(u8, &[u8])> {
    let header = bytes.get(at..at.checked_add(9)?)?;
    let length = u64::from_le_bytes(header[1..9].try_into().ok()?);
    let end = (at as u64 + 9).checked_add(length)?;
    let body = bytes.get(at + 9..usize::try_from(end).ok()?)?;
    Some((header[0], body))
}

/// Whether `records` is a whole number of record frames, none running past its end.
fn frames_tile(records: &[u8]) -> bool {
    let mut at = 0;
    while at < records.len() {
        match frame(records, at) {
            Some((_, body)) => at += 9 + body.len(),
            None => return false,
        }
    }
    true
}

/// Schemas and channels seen so far.
#[derive(Default)]
struct Tables {
    schemas: BTreeMap<u16, String>,
    /// Channel id to topic, message encoding and schema name.
    channels: BTreeMap<u16, (String, String, String)>,
    missing_schema: BTreeMap<u16, (String, u16)>,
    unknown_channel: usize,
}

impl Tables {
    fn take(&mut self, record: mcap::records::Record, recording: &mut Recording) {
        use mcap::records::Record;
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                let type_name = match self.schemas.get(&c.schema_id) {
                    Some(name) => name.clone(),
                    None => {
                        if c.schema_id != 0 {
                            self.missing_schema
                                .insert(c.id, (c.topic.clone(), c.schema_id));
                        }
                        String::new()
                    }
                };
                self.channels
                    .insert(c.id, (c.topic, c.message_encoding, type_name));
            }
            Record::Message { header, data } => match self.channels.get(&header.channel_id) {
                Some((topic, encoding, type_name)) => recording.messages.push(BagMessage {
                    topic: topic.clone(),
                    type_name: type_name.clone(),
                    encoding: encoding.clone(),
                    log_time: header.log_time as i64,
                    publish_time: header.publish_time as i64,
                    data: data.into_owned(),
                }),
                None => self.unknown_channel += 1,
            },
            _ => {}
        }
    }
}

/// What `recover` found.
#[derive(Clone, Debug)]
pub struct Recovered {
    /// What the rewritten file holds.
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
        LinearReaderOptions::default()
            .with_skip_end_magic(true)
            .with_record_length_limit(MAX_RECORD_BYTES),
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
