//! The node's std_srvs/Trigger services: `~/reset` (every object back to rest) and `~/clear`
//! (every object removed). Requests are served on the executor; the stepper does the work
//! between two ticks and answers what it did.

use std::sync::mpsc::{channel, Sender};
use std::time::Duration;

use ros2_client::ros2::policy::{Durability, History, Reliability};
use ros2_client::ros2::{QosPolicies, QosPolicyBuilder};
use ros2_client::{AService, Name, Node, Server, ServiceMapping, ServiceTypeName};

use super::dds::NodeError;
use crate::msg::{TriggerRequest, TriggerResponse};
use crate::runtime::stepper::StepperCommand;

impl ros2_client::Message for TriggerRequest {}
impl ros2_client::Message for TriggerResponse {}

/// The std_srvs/Trigger service type.
pub type Trigger = AService<TriggerRequest, TriggerResponse>;

/// ROS 2's default service QoS: reliable, volatile, keep-last 10.
fn service_qos() -> QosPolicies {
    QosPolicyBuilder::new()
        .history(History::KeepLast { depth: 10 })
        .reliability(Reliability::Reliable {
            max_blocking_time: ros2_client::ros2::Duration::from_millis(100),
        })
        .durability(Durability::Volatile)
        .build()
}

/// A std_srvs/Trigger server at the fully qualified `name`.
pub fn trigger_server(node: &mut Node, name: &str) -> Result<Server<Trigger>, NodeError> {
    let parsed =
        Name::parse(name).map_err(|e| NodeError::Name(format!("service `{name}`: {e:?}")))?;
    node.create_server::<Trigger>(
        ServiceMapping::Enhanced,
        &parsed,
        &ServiceTypeName::new("std_srvs", "Trigger"),
        service_qos(),
        service_qos(),
    )
    .map_err(|e| NodeError::Dds(format!("service `{name}`: {e:?}")))
}

/// Which control request a server forwards.
#[derive(Clone, Copy)]
pub enum Control {
    /// `~/reset`: every object back to rest.
    Reset,
    /// `~/clear`: every object removed.
    Clear,
}

/// Serves `server` until the executor stops: each request becomes a stepper command, and the
/// stepper's answer the response (or a failure if it does not answer within a second).
pub async fn serve(server: Server<Trigger>, control: Control, stepper: Sender<StepperCommand>) {
    loop {
        let Ok((id, _)) = server.async_receive_request().await else {
            continue;
        };
        let (answer_tx, answer_rx) = channel();
        let command = match control {
            Control::Reset => StepperCommand::Reset(answer_tx),
            Control::Clear => StepperCommand::Clear(answer_tx),
        };
        let sent = stepper.send(command).is_ok();
        let answer =
            smol::unblock(move || answer_rx.recv_timeout(Duration::from_secs(1)).ok()).await;
        let response = match (sent, answer) {
            (true, Some(message)) => TriggerResponse {
                success: true,
                message,
            },
            _ => TriggerResponse {
                success: false,
                message: "the stepping thread did not answer within 1 s".into(),
            },
        };
        if let Err(e) = server.async_send_response(id, response).await {
            log::warn!("service response not sent: {e:?}");
        }
    }
}
