//! Zero-copy hand-off to local programs over iceoryx2 shared memory: per frame, the deformed
//! points, and per shape, its weights, as f32 slices behind a `#[repr(C)]` header. Subscribers
//! read the publisher's memory in place; nothing is serialized.
//!
//! Services (defaults): `physskin/deformed_points` (x, y, z per point) and `physskin/weights`
//! (points x handles, row-major). Payload type `[f32]` (iceoryx2 type name "f32"), user header
//! [`FrameHeader`] (type name "PhysskinFrameHeader"), so C, C++ and Python subscribers can open
//! them too.

use std::sync::atomic::{AtomicU64, Ordering};

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use iceoryx2::service::ipc_threadsafe;

/// In front of every frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("PhysskinFrameHeader")]
#[repr(C)]
pub struct FrameHeader {
    /// The shape (as in the ROS messages' shape_id).
    pub shape_id: u32,
    /// Points in the frame.
    pub point_count: u32,
    /// Handles of the shape, the rigid one included (weights frames carry this many floats per
    /// point; deformed frames carry 3).
    pub handle_count: u32,
    /// 0: deformed points, 1: weights.
    pub kind: u32,
    /// Time of the state, ns (the node's clock).
    pub stamp_ns: i64,
    /// Counts frames of this service from 0.
    pub sequence: u64,
}

impl FrameHeader {
    /// `kind` of a frame of deformed points.
    pub const DEFORMED: u32 = 0;
    /// `kind` of a frame of skinning weights.
    pub const WEIGHTS: u32 = 1;
}

/// Why the shared-memory transport could not start or send.
#[derive(Debug, thiserror::Error)]
pub enum ShmError {
    /// iceoryx2 refused a service name.
    #[error("iceoryx2 service name `{name}`: {reason}")]
    Name {
        /// The name.
        name: String,
        /// iceoryx2's error.
        reason: String,
    },
    /// iceoryx2 could not create its node, a service or a publisher, or could not send.
    #[error("iceoryx2: {0}")]
    Transport(String),
}

fn transport(e: impl std::fmt::Debug) -> ShmError {
    ShmError::Transport(format!("{e:?}"))
}

/// Service names and sizes.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShmOptions {
    /// Default "physskin/deformed_points".
    pub deformed_service: String,
    /// Default "physskin/weights".
    pub weights_service: String,
    /// Floats a frame may hold before the publisher reallocates (it grows by powers of two).
    /// Default 300,000 (100k points of x, y, z).
    pub initial_max_floats: usize,
}

impl Default for ShmOptions {
    fn default() -> Self {
        Self {
            deformed_service: "physskin/deformed_points".into(),
            weights_service: "physskin/weights".into(),
            initial_max_floats: 300_000,
        }
    }
}

type Service = ipc_threadsafe::Service;

/// Frames a subscriber holds before the oldest is overwritten: a second of one object at 60 Hz,
/// or a replay's catch-up after a slow build (a burst of up to about 30 frames of three
/// objects), while the subscriber polls every few milliseconds. Every opener of a service must
/// ask for the same (tests/peers/shm_peer.py does).
pub const SUBSCRIBER_BUFFER: usize = 64;

/// Subscribers per service. The shared segment holds about MAX_SUBSCRIBERS x SUBSCRIBER_BUFFER
/// frames of the largest size so far (address space; only written frames take memory).
pub const MAX_SUBSCRIBERS: usize = 8;

/// An iceoryx2 node; its own log is kept to errors (it would otherwise note on every start that
/// no config file exists). What processes killed with SIGKILL left behind (in /dev/shm and
/// /tmp/iceoryx2) is cleaned up on the way.
fn new_node() -> Result<Node<Service>, ShmError> {
    set_log_level(LogLevel::Error);
    let node = NodeBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<Service>()
        .map_err(transport)?;
    node.try_cleanup_dead_nodes();
    Ok(node)
}

/// Publishes frames to local subscribers; shareable between threads.
pub struct ShmPublisher {
    deformed: Publisher<Service, [f32], FrameHeader>,
    weights: Publisher<Service, [f32], FrameHeader>,
    sequences: [AtomicU64; 2],
    // Dropped last: the ports above belong to it.
    _node: Node<Service>,
}

