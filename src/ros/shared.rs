//! The state the node's executor, its build thread and its stepper share.

use std::sync::{Arc, RwLock};

use super::diagnostics::Health;
use super::outputs::Outputs;
use super::params::NodeParams;
use super::tf::TfBuffer;

/// What the executor, the build thread and the stepper share.
pub(super) struct Shared {
    pub params: Arc<RwLock<NodeParams>>,
    pub outputs: Arc<Outputs>,
    pub tf: Arc<RwLock<TfBuffer>>,
    pub health: Arc<Health>,
}
