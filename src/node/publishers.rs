//! The node's DDS publishers: a sink of the runtime's outputs.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use ros2_client::{Node, Publisher};

use super::dds::{publisher, NodeError, QosTable};
use crate::msg::{
    MarkerArray, Output, PointCloud2, RosMessage, Sink, SkinningWeights, Status, SubspaceState,
};
use crate::runtime::qos_overrides::Endpoint;
use crate::runtime::{NodeParams, Topics};

/// The node's DDS publishers (absent when switched off in `publish.*`).
pub struct Publishers {
    topics: Topics,
    deformed_points: Option<Publisher<PointCloud2>>,
    weights: Option<Publisher<SkinningWeights>>,
    weights_cloud: Option<Publisher<PointCloud2>>,
    state: Option<Publisher<SubspaceState>>,
    status: Publisher<Status>,
    markers: Option<Publisher<MarkerArray>>,
    /// Publications DDS refused because a reader was too far behind (shared with
    /// /diagnostics).
    pub dropped: Arc<AtomicU64>,
}

impl Publishers {
    /// A publisher for each output `p` switches on, with its QoS from `qos`. An error when a
    /// name is refused or DDS cannot create a publisher.
    pub fn create(
        node: &mut Node,
        t: &Topics,
        qos: &QosTable,
        p: &NodeParams,
    ) -> Result<Self, NodeError> {
        let pubs = &p.publish;
        let out = |topic: &str| qos.of(topic, Endpoint::Publisher);
        Ok(Self {
            topics: t.clone(),
            deformed_points: pubs
                .deformed_points
                .then(|| publisher(node, &t.deformed_points, out(&t.deformed_points)))
                .transpose()?,
            weights: pubs
                .weights
                .then(|| publisher(node, &t.weights, out(&t.weights)))
                .transpose()?,
            weights_cloud: pubs
                .weights_cloud
                .then(|| publisher(node, &t.weights_cloud, out(&t.weights_cloud)))
                .transpose()?,
            state: pubs
                .state
                .then(|| publisher(node, &t.state, out(&t.state)))
                .transpose()?,
            status: publisher(node, &t.status, out(&t.status))?,
            markers: (p.markers.rate_hz > 0.0)
                .then(|| publisher(node, &t.markers, out(&t.markers)))
                .transpose()?,
            dropped: Arc::default(),
        })
    }

    fn publish<M: RosMessage + Clone>(
        &self,
        topic: &str,
        publisher: Option<&Publisher<M>>,
        message: &M,
    ) {
        let Some(p) = publisher else { return };
        if let Err(e) = p.publish(message.clone()) {
            self.refused(topic, &e);
        }
    }

    /// Counts a publication DDS refused (a reader too far behind); says so on the first and
    /// then every 100th.
    fn refused<D>(&self, topic: &str, e: &ros2_client::ros2::WriteError<D>) {
        let n = self.dropped.fetch_add(1, Ordering::Relaxed);
        if n.is_multiple_of(100) {
            // Display, not Debug: the Debug form carries the whole message.
            log::warn!(
                "{topic} not published ({e}: a reader is behind); {} publications dropped so far",
                n + 1
            );
        }
    }
}

impl Sink for Publishers {
    fn send(&self, topic: &str, _log_time_ns: i64, message: &Output) {
        match message {
            Output::Cloud(m) if topic == self.topics.weights_cloud => {
                self.publish(topic, self.weights_cloud.as_ref(), m)
            }
            Output::Cloud(m) => self.publish(topic, self.deformed_points.as_ref(), m),
            Output::Weights(m) => self.publish(topic, self.weights.as_ref(), m),
            Output::State(m) => self.publish(topic, self.state.as_ref(), m),
            Output::Status(m) => self.publish(topic, Some(&self.status), m),
            Output::Markers(m) => self.publish(topic, self.markers.as_ref(), m),
        }
    }
}