/// Opens (or creates) a service of f32 frames.
pub(crate) fn open_service(
    node: &Node<Service>,
    name: &str,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<Service, [f32], FrameHeader>,
    ShmError,
> {
    let service_name: ServiceName = name.try_into().map_err(|e| ShmError::Name {
        name: name.into(),
        reason: format!("{e:?}"),
    })?;
    node.service_builder(&service_name)
        .publish_subscribe::<[f32]>()
        .user_header::<FrameHeader>()
        .history_size(1)
        .subscriber_max_buffer_size(SUBSCRIBER_BUFFER)
        .max_publishers(4)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
        .map_err(transport)
}

impl ShmPublisher {
    /// Opens (or creates) both services and a publisher on each. An error when a service name
    /// is refused or iceoryx2 cannot start.
    pub fn create(options: &ShmOptions) -> Result<Self, ShmError> {
        let node = new_node()?;
        let publisher = |name: &str, floats: usize| {
            open_service(&node, name)?
                .publisher_builder()
                .initial_max_slice_len(floats.max(1))
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .create()
                .map_err(transport)
        };
        Ok(Self {
            deformed: publisher(&options.deformed_service, options.initial_max_floats)?,
            weights: publisher(&options.weights_service, options.initial_max_floats)?,
            sequences: Default::default(),
            _node: node,
        })
    }

    /// The deformed points of a shape (x, y, z per point), copied once into shared memory.
    pub fn publish_deformed(
        &self,
        shape_id: u32,
        stamp_ns: i64,
        handle_count: usize,
        xyz: &[f32],
    ) -> Result<(), ShmError> {
        self.send(
            &self.deformed,
            FrameHeader::DEFORMED,
            shape_id,
            stamp_ns,
            handle_count,
            xyz,
            3,
        )
    }

    /// The weights of a shape (points x handles, row-major).
    pub fn publish_weights(
        &self,
        shape_id: u32,
        stamp_ns: i64,
        handle_count: usize,
        weights: &[f32],
    ) -> Result<(), ShmError> {
        let per_point = handle_count.max(1);
        self.send(
            &self.weights,
            FrameHeader::WEIGHTS,
            shape_id,
            stamp_ns,
            handle_count,
            weights,
            per_point,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn send(
        &self,
        publisher: &Publisher<Service, [f32], FrameHeader>,
        kind: u32,
        shape_id: u32,
        stamp_ns: i64,
        handle_count: usize,
        values: &[f32],
        per_point: usize,
    ) -> Result<(), ShmError> {
        let sequence = self.sequences[kind as usize].fetch_add(1, Ordering::Relaxed);
        let mut sample = publisher
            .loan_slice_uninit(values.len())
            .map_err(transport)?;
        *sample.user_header_mut() = FrameHeader {
            shape_id,
            point_count: (values.len() / per_point) as u32,
            handle_count: handle_count as u32,
            kind,
            stamp_ns,
            sequence,
        };
        let sample = sample.write_from_slice(values);
        sample.send().map_err(transport)?;
        Ok(())
    }
}

/// Receives the frames of one service, reading the publisher's memory in place, and counts
/// the frames it lost (gaps in the sequence numbers: it fell more than [`SUBSCRIBER_BUFFER`]
/// frames behind, and the oldest were overwritten).
pub struct ShmSubscriber {
    subscriber: iceoryx2::port::subscriber::Subscriber<Service, [f32], FrameHeader>,
    /// The sequence number the next frame should carry; u64::MAX before the first.
    next: AtomicU64,
    lost: AtomicU64,
    _node: Node<Service>,
}

impl ShmSubscriber {
    /// Subscribes to `service` (created if no publisher has made it yet).
    pub fn open(service: &str) -> Result<Self, ShmError> {
        let node = new_node()?;
        let subscriber = open_service(&node, service)?
            .subscriber_builder()
            .create()
            .map_err(transport)?;
        Ok(Self {
            subscriber,
            next: AtomicU64::new(u64::MAX),
            lost: AtomicU64::new(0),
            _node: node,
        })
    }

    /// Frames lost since the first received: sent by the publisher, overwritten before this
    /// subscriber took them.
    pub fn lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }

    /// Calls `frame` with each frame received since the last call (its header and its floats,
    /// still in shared memory); returns how many there were.
    pub fn receive(&self, mut frame: impl FnMut(&FrameHeader, &[f32])) -> Result<usize, ShmError> {
        let mut count = 0;
        while let Some(sample) = self.subscriber.receive().map_err(transport)? {
            let header = sample.user_header();
            let expected = self.next.swap(header.sequence + 1, Ordering::Relaxed);
            if expected != u64::MAX {
                // A publisher that restarted counts from 0 again: nothing lost.
                let gap = header.sequence.saturating_sub(expected);
                self.lost.fetch_add(gap, Ordering::Relaxed);
            }
            frame(header, sample.payload());
            count += 1;
        }
        Ok(count)
    }
}

/// Local programs are a sink of the runtime's arrays: deformed points after each step and a
/// new shape's weights, copied once into shared memory. Messages are not theirs. A frame that
/// cannot be handed over is logged; DDS and the recording go on.
impl crate::msg::Sink for ShmPublisher {
    fn send(&self, _topic: &str, _log_time_ns: i64, _message: &crate::msg::Output) {}

    fn deformed(&self, shape_id: u32, stamp_ns: i64, handles: usize, points: &[f32]) {
        if let Err(e) = self.publish_deformed(shape_id, stamp_ns, handles, points) {
            log::warn!("deformed points not handed over on iceoryx2: {e}");
        }
    }

    fn weights(&self, shape_id: u32, stamp_ns: i64, handles: usize, weights: &[f32]) {
        if let Err(e) = self.publish_weights(shape_id, stamp_ns, handles, weights) {
            log::warn!("weights not handed over on iceoryx2: {e}");
        }
    }
}
