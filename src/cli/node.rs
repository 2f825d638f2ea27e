//! `physskin node`: the ROS 2 node until Ctrl-C.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use physskin::ros::{run_node, NodeConfig, NodeError, NodeParams};
use physskin::skinning::NeuralModel;

#[derive(clap::Args)]
pub struct NodeArgs {
    /// Parameter file in the ROS 2 format (`physskin: ros__parameters: ...`, or `/**`).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Node name.
    #[arg(long, default_value = "physskin")]
    name: String,
    /// Node namespace.
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
    /// Model weights (default: the bundled model).
    #[arg(long)]
    model: Option<PathBuf>,
}

pub fn run(args: NodeArgs) -> physskin::Result<()> {
    let mut config = NodeConfig {
        name: args.name,
        namespace: args.namespace,
        domain_id: args
            .domain_id
            .or_else(|| std::env::var("ROS_DOMAIN_ID").ok()?.parse().ok())
            .unwrap_or(0),
        loopback_only: args.loopback_only,
        ..NodeConfig::default()
    };
    if let Some(path) = &args.params {
        config.params = NodeParams::from_yaml_file(path, &config.fully_qualified_name())?;
    }
    if let Some(path) = &args.record {
        config.params.record.path = path.display().to_string();
    }
    if let Some(path) = &args.scene {
        config.params.scene = path.display().to_string();
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
    let stats = run_node(config, model, stop)?;
    eprintln!(
        "physskin node stopped: {} ticks, {} missed",
        stats.ticks, stats.missed
    );
    Ok(())
}
