//! Recording on a thread of its own: callers serialize and hand over bytes; compression and
//! disk writes never run on the stepping thread.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use super::writer::{BagWriter, RecordOptions, RecordSummary};
use super::BagError;
use crate::msg::{encode, Output, RosMessage, Sink, TopicInfo};

enum Command {
    Topic(TopicInfo),
    Message {
        topic: String,
        log_time: i64,
        publish_time: i64,
        data: Vec<u8>,
    },
    Finish,
}

/// A recording in progress. Cheap to share (`&self` everywhere); [`Recorder::finish`] ends it.
pub struct Recorder {
    sender: SyncSender<Command>,
    /// Topics to record; empty: all.
    topics: Vec<String>,
    thread: Mutex<Option<JoinHandle<Result<RecordSummary, BagError>>>>,
    counters: Arc<Counters>,
    path: String,
}

/// What a running recording has taken, for /diagnostics.
#[derive(Default)]
struct Counters {
    messages: AtomicU64,
    bytes: AtomicU64,
    /// Messages that could not be handed over: the recording had stopped.
    dropped: AtomicU64,
    /// Why the writing thread stopped, once it has failed.
    failure: Mutex<Option<String>>,
}

/// A recording's health: where it goes, what it took, what it lost.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecorderHealth {
    /// The recording's first file.
    pub path: String,
    /// Messages handed to the writing thread.
    pub messages: u64,
    /// Serialized message bytes handed to the writer (before compression).
    pub bytes: u64,
    /// Messages lost because the recording had stopped.
    pub dropped: u64,
    /// The writer's error, once it has failed.
    pub failure: Option<String>,
}

impl Recorder {
    /// Creates the first file now (so a bad path fails here) and starts the writing thread.
    /// `topics` limits what is recorded (empty: everything offered).
    pub fn start(options: RecordOptions, topics: Vec<String>) -> Result<Self, BagError> {
        let path = options.path.display().to_string();
        let mut writer = BagWriter::create(options)?;
        let counters = Arc::new(Counters::default());
        let seen_by_writer = counters.clone();
        // Room for a few seconds of 60 Hz output; beyond it callers wait rather than lose data.
        let (sender, receiver) = sync_channel::<Command>(1024);
        let thread = std::thread::Builder::new()
            .name("physskin-record".into())
            .spawn(move || {
                let mut failure = None;
                for command in receiver {
                    let result = match command {
                        Command::Topic(topic) => writer.add_topic(topic),
                        Command::Message {
                            topic,
                            log_time,
                            publish_time,
                            data,
                        } => writer.write(&topic, log_time, publish_time, &data),
                        Command::Finish => break,
                    };
                    if let Err(e) = result {
                        if let Ok(mut slot) = seen_by_writer.failure.lock() {
                            *slot = Some(e.to_string());
                        }
                        failure = Some(e);
                        break;
                    }
                }
                // Whatever happened, close the file so that what was written stays readable.
                let summary = writer.finish();
                match failure {
                    Some(e) => Err(e),
                    None => summary,
                }
            })
            .map_err(|e| BagError::Stopped(format!("cannot start the recording thread: {e}")))?;
        Ok(Self {
            sender,
            topics,
            thread: Mutex::new(Some(thread)),
            counters,
            path,
        })
    }

    /// What the recording has taken and lost so far.
    pub fn health(&self) -> RecorderHealth {
        let c = &self.counters;
        RecorderHealth {
            path: self.path.clone(),
            messages: c.messages.load(Ordering::Relaxed),
            bytes: c.bytes.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            failure: c.failure.lock().ok().and_then(|f| f.clone()),
        }
    }

    /// Whether messages on `topic` are recorded.
    pub fn wants(&self, topic: &str) -> bool {
        self.topics.is_empty() || self.topics.iter().any(|t| t == topic)
    }

    /// Declares a topic (its channel is written even when no message follows).
    pub fn declare(&self, topic: TopicInfo) -> Result<(), BagError> {
        if !self.wants(&topic.name) {
            return Ok(());
        }
        self.send(Command::Topic(topic))
    }

    /// Records a message of a declared topic. Times in ns.
    pub fn record<M: RosMessage>(
        &self,
        topic: &str,
        log_time: i64,
        publish_time: i64,
        message: &M,
    ) -> Result<(), BagError> {
        self.queue(topic, log_time, publish_time, || encode(message))
    }

    /// Records an already serialized (CDR) message of a declared topic.
    pub fn record_raw(
        &self,
        topic: &str,
        log_time: i64,
        publish_time: i64,
        data: &[u8],
    ) -> Result<(), BagError> {
        self.queue(topic, log_time, publish_time, || data.to_vec())
    }

    /// Hands a message to the writing thread; `data` is only made for wanted topics.
    fn queue(
        &self,
        topic: &str,
        log_time: i64,
        publish_time: i64,
        data: impl FnOnce() -> Vec<u8>,
    ) -> Result<(), BagError> {
        if !self.wants(topic) {
            return Ok(());
        }
        let data = data();
        let size = data.len() as u64;
        let sent = self.send(Command::Message {
            topic: topic.into(),
            log_time,
            publish_time,
            data,
        });
        let c = &self.counters;
        match &sent {
            Ok(()) => {
                c.messages.fetch_add(1, Ordering::Relaxed);
                c.bytes.fetch_add(size, Ordering::Relaxed);
            }
            Err(_) => {
                c.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
        sent
    }

    fn send(&self, command: Command) -> Result<(), BagError> {
        self.sender.send(command).map_err(|_| self.stopped_reason())
    }

    fn stopped_reason(&self) -> BagError {
        match self.join() {
            Some(Err(e)) => e,
            _ => BagError::Stopped("the recording was finished".into()),
        }
    }

    fn join(&self) -> Option<Result<RecordSummary, BagError>> {
        let handle = self.thread.lock().ok()?.take()?;
        Some(
            handle
                .join()
                .unwrap_or_else(|_| Err(BagError::Stopped("the recording thread panicked".into()))),
        )
    }

    /// Writes what is queued, closes the file(s) and says what they hold.
    pub fn finish(&self) -> Result<RecordSummary, BagError> {
        let _ = self.sender.send(Command::Finish);
        self.join().unwrap_or_else(|| {
            Err(BagError::Stopped(
                "the recording was already finished".into(),
            ))
        })
    }
}

/// A recording is a sink of the runtime's outputs: each is recorded with its log time as its
/// publish time too. A message the recording refuses is logged, and the runtime goes on.
impl Sink for Recorder {
    fn send(&self, topic: &str, log_time_ns: i64, message: &Output) {
        let (t, at) = (topic, log_time_ns);
        let recorded = match message {
            Output::Cloud(m) => self.record(t, at, at, m),
            Output::Weights(m) => self.record(t, at, at, m),
            Output::State(m) => self.record(t, at, at, m),
            Output::Status(m) => self.record(t, at, at, m),
            Output::Markers(m) => self.record(t, at, at, m),
        };
        if let Err(e) = recorded {
            log::error!("recording {topic}: {e}");
        }
    }
}
