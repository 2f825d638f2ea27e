//! A recording's inputs sent to a running node: each input topic of the recording gets a DDS
//! publisher with the QoS the node subscribes with, and each message goes out on its recorded
//! topic at the recorded pace (`physskin replay FILE --publish`).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use ros2_client::{Node, NodeName, NodeOptions, Publisher};

use super::dds::{context, publisher, qos_of, NodeError, QosTable};
use crate::bag::read_recording;
use crate::msg::{
    from_cdr, Interaction, JointState, Mesh, MeshStamped, PointCloud2, RosMessage, StringMessage,
    TFMessage,
};
use crate::runtime::params::RobotParams;
use crate::runtime::qos_overrides::Endpoint;
use crate::runtime::{topic_table, InputKind, InputTopics, NameResolver, Topics};

/// How to send.
#[derive(Clone, Debug)]
pub struct SendOptions {
    /// The receiving node's topics, resolved.
    pub topics: Topics,
    /// ROS_DOMAIN_ID.
    pub domain_id: u16,
    /// A multiple of the recorded pace (1 = as recorded).
    pub pace: f64,
    /// How long to wait for a subscriber on each topic before sending, s.
    pub wait_s: f64,
}

/// What was sent.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SendSummary {
    /// Messages sent, per topic.
    pub sent: BTreeMap<String, usize>,
    /// Topics no subscriber matched within the wait (their messages were sent anyway).
    pub unmatched: Vec<String>,
    /// Wall-clock time of the sending, s.
    pub wall_seconds: f64,
}

/// One typed publisher per input topic.
enum AnyPublisher {
    Cloud(Publisher<PointCloud2>),
    Mesh(Publisher<Mesh>),
    MeshStamped(Publisher<MeshStamped>),
    Interaction(Publisher<Interaction>),
    Transforms(Publisher<TFMessage>),
    Joints(Publisher<JointState>),
    Description(Publisher<StringMessage>),
}

impl AnyPublisher {
    fn create(
        node: &mut Node,
        topic: &str,
        kind: &InputKind,
        table: &QosTable,
    ) -> Result<Self, NodeError> {
        let q = qos_of(table.profile(topic, Endpoint::Publisher));
        Ok(match kind {
            InputKind::Cloud => Self::Cloud(publisher(node, topic, q)?),
            InputKind::Mesh => Self::Mesh(publisher(node, topic, q)?),
            InputKind::MeshStamped => Self::MeshStamped(publisher(node, topic, q)?),
            InputKind::Interaction => Self::Interaction(publisher(node, topic, q)?),
            InputKind::Transforms { .. } => Self::Transforms(publisher(node, topic, q)?),
            InputKind::Joints(_) => Self::Joints(publisher(node, topic, q)?),
            InputKind::RobotDescription => Self::Description(publisher(node, topic, q)?),
        })
    }

    fn matched(&self, node: &Node) -> usize {
        match self {
            Self::Cloud(p) => p.get_subscription_count(node),
            Self::Mesh(p) => p.get_subscription_count(node),
            Self::MeshStamped(p) => p.get_subscription_count(node),
            Self::Interaction(p) => p.get_subscription_count(node),
            Self::Transforms(p) => p.get_subscription_count(node),
            Self::Joints(p) => p.get_subscription_count(node),
            Self::Description(p) => p.get_subscription_count(node),
        }
    }

    /// Decodes the recorded CDR bytes and publishes them.
    fn send(&self, bytes: &[u8]) -> Result<(), String> {
        fn out<M: RosMessage>(p: &Publisher<M>, bytes: &[u8]) -> Result<(), String> {
            let message: M = from_cdr(bytes)?;
            p.publish(message).map_err(|e| e.to_string())
        }
        match self {
            Self::Cloud(p) => out(p, bytes),
            Self::Mesh(p) => out(p, bytes),
            Self::MeshStamped(p) => out(p, bytes),
            Self::Interaction(p) => out(p, bytes),
            Self::Transforms(p) => out(p, bytes),
            Self::Joints(p) => out(p, bytes),
            Self::Description(p) => out(p, bytes),
        }
    }
}

/// Sends the inputs of the recording in `bytes` (named `source` in errors) to a running node.
pub fn send_recording(
    bytes: &[u8],
    source: &str,
    options: &SendOptions,
) -> crate::Result<SendSummary> {
    let recording = read_recording(bytes, source)?;
    let robot = RobotParams::default()
        .resolved(&NameResolver::default())
        .map_err(|e| NodeError::Name(e.to_string()))?;
    let inputs = InputTopics::new(&options.topics, &robot, None);
    let dds = |e: String| NodeError::Dds(e);
    let context = context(options.domain_id, false)?;
    let name = NodeName::new("/", "physskin_send").map_err(|e| dds(format!("{e:?}")))?;
    let mut node = context
        .new_node(name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| dds(format!("{e:?}")))?;
    // The profiles the node's table offers the topics with (what it subscribes with too).
    let mut profiles = topic_table(&options.topics);
    profiles.extend(inputs.robot_topic_table());
    let table = QosTable {
        profiles,
        overrides: Default::default(),
    };
    let mut publishers = BTreeMap::new();
    for m in &recording.messages {
        if let (Some(kind), false) = (inputs.kind(&m.topic), publishers.contains_key(&m.topic)) {
            let p = AnyPublisher::create(&mut node, &m.topic, kind, &table)?;
            publishers.insert(m.topic.clone(), p);
        }
    }
    let spinner = node.spinner().map_err(|e| dds(format!("{e:?}")))?;
    std::thread::spawn(move || smol::block_on(spinner.spin()));
    // Discovery takes a moment; a volatile subscriber misses what is sent before it matches.
    let deadline = Instant::now() + Duration::from_secs_f64(options.wait_s.max(0.0));
    while publishers.values().any(|p| p.matched(&node) == 0) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    let mut summary = SendSummary {
        unmatched: (publishers.iter())
            .filter(|(_, p)| p.matched(&node) == 0)
            .map(|(topic, _)| topic.clone())
            .collect(),
        ..Default::default()
    };
    let wall = Instant::now();
    let first = recording.messages.first().map_or(0, |m| m.log_time);
    for m in &recording.messages {
        let Some(p) = publishers.get(&m.topic) else {
            continue;
        };
        let due = Duration::from_secs_f64((m.log_time - first) as f64 / 1e9 / options.pace);
        if let Some(wait) = due.checked_sub(wall.elapsed()) {
            std::thread::sleep(wait);
        }
        p.send(&m.data)
            .map_err(|e| dds(format!("{source} at {} ns, {}: {e}", m.log_time, m.topic)))?;
        *summary.sent.entry(m.topic.clone()).or_default() += 1;
    }
    // Reliable samples still in flight reach the node before the participant goes.
    std::thread::sleep(Duration::from_millis(500));
    summary.wall_seconds = wall.elapsed().as_secs_f64();
    Ok(summary)
}
