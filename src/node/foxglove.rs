//! The Foxglove live view: a WebSocket server (the `foxglove` SDK's, so no hand-written
//! protocol) that Foxglove connects to from a laptop without ROS. Every output topic, every
//! input as it arrives (/tf among them) and /diagnostics go out as `cdr` channels with their
//! `ros2msg` schemas, the same bytes DDS and the recording carry; the node's parameters can be
//! read and set; a client may publish physskin/Interaction on `~/interaction` to poke objects.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex, RwLock};

use foxglove::websocket::{
    AnyClient, Capability, Client, ClientChannel, GetParametersResponder, Parameter,
    ParameterHandler, ParameterValue, ServerListener, SetParametersResponder,
};
use foxglove::{
    ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer,
    WebSocketServerHandle,
};
use serde_json::Value;

use super::dds::NodeError;
use crate::msg::{
    encode, from_cdr, schema_text, DiagnosticArray, Interaction, MarkerArray, Output, PointCloud2,
    RosMessage, Sink, SkinningWeights, Status, SubspaceState, TFMessage,
};
use crate::runtime::outputs::{TF, TF_STATIC};
use crate::runtime::stepper::StepperCommand;
use crate::runtime::{NodeParams, Outputs, Topics};

/// The channels every message goes out on, and the server once started.
pub struct LiveView {
    /// Where its server listens.
    address: SocketAddr,
    context: Arc<Context>,
    channels: Mutex<HashMap<String, Arc<RawChannel>>>,
    server: Mutex<Option<WebSocketServerHandle>>,
}

impl LiveView {
    /// A view whose server will listen on `address`, not started yet, with a channel for
    /// every output topic of `t`, its interaction topic (so that a client knows
    /// physskin/msg/Interaction to publish it), /tf, /tf_static and /diagnostics; other inputs
    /// get theirs as they first arrive.
    pub fn new(t: &Topics, address: SocketAddr) -> Self {
        let view = Self {
            address,
            context: Context::new(),
            channels: Mutex::default(),
            server: Mutex::default(),
        };
        for topic in [&t.deformed_points, &t.weights_cloud] {
            view.channel::<PointCloud2>(topic);
        }
        view.channel::<SkinningWeights>(&t.weights);
        view.channel::<SubspaceState>(&t.state);
        view.channel::<Status>(&t.status);
        view.channel::<MarkerArray>(&t.markers);
        view.channel::<Interaction>(&t.interaction);
        view.channel::<TFMessage>(TF);
        view.channel::<TFMessage>(TF_STATIC);
        view.channel::<DiagnosticArray>("/diagnostics");
        view
    }

    /// `message` on `topic` at `log_time_ns`, to the clients subscribed to it (serialized only
    /// when one is).
    pub fn relay<M: RosMessage>(&self, topic: &str, log_time_ns: i64, message: &M) {
        let Some(channel) = self.channel::<M>(topic) else {
            return;
        };
        if !channel.has_sinks() {
            return;
        }
        let bytes = encode(message);
        let meta = PartialMetadata {
            log_time: Some(log_time_ns.max(0) as u64),
        };
        channel.log_with_meta(&bytes, meta);
    }

    /// The channel of `topic`, made with `M`'s schema on first use; None (and a warning) if the
    /// SDK refuses it.
    fn channel<M: RosMessage>(&self, topic: &str) -> Option<Arc<RawChannel>> {
        let mut channels = self.channels.lock().ok()?;
        if let Some(c) = channels.get(topic) {
            return Some(c.clone());
        }
        let schema = Schema::new(M::type_name(), "ros2msg", schema_text::<M>().into_bytes());
        let made = ChannelBuilder::new(topic)
            .message_encoding("cdr")
            .schema(schema)
            .context(&self.context)
            .build_raw();
        match made {
            Ok(c) => {
                channels.insert(topic.to_string(), c.clone());
                Some(c)
            }
            Err(e) => {
                log::warn!("Foxglove channel {topic}: {e}");
                None
            }
        }
    }

    /// Where the server listens (its port as asked: 0 picks one, which `start` returns).
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// Starts the server on its address; clients' interactions go to the stepper through
    /// `client_input`, parameters are read and set in `params`. Returns the port it listens on.
    pub fn start(
        &self,
        name: &str,
        client_input: ClientInput,
        params: Arc<RwLock<NodeParams>>,
    ) -> Result<u16, NodeError> {
        let address = self.address;
        let server = WebSocketServer::new()
            .name(name)
            .context(&self.context)
            .bind(address.ip().to_string(), address.port())
            .capabilities([Capability::ClientPublish])
            .supported_encodings(["cdr"])
            .listener(Arc::new(client_input))
            .parameter_handler(Arc::new(ParamAccess { params }))
            .start_blocking()
            .map_err(|e| NodeError::Dds(format!("Foxglove server on {address}: {e}")))?;
        let port = server.port();
        if let Ok(mut slot) = self.server.lock() {
            *slot = Some(server);
        }
        Ok(port)
    }

    /// Stops the server (its clients are told), if one runs.
    pub fn stop(&self) {
        let server = self.server.lock().ok().and_then(|mut s| s.take());
        if let Some(server) = server {
            server.stop().wait_blocking();
        }
    }
}

