//! One dispatch from topic to input, for both shells: which topics the runtime listens to,
//! what each carries, and each message turned into what the runtime takes. The node subscribes
//! to [`InputTopics::all`] and hands each typed message to the constructors below; a replay
//! decodes each recorded message of those topics with [`InputTopics::decode`].

use std::collections::BTreeMap;

use super::builder::BuildRequest;
use super::cloud_objects::instance_field;
use super::outputs::{TF, TF_STATIC};
use super::params::{NodeParams, RobotParams, Topics};
use crate::msg::{
    from_cdr, Interaction, JointState, Mesh, MeshStamped, PointCloud2, QosProfile, RosMessage,
    StringMessage, TFMessage, TopicInfo,
};
use crate::scene::{MeshLookup, Robot, SceneFile};

/// What a topic carries.
#[derive(Clone, Debug, PartialEq)]
pub enum InputKind {
    /// sensor_msgs/PointCloud2: an object per instance id, or the frame's one object.
    Cloud,
    /// shape_msgs/Mesh, in the `mesh_frame` parameter's frame.
    Mesh,
    /// physskin/MeshStamped.
    MeshStamped,
    /// physskin/Interaction: a push, a hold, a release.
    Interaction,
    /// tf2_msgs/TFMessage, static or not.
    Transforms {
        /// From /tf_static.
        is_static: bool,
    },
    /// sensor_msgs/JointState for the robots that read it.
    Joints(JointReaders),
    /// std_msgs/String: the URDF of the robot from the graph.
    RobotDescription,
}

/// The robots a joint-state topic moves.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JointReaders {
    /// The scene robots on it, by name.
    pub scene_robots: Vec<String>,
    /// The robot from `robot_description` reads it too.
    pub described: bool,
}

impl InputKind {
    /// The ROS type of the topic's messages, "pkg/msg/Name".
    pub fn type_name(&self) -> String {
        match self {
            Self::Cloud => PointCloud2::type_name(),
            Self::Mesh => Mesh::type_name(),
            Self::MeshStamped => MeshStamped::type_name(),
            Self::Interaction => Interaction::type_name(),
            Self::Transforms { .. } => TFMessage::type_name(),
            Self::Joints(_) => JointState::type_name(),
            Self::RobotDescription => StringMessage::type_name(),
        }
    }
}

/// An input, decoded and ready for the runtime.
pub enum Input {
    /// A cloud's objects (one per instance id) or a mesh.
    Geometry(Vec<BuildRequest>),
    /// Transforms for the tf buffer.
    Transforms(TFMessage, bool),
    /// A push, hold or release.
    Interaction(Interaction),
    /// A joint state for the robots that read its topic.
    Joints(JointReaders, JointState),
    /// A robot from `robot_description`, with notes on links that stand in with their visual
    /// box.
    Robot(Box<Robot>, Vec<String>),
}

impl Input {
    /// A cloud's objects, with the cloud's size limit and instance field from `p`: those of
    /// this instance's shard (`instances.shard`).
    pub fn cloud(cloud: &PointCloud2, p: &NodeParams) -> Result<Self, String> {
        let shard = p.shard().unwrap_or_default();
        // Another instance's frame is not even decoded.
        let labelled = instance_field(cloud, &p.instance_field).is_some();
        if !labelled && !shard.owns_frame(&cloud.header.frame_id) {
            return Ok(Self::Geometry(Vec::new()));
        }
        let mut requests = BuildRequest::from_cloud(cloud, p.max_points, &p.instance_field)?;
        requests.retain(|r| shard.owns(&r.key()));
        Ok(Self::Geometry(requests))
    }

    /// A mesh in the `mesh_frame` parameter's frame (none when another shard's).
    pub fn mesh(mesh: &Mesh, p: &NodeParams) -> Result<Self, String> {
        Self::shard_of_mesh(p, &p.mesh_frame, || {
            BuildRequest::from_mesh(mesh, &p.mesh_frame, 0, p.max_points)
        })
    }

    /// A mesh in its header's frame, at its stamp (none when another shard's).
    pub fn mesh_stamped(m: &MeshStamped, p: &NodeParams) -> Result<Self, String> {
        let stamp = m.header.stamp.nanos();
        Self::shard_of_mesh(p, &m.header.frame_id, || {
            BuildRequest::from_mesh(&m.mesh, &m.header.frame_id, stamp, p.max_points)
        })
    }

    /// The robot a `robot_description` URDF describes (its meshes from the ROS package
    /// paths); an error naming what is wrong with the URDF.
    pub fn robot(description: &StringMessage) -> Result<Self, String> {
        let (robot, notes) =
            Robot::from_description(&description.data, &MeshLookup::from_environment())
                .map_err(|e| format!("robot_description: {e}"))?;
        Ok(Self::Robot(Box::new(robot), notes))
    }

