//! Where outputs go. The runtime builds each output message once and hands it to every sink
//! of its shell: DDS publishers in the node, an MCAP recorder in a node that records and in a
//! replay, iceoryx2 for local programs, a collector in tests.

use std::sync::Arc;
#[cfg(test)]
use std::sync::Mutex;

use super::messages::{MarkerArray, PointCloud2, SkinningWeights, Status, SubspaceState};

/// One output message of the runtime.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    /// A deformed cloud, or the weights as a cloud.
    Cloud(PointCloud2),
    /// A new shape's weights.
    Weights(SkinningWeights),
    /// A body's reduced state after a step.
    State(SubspaceState),
    /// What was done with an input, or what happened to an object.
    Status(Status),
    /// Surface markers for viewers.
    Markers(MarkerArray),
}

/// Takes the runtime's outputs.
pub trait Sink: Send + Sync {
    /// One message on `topic`, emitted at `log_time_ns` (the runtime's clock). A sink that
    /// must own the message clones it.
    fn send(&self, topic: &str, log_time_ns: i64, message: &Output);

    /// A body's deformed points after a step, borrowed from the body: for sinks that hand
    /// arrays over without a message (iceoryx2). Nothing by default.
    fn deformed(&self, _shape_id: u32, _stamp_ns: i64, _handles: usize, _points: &[f32]) {}

    /// A new shape's weights (points x handles, row-major), borrowed from its body. Nothing by
    /// default.
    fn weights(&self, _shape_id: u32, _stamp_ns: i64, _handles: usize, _weights: &[f32]) {}
}

impl<S: Sink + ?Sized> Sink for Arc<S> {
    fn send(&self, topic: &str, log_time_ns: i64, message: &Output) {
        (**self).send(topic, log_time_ns, message)
    }
    fn deformed(&self, shape_id: u32, stamp_ns: i64, handles: usize, points: &[f32]) {
        (**self).deformed(shape_id, stamp_ns, handles, points)
    }
    fn weights(&self, shape_id: u32, stamp_ns: i64, handles: usize, weights: &[f32]) {
        (**self).weights(shape_id, stamp_ns, handles, weights)
    }
}

/// A sink that keeps every message, for the runtime's tests.
#[cfg(test)]
#[derive(Default)]
pub struct Collector(Mutex<Vec<(String, i64, Output)>>);

#[cfg(test)]
impl Collector {
    /// The messages so far, (topic, log time, message), in the order they came; the collector
    /// is emptied.
    pub fn take(&self) -> Vec<(String, i64, Output)> {
        self.0
            .lock()
            .map(|mut v| std::mem::take(&mut *v))
            .unwrap_or_default()
    }
}

#[cfg(test)]
impl Sink for Collector {
    fn send(&self, topic: &str, log_time_ns: i64, message: &Output) {
        if let Ok(mut v) = self.0.lock() {
            v.push((topic.into(), log_time_ns, message.clone()));
        }
    }
}
