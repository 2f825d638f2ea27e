//! The stepping thread: every running object advances once per period and its outputs go out.
//! New bodies and interactions arrive on a channel between ticks.

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use rayon::prelude::*;

use super::builder::ReadyBody;
use super::messages::{Interaction, Status};
use super::outputs::{Outputs, SharedOutputs};

pub enum StepperCommand {
    Add(Box<ReadyBody>),
    Interact(Interaction),
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
        self.bodies.par_iter_mut().for_each(|b| {
            b.body.step();
        });
        self.unpublished.iter_mut().for_each(|u| *u = true);
        if !self.on_the_beat {
            self.publish_pending(outputs);
        }
    }

    fn publish_pending(&mut self, outputs: &Outputs) {
        for (b, unpublished) in self.bodies.iter().zip(&mut self.unpublished) {
            if std::mem::take(unpublished) {
                publish_last_step(b, outputs);
            }
        }
    }

    pub fn bodies(&self) -> &[ReadyBody] {
        &self.bodies
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
        interact(&mut self.bodies, i, outputs)
    }
}

fn step(b: &mut ReadyBody, outputs: &Outputs) {
    b.body.step();
    publish_last_step(b, outputs);
}

/// Publishes a body's last step (and a warning if it did not converge).
fn publish_last_step(b: &ReadyBody, outputs: &Outputs) {
    let Some(report) = b.body.last_step() else {
        return;
    };
    if !report.converged {
        let message = format!(
            "step did not converge ({} iterations, decrement {:e})",
            report.iterations, report.decrement
        );
        outputs.report(Status::WARN, b.id, "step_unconverged", message);
    }
    outputs.publish_step(b.id, &b.frame, &b.body);
}

fn interact(bodies: &mut [ReadyBody], i: &Interaction, outputs: &Outputs) {
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
    for b in bodies.iter_mut().filter(|b| {
        (i.shape_id == 0 || b.id == i.shape_id) && (frame.is_empty() || b.frame == *frame)
    }) {
        matched += 1;
        match i.kind {
            Interaction::FORCE => b.body.push(point, force, i.duration.max(0.0)),
            Interaction::PIN => {
                if b.body.hold(&point, i.radius) == 0 {
                    ignored(format!(
                        "no material within {} m of the pin point",
                        i.radius
                    ));
                }
            }
            _ => {
                b.body.release(&point, i.radius);
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