    fn shard_of_mesh(
        p: &NodeParams,
        frame: &str,
        request: impl FnOnce() -> Result<BuildRequest, String>,
    ) -> Result<Self, String> {
        if !p.shard().unwrap_or_default().owns_frame(frame) {
            return Ok(Self::Geometry(Vec::new()));
        }
        request().map(|r| Self::Geometry(vec![r]))
    }
}

/// The topics the runtime listens to and what each carries.
#[derive(Clone, Debug)]
pub struct InputTopics {
    by_name: BTreeMap<String, InputKind>,
}

impl InputTopics {
    /// The input topics of `topics` and `robot` (resolved), /tf, /tf_static, and the
    /// joint-state topic of each robot of `scene` (a JointState may carry the joints of
    /// several robots).
    pub fn new(topics: &Topics, robot: &RobotParams, scene: Option<&SceneFile>) -> Self {
        let mut by_name = BTreeMap::new();
        for r in scene.iter().flat_map(|f| &f.robots) {
            if let Some(readers) = joint_readers(&mut by_name, &r.joint_states) {
                readers.scene_robots.push(r.name.clone());
            }
        }
        if !robot.description_topic.is_empty() {
            if let Some(readers) = joint_readers(&mut by_name, &robot.joint_states_topic) {
                readers.described = true;
            }
            by_name.insert(robot.description_topic.clone(), InputKind::RobotDescription);
        }
        by_name.insert(TF.into(), InputKind::Transforms { is_static: false });
        by_name.insert(TF_STATIC.into(), InputKind::Transforms { is_static: true });
        by_name.insert(topics.points.clone(), InputKind::Cloud);
        by_name.insert(topics.mesh.clone(), InputKind::Mesh);
        by_name.insert(topics.mesh_stamped.clone(), InputKind::MeshStamped);
        by_name.insert(topics.interaction.clone(), InputKind::Interaction);
        Self { by_name }
    }

    /// The robot's and the joint states' topics as they are offered and recorded:
    /// `robot_description` reliable and transient local (robot_state_publisher publishes it
    /// once), joint states as sensor data.
    pub fn robot_topic_table(&self) -> Vec<TopicInfo> {
        self.all()
            .filter_map(|(topic, kind)| match kind {
                InputKind::RobotDescription => Some(TopicInfo::of::<StringMessage>(
                    topic,
                    QosProfile::reliable(1, true),
                )),
                InputKind::Joints(_) => {
                    Some(TopicInfo::of::<JointState>(topic, QosProfile::sensor(5)))
                }
                _ => None,
            })
            .collect()
    }

    /// What `topic` carries; None: not an input.
    pub fn kind(&self, topic: &str) -> Option<&InputKind> {
        self.by_name.get(topic)
    }

    /// Every input topic with what it carries.
    pub fn all(&self) -> impl Iterator<Item = (&str, &InputKind)> {
        self.by_name
            .iter()
            .map(|(name, kind)| (name.as_str(), kind))
    }

    /// A recorded message of an input `topic`: its type and encoding checked, decoded, and
    /// made an input; `at` names it in errors.
    pub fn decode(
        &self,
        topic: &str,
        type_name: &str,
        encoding: &str,
        bytes: &[u8],
        p: &NodeParams,
        at: &str,
    ) -> Result<Input, String> {
        let kind = self
            .kind(topic)
            .ok_or_else(|| format!("{at}: not an input topic"))?;
        let expected = kind.type_name();
        if encoding != "cdr" || type_name != expected {
            return Err(format!(
                "{at}: carries {type_name:?} in encoding {encoding:?}, expected {expected} in cdr"
            ));
        }
        let bad = |e: String| format!("{at}: {e}");
        match kind {
            InputKind::Cloud => Input::cloud(&from_cdr(bytes).map_err(bad)?, p),
            InputKind::Mesh => Input::mesh(&from_cdr(bytes).map_err(bad)?, p),
            InputKind::MeshStamped => Input::mesh_stamped(&from_cdr(bytes).map_err(bad)?, p),
            InputKind::Interaction => from_cdr(bytes).map(Input::Interaction).map_err(bad),
            InputKind::Transforms { is_static } => {
                Ok(Input::Transforms(from_cdr(bytes).map_err(bad)?, *is_static))
            }
            InputKind::Joints(readers) => Ok(Input::Joints(
                readers.clone(),
                from_cdr(bytes).map_err(bad)?,
            )),
            InputKind::RobotDescription => Input::robot(&from_cdr(bytes).map_err(bad)?),
        }
    }
}

/// The robots that read joint-state `topic`, a new entry when none did yet.
fn joint_readers<'a>(
    by_name: &'a mut BTreeMap<String, InputKind>,
    topic: &str,
) -> Option<&'a mut JointReaders> {
    match by_name
        .entry(topic.to_string())
        .or_insert_with(|| InputKind::Joints(JointReaders::default()))
    {
        InputKind::Joints(readers) => Some(readers),
        _ => None,
    }
}
