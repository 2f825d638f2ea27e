//! Writes ROS 2 MCAP files that rosbag2 and Foxglove read: profile `ros2`, `ros2msg` schemas,
//! `cdr` channels with their offered QoS, zstd chunks, a summary with statistics, and the
//! `rosbag2` metadata record. Chunks are closed at least every `flush_interval_s`, so a killed
//! recorder loses only the open chunk; the file can be split by size or duration.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::metadata::{bag_metadata, FileSummary};
use super::BagError;
use crate::msg::TopicInfo;

/// Where and how to record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordOptions {
    /// The first file. Split files follow as `<stem>_1.mcap`, `<stem>_2.mcap`, ...
    pub path: PathBuf,
    /// Start a new file when this one passes this size, MB. 0: never. Default 0.
    pub split_size_mb: f64,
    /// Start a new file when this one spans this much log time, s. 0: never. Default 0.
    pub split_duration_s: f64,
    /// The open chunk is closed and flushed to disk at least this often (wall clock), s: what
    /// a kill -9 can lose. Default 1.
    pub flush_interval_s: f64,
}

impl Default for RecordOptions {
    fn default() -> Self {
        Self {
            path: PathBuf::from("physskin.mcap"),
            split_size_mb: 0.0,
            split_duration_s: 0.0,
            flush_interval_s: 1.0,
        }
    }
}

/// What a recording holds, over all its files.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RecordSummary {
    /// Each file, in the order written.
    pub files: Vec<FileSummary>,
    /// Messages over all files.
    pub messages: u64,
    /// Messages per topic name over all files.
    pub per_topic: BTreeMap<String, u64>,
}

/// A `Write + Seek` that knows how many bytes the file has, for splitting by size.
struct Counted {
    inner: BufWriter<File>,
    position: u64,
    /// The file's size so far, shared with the [`OpenFile`] (the mcap writer owns this).
    end: Arc<AtomicU64>,
}

impl Write for Counted {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.position += n as u64;
        self.end.fetch_max(self.position, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for Counted {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.position = self.inner.seek(pos)?;
        Ok(self.position)
    }
}

struct OpenFile {
    writer: mcap::Writer<Counted>,
    bytes: Arc<AtomicU64>,
    channels: HashMap<String, u16>,
    summary: FileSummary,
}

/// One recording, possibly split over several files.
pub struct BagWriter {
    options: RecordOptions,
    topics: Vec<TopicInfo>,
    file: Option<OpenFile>,
    done: Vec<FileSummary>,
    last_flush: Instant,
}

impl BagWriter {
    /// Checks the options and creates the first file (and its directory). An error: an option
    /// out of range (`BagError::Options`), or a file that cannot be created or started
    /// (`BagError::Io`, `BagError::Write`).
    pub fn create(options: RecordOptions) -> Result<Self, BagError> {
        let check = |ok: bool, what: &str| {
            if ok {
                Ok(())
            } else {
                Err(BagError::Options(what.to_string()))
            }
        };
        check(
            options.split_size_mb >= 0.0 && options.split_size_mb.is_finite(),
            "split_size_mb must be 0 (off) or positive",
        )?;
        check(
            options.split_duration_s >= 0.0 && options.split_duration_s.is_finite(),
            "split_duration_s must be 0 (off) or positive",
        )?;
        check(
            options.flush_interval_s > 0.0 && options.flush_interval_s.is_finite(),
            "flush_interval_s must be positive",
        )?;
        let mut writer = Self {
            file: None,
            done: Vec::new(),
            topics: Vec::new(),
            last_flush: Instant::now(),
            options,
        };
        writer.open(0)?;
        Ok(writer)
    }

    fn path_of(&self, index: usize) -> PathBuf {
        if index == 0 {
            return self.options.path.clone();
        }
        let stem = self
            .options
            .path
            .file_stem()
            .map_or("physskin".into(), |s| s.to_string_lossy().into_owned());
        self.options
            .path
            .with_file_name(format!("{stem}_{index}.mcap"))
    }

