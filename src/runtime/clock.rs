//! The node's time: the wall clock, or /clock when use_sim_time is set.

use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use crate::msg::Time;

/// Where stamps and the step schedule take their time from.
#[derive(Clone)]
pub enum NodeClock {
    /// The system clock (Unix time).
    Wall,
    /// Nanoseconds of the last /clock message; negative until the first arrives.
    Sim(Arc<AtomicI64>),
}

impl NodeClock {
    /// A simulated clock that has not started: it starts with the first [`NodeClock::set`].
    pub fn simulated() -> Self {
        NodeClock::Sim(Arc::new(AtomicI64::new(-1)))
    }

    /// Now, in nanoseconds since the epoch (wall) or of the simulation; None while a simulated
    /// clock has not started.
    pub fn now_nanos(&self) -> Option<i64> {
        match self {
            NodeClock::Wall => Some(
                SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos() as i64),
            ),
            NodeClock::Sim(nanos) => {
                let t = nanos.load(Ordering::Acquire);
                (t >= 0).then_some(t)
            }
        }
    }

    /// Now as a ROS Time; 0 while a simulated clock has not started.
    pub fn now(&self) -> Time {
        Time::from_nanos(self.now_nanos().unwrap_or(0))
    }

    /// Records a /clock message (simulated clocks only). Time never runs backwards here: a
    /// replay that loops restarts the schedule instead (see the stepper).
    pub fn set(&self, time: &Time) {
        if let NodeClock::Sim(nanos) = self {
            nanos.store(time.nanos(), Ordering::Release);
        }
    }

    /// Whether the clock follows /clock.
    pub fn is_simulated(&self) -> bool {
        matches!(self, NodeClock::Sim(_))
    }
}
