//! The stepping thread: every running object advances once per period and its outputs go out.
//! New bodies, interactions and control requests arrive on a channel between ticks.

use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::builder::{ReadyBody, RefinedField};
use super::diagnostics::Health;
use super::outputs::SharedOutputs;
use super::stage::Stage;
use crate::msg::{Interaction, JointState};
use crate::scene::Scene;

/// What the stepping thread is asked between ticks.
pub enum StepperCommand {
    /// A built body joins the stage (replacing the object of the same key).
    Add(Box<ReadyBody>),
    /// A running object switches to its refined field.
    Switch(Box<RefinedField>),
    /// A later frame of a running object corrects it.
    Observe(Box<super::tracking::Observation>),
    /// A force, pin, release or removal for one object.
    Interact(Interaction),
    /// A scene's objects and robots join the stage; its objects get ids from `first_id` and
    /// publish in `frame` (the scene's world frame).
    Scene {
        /// The scene.
        scene: Box<Scene>,
        /// The id of its first object; the others follow.
        first_id: u32,
        /// The frame its objects publish in.
        frame: String,
    },
    /// A joint state for the robots on its topic.
    Joints {
        /// The robots on the state's topic.
        robots: super::inputs::JointReaders,
        /// The joint state.
        state: JointState,
    },
    /// A robot from `robot_description` replaces the one before, with notes on the links that
    /// stand in with their visual box.
    Robot(Box<crate::scene::Robot>, Vec<String>),
    /// Geometry arrived for this object (it is still wanted).
    Seen(super::builder::ObjectKey),
    /// Every object back to rest; the answer says what was done.
    Reset(Sender<String>),
    /// Every object removed; the answer says what was done.
    Clear(Sender<String>),
}

/// Counters the stepper keeps for the node's final report.
#[derive(Clone, Debug, Default)]
pub struct StepperStats {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks skipped because a tick ran past the next one's start.
    pub missed: u64,
}

/// Runs until `commands` closes. `rate_hz` periods of the node's clock (wall or /clock).
pub fn run_stepper(
    commands: Receiver<StepperCommand>,
    rate_hz: f64,
    mut stage: Stage,
    outputs: SharedOutputs,
    health: Arc<Health>,
) -> StepperStats {
    let period = (1e9 / rate_hz) as i64;
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
                Ok(command) => {
                    // A new body's first step and frame go out at once, unless the tick is
                    // less than half a period away: they would then delay the beat, so the
                    // body waits for the tick like the others.
                    let now = outputs.clock.now_nanos();
                    let beat_is_near =
                        matches!((now, next_tick), (Some(now), Some(t)) if t - now < period / 2);
                    serve(&mut stage, command, &outputs, !beat_is_near)
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return stats,
            }
        }
        let started = Instant::now();
        stage.tick(&outputs);
        stats.ticks += 1;
        let (objects, awake) = stage.counts();
        health.tick(objects, awake, started.elapsed().as_secs_f64() * 1e3);
        health.track(stage.take_tracking());
        let tick = next_tick.expect("set before the first tick") + period;
        let now = outputs.clock.now_nanos().unwrap_or(tick);
        next_tick = Some(if now - tick > period || now < tick - 2 * period {
            // Late by more than a period (or the simulated clock went back): skip ahead
            // instead of bursting to catch up.
            let missed = ((now - tick) / period).max(0) as u64;
            stats.missed += missed;
            health.missed(missed);
            if !outputs.clock.is_simulated() {
                let ms = started.elapsed().as_secs_f64() * 1e3;
                log::warn!("tick took {ms:.1} ms, behind schedule");
            }
            now + period
        } else {
            tick
        });
    }
}

/// One command between ticks.
fn serve(stage: &mut Stage, command: StepperCommand, outputs: &SharedOutputs, step_now: bool) {
    match command {
        StepperCommand::Add(ready) => stage.add(*ready, outputs, step_now),
        StepperCommand::Switch(refined) => stage.switch(*refined, outputs),
        StepperCommand::Observe(frame) => stage.observe(*frame, outputs),
        StepperCommand::Interact(i) => stage.interact(&i, outputs),
        StepperCommand::Scene {
            scene,
            first_id,
            frame,
        } => stage.set_scene(*scene, first_id, frame, outputs),
        StepperCommand::Joints { robots, state } => stage.set_joints(&robots, &state, outputs),
        StepperCommand::Robot(robot, notes) => stage.set_robot(*robot, &notes, outputs),
        StepperCommand::Seen(frame) => stage.seen(&frame, outputs),
        StepperCommand::Reset(answer) => {
            let _ = answer.send(stage.reset(outputs));
        }
        StepperCommand::Clear(answer) => {
            let _ = answer.send(stage.clear(outputs));
        }
    }
}
