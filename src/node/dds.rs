//! The node's DDS plumbing: why it could not start, its DDS context, the QoS profiles of its
//! endpoints (with the `qos_overrides.*` parameters) and how publishers and subscriptions are
//! made. Shared by the node, its inputs and its services.

use std::net::Ipv4Addr;

use ros2_client::ros2::policy::{Durability, History, Reliability, ResourceLimits};
use ros2_client::ros2::{QosPolicies, QosPolicyBuilder};
use ros2_client::rustdds::DomainParticipantBuilder;
use ros2_client::{Context, MessageTypeName, Name, Node, Publisher, Subscription};

use crate::msg::RosMessage;
use crate::msg::{QosProfile, TopicInfo};
use crate::runtime::qos_overrides::{Endpoint, QosOverrides};

// Lives in `crate::error` (the crate error wraps it, and nothing there may depend on the ROS
// layer); named here too, where it always was.
pub use crate::error::NodeError;

/// A DDS context, restricted to loopback when asked.
pub fn context(domain_id: u16, loopback_only: bool) -> Result<Context, NodeError> {
    let dds = |e: ros2_client::ros2::CreateError| NodeError::Dds(format!("{e:?}"));
    let mut builder = DomainParticipantBuilder::new(domain_id);
    if loopback_only {
        builder = builder.with_only_networks([Ipv4Addr::LOCALHOST]);
    }
    Context::from_domain_participant(builder.build().map_err(dds)?).map_err(dds)
}

/// Sensor inputs: keep-last 5, best effort, volatile (ROS's sensor-data profile). A best-effort
/// reader also matches reliable writers.
pub fn sensor_qos() -> QosPolicies {
    QosPolicyBuilder::new()
        .history(History::KeepLast { depth: 5 })
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .build()
}

/// The DDS QoS of a recorded profile.
pub fn qos_of(profile: QosProfile) -> QosPolicies {
    if profile.reliable {
        reliable_qos(profile.depth as i32, profile.transient_local)
    } else {
        QosPolicyBuilder::new()
            .history(History::KeepLast {
                depth: profile.depth as i32,
            })
            .reliability(Reliability::BestEffort)
            .durability(Durability::Volatile)
            .build()
    }
}

/// Reliable keep-last `depth`, transient local when late joiners should still get the last ones.
/// The resource limit holds the writer to `depth` samples: RustDDS 0.14 prunes a reliable
/// writer's history only down to what every matched reader acknowledged, so with no reader it
/// kept up to 8192 samples (the soak measured +50 MB/min from the weights topics alone).
pub fn reliable_qos(depth: i32, transient_local: bool) -> QosPolicies {
    QosPolicyBuilder::new()
        .history(History::KeepLast { depth })
        .resource_limits(ResourceLimits {
            max_samples: depth,
            max_instances: 1,
            max_samples_per_instance: depth,
        })
        .reliability(Reliability::Reliable {
            max_blocking_time: ros2_client::ros2::Duration::from_millis(100),
        })
        .durability(if transient_local {
            Durability::TransientLocal
        } else {
            Durability::Volatile
        })
        .build()
}

fn topic_of<M: RosMessage>(
    node: &Node,
    name: &str,
    qos: &QosPolicies,
) -> Result<ros2_client::rustdds::Topic, NodeError> {
    let parsed =
        Name::parse(name).map_err(|e| NodeError::Name(format!("topic `{name}`: {e:?}")))?;
    node.create_topic(&parsed, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
        .map_err(|e| NodeError::Dds(format!("topic `{name}`: {e:?}")))
}

/// A publisher of `M` on the topic `name` with `qos`. An error when the name is refused or
/// DDS cannot create it.
pub fn publisher<M: RosMessage>(
    node: &mut Node,
    name: &str,
    qos: QosPolicies,
) -> Result<Publisher<M>, NodeError> {
    let topic = topic_of::<M>(node, name, &qos)?;
    node.create_publisher(&topic, Some(qos))
        .map_err(|e| NodeError::Dds(format!("publisher `{name}`: {e:?}")))
}

/// A subscription to `M` on the topic `name` with `qos`. An error when the name is refused or
/// DDS cannot create it.
pub fn subscription<M: RosMessage>(
    node: &mut Node,
    name: &str,
    qos: QosPolicies,
) -> Result<Subscription<M>, NodeError> {
    let topic = topic_of::<M>(node, name, &qos)?;
    node.create_subscription(&topic, Some(qos))
        .map_err(|e| NodeError::Dds(format!("subscription `{name}`: {e:?}")))
}

/// QoS of each endpoint: the topic table's profile, then the `qos_overrides.*` parameters.
pub(super) struct QosTable {
    pub(super) profiles: Vec<TopicInfo>,
    pub(super) overrides: QosOverrides,
}

impl QosTable {
    /// The topic's profile in the table (sensor data, depth 5, for a topic it lacks), after the
    /// overrides.
    pub(super) fn profile(&self, topic: &str, endpoint: Endpoint) -> QosProfile {
        let base = self
            .profiles
            .iter()
            .find(|info| info.name == topic)
            .map_or(QosProfile::sensor(5), |info| info.qos);
        self.overrides.apply(topic, endpoint, base)
    }

    pub(super) fn of(&self, topic: &str, endpoint: Endpoint) -> QosPolicies {
        let profile = self.profile(topic, endpoint);
        match endpoint {
            Endpoint::Publisher if profile.reliable => {
                never_blocking(qos_of(profile), profile.depth)
            }
            _ => qos_of(profile),
        }
    }
}

/// The node's writers never wait for a reader: the stepping thread publishes, and a reader
/// that falls behind loses samples instead of stalling every object (each refused publication
/// is counted in /diagnostics). The writer holds up to 4 x depth unacknowledged samples, so
/// the acknowledgements' round trip on a loaded machine does not cost samples, and memory
/// stays bounded.
fn never_blocking(qos: QosPolicies, depth: u32) -> QosPolicies {
    let held = 4 * depth.max(1) as i32;
    qos.modify_by(
        &QosPolicyBuilder::new()
            .reliability(Reliability::Reliable {
                max_blocking_time: ros2_client::ros2::Duration::ZERO,
            })
            .resource_limits(ResourceLimits {
                max_samples: held,
                max_instances: 1,
                max_samples_per_instance: held,
            })
            .build(),
    )
}