impl Sink for LiveView {
    fn send(&self, topic: &str, log_time_ns: i64, message: &Output) {
        match message {
            Output::Cloud(m) => self.relay(topic, log_time_ns, m),
            Output::Weights(m) => self.relay(topic, log_time_ns, m),
            Output::State(m) => self.relay(topic, log_time_ns, m),
            Output::Status(m) => self.relay(topic, log_time_ns, m),
            Output::Markers(m) => self.relay(topic, log_time_ns, m),
        }
    }
}

/// What Foxglove clients publish: physskin/Interaction on the node's interaction topic goes to
/// the stepper as a DDS one would; anything else is refused by name.
pub struct ClientInput {
    /// The node's interaction topic, resolved.
    pub interaction_topic: String,
    /// The stepper's commands (a Sender is not Sync; the lock is held for a send).
    pub step_tx: Mutex<Sender<StepperCommand>>,
    /// For refusals.
    pub outputs: Arc<Outputs>,
}

impl ServerListener for ClientInput {
    fn on_message_data(&self, _client: Client, channel: &ClientChannel, payload: &[u8]) {
        let refuse = |why: String| {
            let message = format!("Foxglove client on {}: {why}", channel.topic);
            self.outputs
                .report(Status::ERROR, 0, "input_rejected", message)
        };
        if channel.topic != self.interaction_topic {
            return refuse(format!("only {} is taken", self.interaction_topic));
        }
        if channel.encoding != "cdr" || channel.schema_name != Interaction::type_name() {
            let got = format!("{} in {}", channel.schema_name, channel.encoding);
            return refuse(format!(
                "{got}, expected {} in cdr",
                Interaction::type_name()
            ));
        }
        match from_cdr::<Interaction>(payload) {
            Ok(i) => {
                if let Ok(tx) = self.step_tx.lock() {
                    let _ = tx.send(StepperCommand::Interact(i));
                }
            }
            Err(e) => refuse(e),
        }
    }
}

/// The node's parameters for Foxglove's parameter panel: read all, set those that may change
/// while the node runs (checked as `ros2 param set` checks them).
struct ParamAccess {
    params: Arc<RwLock<NodeParams>>,
}

impl ParameterHandler for ParamAccess {
    fn get(
        &self,
        _client: AnyClient,
        names: Vec<String>,
        _request_id: Option<String>,
        responder: GetParametersResponder,
    ) {
        let all = self
            .params
            .read()
            .map(|p| p.flattened())
            .unwrap_or_default();
        let wanted = all
            .into_iter()
            .filter(|(name, _)| names.is_empty() || names.contains(name))
            .map(|(name, value)| to_parameter(name, &value))
            .collect();
        responder.respond(wanted);
    }

    fn set(
        &self,
        _client: AnyClient,
        parameters: Vec<Parameter>,
        _request_id: Option<String>,
        responder: SetParametersResponder,
    ) {
        let mut applied = Vec::new();
        if let Ok(mut current) = self.params.write() {
            for p in parameters {
                let value = p.value.as_ref().map_or(Value::Null, from_parameter);
                match current.with_while_running(&p.name, value) {
                    Ok(updated) => {
                        *current = updated;
                        log::info!("parameter {} set from Foxglove", p.name);
                        applied.push(p);
                    }
                    Err(e) => log::warn!("Foxglove set {}: {e}", p.name),
                }
            }
        }
        responder.respond(applied);
    }
}

/// A parameter's JSON value as Foxglove's.
fn to_parameter(name: String, value: &Value) -> Parameter {
    Parameter {
        name,
        r#type: None,
        value: to_parameter_value(value),
    }
}

fn to_parameter_value(value: &Value) -> Option<ParameterValue> {
    Some(match value {
        Value::Bool(b) => ParameterValue::Bool(*b),
        Value::Number(n) if n.is_f64() => ParameterValue::Float64(n.as_f64()?),
        Value::Number(n) => ParameterValue::Integer(n.as_i64()?),
        Value::String(s) => ParameterValue::String(s.clone()),
        Value::Array(items) => {
            ParameterValue::Array(items.iter().filter_map(to_parameter_value).collect())
        }
        Value::Null | Value::Object(_) => return None,
    })
}

/// Foxglove's value as the JSON the parameters are typed by.
fn from_parameter(value: &ParameterValue) -> Value {
    match value {
        ParameterValue::Bool(b) => Value::from(*b),
        ParameterValue::Integer(i) => Value::from(*i),
        ParameterValue::Float64(f) => Value::from(*f),
        ParameterValue::String(s) => Value::from(s.clone()),
        ParameterValue::Array(items) => Value::Array(items.iter().map(from_parameter).collect()),
        ParameterValue::Dict(map) => Value::Object(
            map.iter()
                .map(|(k, v)| (k.clone(), from_parameter(v)))
                .collect(),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_round_trip_through_foxglove_values() {
        let p = NodeParams::default();
        for (name, value) in p.flattened() {
            let foxglove = to_parameter(name.clone(), &value);
            let Some(v) = &foxglove.value else {
                continue;
            };
            let back = from_parameter(v);
            // Integers and floats keep their kind; a float that is whole stays a float.
            assert_eq!(back, value, "{name}");
        }
    }
}