    fn open(&mut self, index: usize) -> Result<(), BagError> {
        let path = self.path_of(index);
        let io = |e: std::io::Error| BagError::Io {
            path: path.clone(),
            source: e,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        let file = File::create(&path).map_err(io)?;
        let bytes = Arc::new(AtomicU64::new(0));
        let counted = Counted {
            inner: BufWriter::with_capacity(1 << 20, file),
            position: 0,
            end: bytes.clone(),
        };
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("physskin ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            // The recorder has a thread of its own; zstd's workers would compete with stepping.
            .compression_threads(0)
            .chunk_size(Some(4 << 20))
            .create(counted)
            .map_err(|e| BagError::mcap(&path, e))?;
        let mut open = OpenFile {
            writer,
            bytes,
            channels: HashMap::new(),
            summary: FileSummary {
                path,
                ..Default::default()
            },
        };
        for topic in &self.topics {
            add_channel(&mut open, topic)?;
        }
        self.file = Some(open);
        self.last_flush = Instant::now();
        Ok(())
    }

    /// Declares a topic (again: no effect). Messages can only be written to declared topics.
    pub fn add_topic(&mut self, topic: TopicInfo) -> Result<(), BagError> {
        if let Some(known) = self.topics.iter().find(|t| t.name == topic.name) {
            if known.type_name != topic.type_name {
                return Err(BagError::Options(format!(
                    "topic {} recorded as {} cannot also carry {}",
                    topic.name, known.type_name, topic.type_name
                )));
            }
            return Ok(());
        }
        if let Some(open) = &mut self.file {
            add_channel(open, &topic)?;
        }
        self.topics.push(topic);
        Ok(())
    }

    /// The topics declared so far, in declaration order.
    pub fn topics(&self) -> &[TopicInfo] {
        &self.topics
    }

    /// Writes one serialized (CDR) message. Times in ns.
    pub fn write(
        &mut self,
        topic: &str,
        log_time: i64,
        publish_time: i64,
        data: &[u8],
    ) -> Result<(), BagError> {
        self.split_if_due(log_time)?;
        let open = self.file.as_mut().expect("a file is open until finish");
        let channel_id = *open
            .channels
            .get(topic)
            .ok_or_else(|| BagError::Options(format!("topic {topic} was not declared")))?;
        let s = &mut open.summary;
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: s.messages as u32,
            log_time: log_time.max(0) as u64,
            publish_time: publish_time.max(0) as u64,
        };
        open.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| BagError::mcap(&s.path, e))?;
        if s.messages == 0 {
            s.start_ns = log_time;
        }
        s.start_ns = s.start_ns.min(log_time);
        s.end_ns = s.end_ns.max(log_time);
        s.messages += 1;
        *s.per_topic.entry(topic.to_string()).or_default() += 1;
        if self.last_flush.elapsed().as_secs_f64() >= self.options.flush_interval_s {
            self.flush()?;
        }
        Ok(())
    }

    /// Closes the open chunk and pushes it to the disk.
    pub fn flush(&mut self) -> Result<(), BagError> {
        if let Some(open) = &mut self.file {
            open.writer
                .flush()
                .map_err(|e| BagError::mcap(&open.summary.path, e))?;
        }
        self.last_flush = Instant::now();
        Ok(())
    }

    fn split_if_due(&mut self, log_time: i64) -> Result<(), BagError> {
        let Some(open) = &self.file else {
            return Ok(());
        };
        let s = &open.summary;
        if s.messages == 0 {
            return Ok(());
        }
        let too_big = self.options.split_size_mb > 0.0
            && open.bytes.load(Ordering::Relaxed) as f64 >= self.options.split_size_mb * 1e6;
        let too_long = self.options.split_duration_s > 0.0
            && (log_time - s.start_ns) as f64 >= self.options.split_duration_s * 1e9;
        if too_big || too_long {
            let index = self.done.len() + 1;
            self.close_file()?;
            self.open(index)?;
        }
        Ok(())
    }

