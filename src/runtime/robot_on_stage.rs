//! The robot the ROS graph describes (`robot_description`), on the stage: its joints follow
//! their JointState topic, /tf places the links it knows, and its links' collision shapes
//! push and hold every object simulated in the fixed frame.

use std::collections::HashSet;

use super::outputs::Outputs;
use super::tf::TfBuffer;
use crate::msg::{JointState, Status};
use crate::physics::Obstacle;
use crate::scene::Robot;

/// The described robot and what was already said about it.
pub(crate) struct RobotOnStage {
    robot: Robot,
    /// The frame its links collide in (the node's fixed frame).
    frame: String,
    /// Place links by /tf where it knows them.
    links_from_tf: bool,
    /// Joint-state problems already reported (each once, not at the topic's rate).
    reported: HashSet<String>,
}

impl RobotOnStage {
    /// `robot` in `frame`; None (and a warning saying why) without a fixed frame, where
    /// objects live each in their input's frame and a robot has nowhere to stand.
    pub fn new(
        robot: Robot,
        notes: &[String],
        frame: &str,
        links_from_tf: bool,
        outputs: &Outputs,
    ) -> Option<Self> {
        let name = robot.name().to_string();
        if frame.is_empty() {
            let why = format!(
                "robot `{name}` from robot_description is not used: set fixed_frame, the \
                 frame its links and the objects they touch share"
            );
            outputs.report(Status::WARN, 0, "robot_ignored", why);
            return None;
        }
        for note in notes {
            outputs.report(
                Status::WARN,
                0,
                "robot_mesh_missing",
                format!("robot `{name}`: {note}"),
            );
        }
        let (links, shapes) = robot.size();
        let placed = if links_from_tf {
            ", placed by /tf where it knows a link"
        } else {
            ""
        };
        let ready = format!(
            "robot `{name}` from robot_description: {links} links, {shapes} collision shapes, in \
             `{frame}`{placed}"
        );
        outputs.report(Status::INFO, 0, "robot_ready", ready);
        Some(Self {
            robot,
            frame: frame.to_string(),
            links_from_tf,
            reported: HashSet::new(),
        })
    }

    /// Joints move. Names the robot lacks are reported once (a JointState may carry other
    /// robots' joints); its own are applied either way.
    pub fn set_joints(&mut self, state: &JointState, outputs: &Outputs) {
        if let Err(problem) = self.robot.set_joint_positions(&state.name, &state.position) {
            if self.reported.insert(problem.clone()) {
                outputs.report(Status::WARN, 0, "joint_state_ignored", problem);
            }
        }
    }

    /// The links' collision shapes where the links are now: from /tf (latest) for links it
    /// places in the fixed frame, else from the joints.
    pub fn colliders(&self, tf: Option<&TfBuffer>) -> Vec<Obstacle> {
        let from_tf = |link: &str| {
            let tf = tf.filter(|_| self.links_from_tf)?;
            tf.lookup(&self.frame, link, 0).ok()
        };
        self.robot.colliders(&self.robot.link_poses_with(from_tf))
    }
}
