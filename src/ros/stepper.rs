//! The stepping thread: every running object advances once per period and its outputs go out.
//! New bodies and interactions arrive on a channel between ticks.

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use rayon::prelude::*;

use super::builder::ReadyBody;
use super::messages::{Interaction, JointState, Status};
use super::outputs::{Outputs, SharedOutputs};
use crate::pipeline::SoftBody;
use crate::scene::Scene;

pub enum StepperCommand {
    Add(Box<ReadyBody>),
    Interact(Interaction),
    /// A scene's objects and robots join the stage; its objects get ids from `first_id` and
    /// publish in `frame` (the scene's world frame).
    Scene {
        scene: Box<Scene>,
        first_id: u32,
        frame: String,
    },
    /// A joint state for the robots on its topic.
    Joints {
        robots: Vec<String>,
        state: JointState,
    },
}

/// Counters the stepper keeps for the node's final report.
#[derive(Clone, Debug, Default)]
pub struct StepperStats {
    pub ticks: u64,
    /// Ticks skipped because a tick ran past the next one's start.
    pub missed: u64,
}

/// Runs until `commands` closes. `rate_hz` periods of the node's clock (wall or /clock).
pub fn run_stepper(
    commands: Receiver<StepperCommand>,
    rate_hz: f64,
    outputs: SharedOutputs,
) -> StepperStats {
    let period = (1e9 / rate_hz) as i64;
    let mut stage = Stage::on_the_beat();
    let mut stats = StepperStats::default();
    let mut next_tick: Option<i64> = None;
    loop {
        // Wait for the tick, serving commands meanwhile. A simulated clock is polled: /clock
        // moves in jumps, not at the wall clock's pace.
        loop {
            let now = outputs.clock.now_nanos();
            let wait = match (now, next_tick) {
                (Some(now), Some(t)) if now >= t => break,
                (Some(now), Some(t)) if !outputs.clock.is_simulated() => {
                    Duration::from_nanos((t - now) as u64)
                }
                (Some(now), None) => {
                    next_tick = Some(now);
                    break;
                }
                _ => Duration::from_millis(1),
            };
            match commands.recv_timeout(wait) {
                Ok(StepperCommand::Add(ready)) => {
                    // A new body's first step and frame go out at once, unless the tick is
                    // less than half a period away: they would then delay the beat, so the
                    // body waits for the tick like the others.
                    let now = outputs.clock.now_nanos();
                    let beat_is_near =
                        matches!((now, next_tick), (Some(now), Some(t)) if t - now < period / 2);
                    stage.add(*ready, &outputs, !beat_is_near)
                }
                Ok(StepperCommand::Interact(i)) => stage.interact(&i, &outputs),
                Ok(StepperCommand::Scene {
                    scene,
                    first_id,
                    frame,
                }) => stage.set_scene(*scene, first_id, frame, &outputs),
                Ok(StepperCommand::Joints { robots, state }) => {
                    stage.set_joints(&robots, &state, &outputs)
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return stats,
            }
        }
        let started = Instant::now();
        stage.tick(&outputs);
        stats.ticks += 1;
        let tick = next_tick.expect("set before the first tick") + period;
        let now = outputs.clock.now_nanos().unwrap_or(tick);
        next_tick = Some(if now - tick > period || now < tick - 2 * period {
            // Late by more than a period (or the simulated clock went back): skip ahead
            // instead of bursting to catch up.
            stats.missed += ((now - tick) / period).max(0) as u64;
            if !outputs.clock.is_simulated() {
                let ms = started.elapsed().as_secs_f64() * 1e3;
                eprintln!("[physskin] warn: tick took {ms:.1} ms, behind schedule");
            }
            now + period
        } else {
            tick
        });
    }
}

/// The running objects: one per frame. The stepper thread ticks it on the clock; a replay
/// ticks it on the log's time.
#[derive(Default)]
pub struct Stage {
    bodies: Vec<ReadyBody>,
    /// Per body: its last step is computed but not yet published (on-the-beat mode).
    unpublished: Vec<bool>,
    on_the_beat: bool,
    scene: Option<SceneOnStage>,
}

/// A scene's objects and robots, stepped with the other bodies.
struct SceneOnStage {
    scene: Scene,
    first_id: u32,
    frame: String,
    /// Its last step is computed but not yet published.
    unpublished: bool,
    /// Joint-state problems already reported (each once, not at the topic's rate).
    reported: std::collections::HashSet<String>,
}

impl SceneOnStage {
    /// (shape id, name, body) of each deformable object.
    fn bodies(&self) -> impl Iterator<Item = (u32, &str, &SoftBody)> {
        let first = self.first_id;
        self.scene
            .bodies_named()
            .enumerate()
            .map(move |(i, (name, body))| (first + i as u32, name, body))
    }

    /// Shape ids: `first_id` plus the object's place among the scene's deformable objects.
    fn id_of(&self, index: usize) -> u32 {
        self.first_id + index as u32
    }
}

impl Stage {
    /// A stage that publishes on the beat: each tick first publishes the steps computed in the
    /// previous one, then computes the next. Publication then happens at the tick, whatever a
    /// step costs (one period of added delay); the node runs this way.
    pub fn on_the_beat() -> Self {
        Self {
            on_the_beat: true,
            ..Self::default()
        }
    }

    /// Steps every object once and publishes its outputs. Objects are independent: they step
    /// in parallel, and publish one after another in a fixed order.
    pub fn tick(&mut self, outputs: &Outputs) {
        if self.on_the_beat {
            self.publish_pending(outputs);
        }
        let scene = &mut self.scene;
        rayon::join(
            || {
                self.bodies.par_iter_mut().for_each(|b| {
                    b.body.step();
                })
            },
            || {
                if let Some(s) = scene {
                    s.scene.step();
                    s.unpublished = true;
                }
            },
        );
        self.unpublished.iter_mut().for_each(|u| *u = true);
        if !self.on_the_beat {
            self.publish_pending(outputs);
        }
    }

    fn publish_pending(&mut self, outputs: &Outputs) {
        for (b, unpublished) in self.bodies.iter().zip(&mut self.unpublished) {
            if std::mem::take(unpublished) {
                publish_last_step(b.id, &b.frame, &b.body, outputs);
            }
        }
        if let Some(s) = &mut self.scene {
            if std::mem::take(&mut s.unpublished) {
                // A sleeping object is published once, as it falls asleep.
                for (id, _, body) in s.bodies() {
                    if !body.is_sleeping() || body.fell_asleep() {
                        publish_last_step(id, &s.frame, body, outputs);
                    }
                }
            }
        }
    }

    /// A scene joins (or replaces the scene on) the stage: its objects are announced with
    /// their weights and what was decided for each.
    pub fn set_scene(&mut self, scene: Scene, first_id: u32, frame: String, outputs: &Outputs) {
        let s = SceneOnStage {
            scene,
            first_id,
            frame,
            unpublished: false,
            reported: Default::default(),
        };
        for (id, name, body) in s.bodies() {
            let rest = rest_points(body);
            outputs.publish_weights(id, &s.frame, &rest, body.weights(), body.handles());
            outputs.report(
                Status::INFO,
                id,
                "shape_ready",
                format!("scene object `{name}`: {}", body.decision()),
            );
        }
        self.scene = Some(s);
    }

    /// Robots' joints move (a JointState from their topic).
    pub fn set_joints(&mut self, robots: &[String], state: &JointState, outputs: &Outputs) {
        let Some(s) = &mut self.scene else {
            return;
        };
        if let Err(problem) = s
            .scene
            .set_joint_positions(robots, &state.name, &state.position)
        {
            if s.reported.insert(problem.clone()) {
                outputs.report(Status::WARN, 0, "joint_state_ignored", problem);
            }
        }
    }

    pub fn bodies(&self) -> &[ReadyBody] {
        &self.bodies
    }

    /// The scene's deformable objects: (shape id, name, body).
    pub fn scene_bodies(&self) -> impl Iterator<Item = (u32, &str, &SoftBody)> {
        self.scene.iter().flat_map(|s| s.bodies())
    }

    /// A new body replaces the one in its frame. With `step_now` it makes its first step at
    /// once, so its first deformed cloud does not wait for the next tick.
    pub fn add(&mut self, mut ready: ReadyBody, outputs: &Outputs, step_now: bool) {
        if step_now {
            step(&mut ready, outputs);
        }
        if let Some(i) = self.bodies.iter().position(|b| b.frame == ready.frame) {
            self.bodies[i] = ready;
            self.unpublished[i] = false;
        } else {
            self.bodies.push(ready);
            self.unpublished.push(false);
        }
    }

    pub fn interact(&mut self, i: &Interaction, outputs: &Outputs) {
        let scene_bodies = self.scene.iter_mut().flat_map(|s| {
            let count = s.scene.bodies_named().count();
            let ids: Vec<u32> = (0..count).map(|n| s.id_of(n)).collect();
            let frame = &s.frame;
            s.scene
                .bodies_named_mut()
                .zip(ids)
                .map(move |((_, body), id)| (id, frame.as_str(), body))
        });
        let bodies = self
            .bodies
            .iter_mut()
            .map(|b| (b.id, b.frame.as_str(), &mut b.body))
            .chain(scene_bodies);
        interact(bodies, i, outputs)
    }
}

fn step(b: &mut ReadyBody, outputs: &Outputs) {
    b.body.step();
    publish_last_step(b.id, &b.frame, &b.body, outputs);
}

/// A body's points before any step: its weights are published against them.
fn rest_points(body: &SoftBody) -> Vec<f32> {
    body.deformed().to_vec()
}

/// Publishes a body's last step (and a warning if it did not converge).
fn publish_last_step(id: u32, frame: &str, body: &SoftBody, outputs: &Outputs) {
    let Some(report) = body.last_step() else {
        return;
    };
    if !report.converged {
        let message = format!(
            "step did not converge ({} iterations, decrement {:e})",
            report.iterations, report.decrement
        );
        outputs.report(Status::WARN, id, "step_unconverged", message);
    }
    outputs.publish_step(id, frame, body);
}

fn interact<'a>(
    bodies: impl Iterator<Item = (u32, &'a str, &'a mut SoftBody)>,
    i: &Interaction,
    outputs: &Outputs,
) {
    let point = Vector3::new(i.point.x, i.point.y, i.point.z);
    let force = Vector3::new(i.force.x, i.force.y, i.force.z);
    let frame = &i.header.frame_id;
    let finite = point.iter().chain(force.iter()).all(|c| c.is_finite())
        && i.duration.is_finite()
        && i.radius.is_finite();
    let ignored =
        |problem: String| outputs.report(Status::WARN, i.shape_id, "interaction_ignored", problem);
    if !finite {
        return ignored("non-finite point, force, duration or radius".into());
    }
    if i.kind > Interaction::RELEASE {
        return ignored(format!(
            "unknown kind {} (FORCE 0, PIN 1, RELEASE 2)",
            i.kind
        ));
    }
    let mut matched = 0;
    for (_, _, body) in bodies.filter(|(id, name, _)| {
        (i.shape_id == 0 || *id == i.shape_id) && (frame.is_empty() || name == frame)
    }) {
        matched += 1;
        match i.kind {
            Interaction::FORCE => body.push(point, force, i.duration.max(0.0)),
            Interaction::PIN => {
                if body.hold(&point, i.radius) == 0 {
                    ignored(format!(
                        "no material within {} m of the pin point",
                        i.radius
                    ));
                }
            }
            _ => {
                body.release(&point, i.radius);
            }
        }
    }
    if matched == 0 {
        ignored(format!(
            "no shape matches shape_id {} in frame `{frame}`",
            i.shape_id
        ));
    }
}