    fn close_file(&mut self) -> Result<(), BagError> {
        let Some(mut open) = self.file.take() else {
            return Ok(());
        };
        let path = open.summary.path.clone();
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let yaml = bag_metadata(&name, &open.summary, &self.topics);
        open.writer
            .write_metadata(&mcap::records::Metadata {
                name: "rosbag2".into(),
                metadata: BTreeMap::from([("serialized_metadata".to_string(), yaml)]),
            })
            .and_then(|_| open.writer.finish())
            .map_err(|e| BagError::mcap(&path, e))?;
        open.writer
            .into_inner()
            .flush()
            .map_err(|e| BagError::Io { path, source: e })?;
        self.done.push(open.summary);
        Ok(())
    }

    /// Finishes the last file (summary, statistics, metadata) and says what was written.
    pub fn finish(mut self) -> Result<RecordSummary, BagError> {
        self.close_file()?;
        let mut summary = RecordSummary {
            files: std::mem::take(&mut self.done),
            ..Default::default()
        };
        for f in &summary.files {
            summary.messages += f.messages;
            for (topic, n) in &f.per_topic {
                *summary.per_topic.entry(topic.clone()).or_default() += n;
            }
        }
        Ok(summary)
    }
}

fn add_channel(open: &mut OpenFile, topic: &TopicInfo) -> Result<(), BagError> {
    let path = &open.summary.path;
    let schema = open
        .writer
        .add_schema(&topic.type_name, "ros2msg", topic.schema.as_bytes())
        .map_err(|e| BagError::mcap(path, e))?;
    let metadata = BTreeMap::from([
        ("offered_qos_profiles".to_string(), topic.qos.to_yaml()),
        ("topic_type_hash".to_string(), String::new()),
    ]);
    let id = open
        .writer
        .add_channel(schema, &topic.name, "cdr", &metadata)
        .map_err(|e| BagError::mcap(path, e))?;
    open.channels.insert(topic.name.clone(), id);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::read_messages;
    use crate::msg::QosProfile;
    use crate::msg::Status;

    #[test]
    fn files_split_by_size_are_each_complete() {
        let dir = std::env::temp_dir().join(format!("physskin-split-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut writer = BagWriter::create(RecordOptions {
            path: dir.join("run.mcap"),
            split_size_mb: 0.05,
            // Close a chunk after every message, so the size is seen as it grows.
            flush_interval_s: 1e-9,
            ..Default::default()
        })
        .unwrap();
        writer
            .add_topic(TopicInfo::of::<Status>(
                "/text",
                QosProfile::reliable(1, false),
            ))
            .unwrap();
        // Incompressible payloads of 2 KB.
        let mut state = 1u64;
        for i in 0..100 {
            let data: Vec<u8> = (0..2048)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (state >> 56) as u8
                })
                .collect();
            writer
                .write("/text", i * 1_000_000, i * 1_000_000, &data)
                .unwrap();
        }
        let summary = writer.finish().unwrap();
        assert!(summary.files.len() >= 3, "{} files", summary.files.len());
        assert_eq!(summary.files[1].path, dir.join("run_1.mcap"));
        let mut total = 0;
        for f in &summary.files {
            let bytes = std::fs::read(&f.path).unwrap();
            assert!(
                bytes.len() < 80_000,
                "{} is {} bytes",
                f.path.display(),
                bytes.len()
            );
            let messages = read_messages(&bytes, "split").unwrap();
            assert_eq!(messages.len() as u64, f.messages);
            total += messages.len();
        }
        assert_eq!(total, 100);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_options_are_refused_by_name() {
        let err = BagWriter::create(RecordOptions {
            split_size_mb: -1.0,
            ..Default::default()
        })
        .err()
        .unwrap();
        assert!(err.to_string().contains("split_size_mb"), "{err}");
    }
}
