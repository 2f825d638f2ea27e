//! `physskin node`: the ROS 2 node until Ctrl-C. It takes the ROS command line
//! (`--ros-args ...`) as launch_ros writes it, besides its own flags.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::node::{NodeConfig, NodeError, RosArgs};
use crate::runtime::{NameResolver, ParamLoader};
use crate::skinning::NeuralModel;

#[derive(clap::Args)]
pub struct NodeArgs {
    /// Parameter file in the ROS 2 format (`physskin: ros__parameters: ...`, or `/**`); the
    /// same as `--ros-args --params-file FILE`, read before those.
    #[arg(long)]
    params: Option<PathBuf>,
    /// Node name (`--ros-args -r __node:=NAME` overrides it).
    #[arg(long, default_value = "physskin")]
    name: String,
    /// Node namespace (`--ros-args -r __ns:=/NS` overrides it).
    #[arg(long, default_value = "/")]
    namespace: String,
    /// ROS_DOMAIN_ID (default: the environment's, else 0).
    #[arg(long)]
    domain_id: Option<u16>,
    /// Keep DDS on 127.0.0.1.
    #[arg(long)]
    loopback_only: bool,
    /// Record every input and output topic to this MCAP file (overrides `record.path`).
    #[arg(long)]
    record: Option<PathBuf>,
    /// Scene file to run (overrides `scene`): its objects are simulated and its robots follow
    /// their joint-state topics.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Serve the Foxglove live view on ADDR:PORT (default 127.0.0.1:8765; overrides
    /// `foxglove.address`): Foxglove connects to ws://ADDR:PORT.
    #[arg(long, num_args = 0..=1, default_missing_value = "127.0.0.1:8765", value_name = "ADDR:PORT")]
    foxglove: Option<String>,
    /// Model weights (default: the bundled model).
    #[arg(long)]
    model: Option<PathBuf>,
}

/// The node's names and parameters from its flags and ROS arguments, in rcl's order: the
/// parameter files (`--params` first), then each `-p NAME:=VALUE`.
pub fn ros_setup(
    ros: &RosArgs,
    name: &str,
    namespace: &str,
    params: Option<&Path>,
) -> crate::Result<(NameResolver, ParamLoader)> {
    let names = NameResolver::new(namespace, name)
        .with_rules(&ros.remaps)
        .map_err(NodeError::from)?;
    let node = names.fully_qualified_name();
    let mut loader = ParamLoader::default();
    for file in params
        .into_iter()
        .chain(ros.params_files.iter().map(PathBuf::as_path))
    {
        loader.apply_file(file, &node)?;
    }
    for (name, value) in &ros.params {
        loader.apply_override(name, value)?;
    }
    loader.warnings.extend(
        ros.ignored
            .iter()
            .map(|a| format!("ROS argument `{a}` has no effect on this node")),
    );
    Ok((names, loader))
}

/// Whether the environment keeps ROS 2 to this host, as rmw implementations read it:
/// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, or the older `ROS_LOCALHOST_ONLY=1`.
fn localhost_only_asked() -> bool {
    let env = |name: &str| std::env::var(name).unwrap_or_default();
    env("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST" || env("ROS_LOCALHOST_ONLY") == "1"
}

pub fn run(args: NodeArgs, ros: RosArgs) -> crate::Result<()> {
    let (names, loader) = ros_setup(&ros, &args.name, &args.namespace, args.params.as_deref())?;
    let mut config = NodeConfig {
        names,
        params: loader.params,
        qos: loader.qos,
        warnings: loader.warnings,
        domain_id: args
            .domain_id
            .or_else(|| std::env::var("ROS_DOMAIN_ID").ok()?.parse().ok())
            .unwrap_or(0),
        loopback_only: args.loopback_only || localhost_only_asked(),
        log_level: ros.log_level.unwrap_or(crate::node::LogLevel::Info),
        rosout: !ros.rosout_disabled,
    };
    if let Some(path) = &args.record {
        config.params.record.path = path.display().to_string();
    }
    if let Some(path) = &args.scene {
        config.params.scene = path.display().to_string();
    }
    if let Some(address) = &args.foxglove {
        config.params.foxglove.address = address.clone();
    }
    let model = match &args.model {
        Some(path) => Arc::new(NeuralModel::load(path)?),
        None => NeuralModel::bundled()?,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // Ctrl-C and SIGTERM stop the node cleanly, so DDS tells its peers it is leaving.
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .map_err(|e| NodeError::Signal(e.to_string()))?;
    // The node's own `node_stopped` line counts its ticks.
    crate::node::run(config, model, stop)?;
    Ok(())
}
