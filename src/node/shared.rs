//! The state the node's executor, its build thread and its stepper share.

use std::sync::atomic::AtomicU64;
use std::sync::{Arc, RwLock};

use super::foxglove::LiveView;
use crate::bag::Recorder;
use crate::msg::RosMessage;
use crate::runtime::{Health, NodeParams, Outputs, TfBuffer};

/// What the executor, the build thread and the stepper share.
pub(super) struct Shared {
    pub params: Arc<RwLock<NodeParams>>,
    pub outputs: Arc<Outputs>,
    pub tf: Arc<RwLock<TfBuffer>>,
    pub health: Arc<Health>,
    /// The recording (also one of the outputs' sinks), for inputs and /diagnostics.
    pub recorder: Option<Arc<Recorder>>,
    /// Publications DDS refused, for /diagnostics.
    pub dropped: Arc<AtomicU64>,
    /// The Foxglove live view (also one of the outputs' sinks), for inputs and /diagnostics.
    pub live: Option<Arc<LiveView>>,
}

impl Shared {
    /// Records an input as it arrives (log time now; publish time its stamp when it has one),
    /// and relays it to the live view.
    pub fn record_input<M: RosMessage>(&self, topic: &str, stamp: Option<i64>, message: &M) {
        if self.recorder.is_none() && self.live.is_none() {
            return;
        }
        let now = self.outputs.clock.now_nanos().unwrap_or(0);
        if let Some(live) = &self.live {
            live.relay(topic, now, message);
        }
        if let Some(recorder) = &self.recorder {
            let sent = stamp.filter(|s| *s > 0).unwrap_or(now);
            if let Err(e) = recorder.record(topic, now, sent, message) {
                log::error!("recording {topic}: {e}");
            }
        }
    }

    /// `message` on `topic` to the live view's clients, if there is a live view.
    pub fn relay<M: RosMessage>(&self, topic: &str, message: &M) {
        if let Some(live) = &self.live {
            live.relay(topic, self.outputs.clock.now_nanos().unwrap_or(0), message);
        }
    }
}
