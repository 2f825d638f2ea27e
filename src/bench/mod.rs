//! Benchmarks that print tables (and JSON): speed next to error against the full-space reference.

mod contact;
mod fields;
mod input;
mod latency;
mod plot;
mod real_bench;
mod real_to_sim;
mod replay;
mod scene;
pub(crate) mod sim;
mod soak;
mod stats;
mod stress;
mod transport;

pub use contact::{run_contact_bench, ContactReport, RestingBallRow};
pub use fields::{evaluate_fields, interior_points, EvalMean, EvalOptions, EvalReport, ShapeEval};
pub use input::{prepare_input, PreparedInput};
pub use latency::{run_latency_bench, sample_cloud, LatencyReport, RclpyLatency};
pub use real_bench::{run_real_bench, RealBenchReport, ScanRow};
pub use real_to_sim::{simulate_input, InputSimOptions, InputSimSummary};
pub use replay::{run_replay_bench, ReplayBenchReport};
pub use scene::{
    run_scene, run_scene_bench, SceneBenchReport, SceneRun, SceneRunOptions, WORKCELL,
    WORKCELL_ACTIVE,
};
pub use sim::{
    run_sim_bench, sim_plot, simulate, SimBenchOptions, SimBenchReport, SimRow, SimulateOptions,
    SimulateSummary,
};
pub use soak::{run_soak, MemorySample, SoakOptions, SoakReport};
pub use stats::median;
pub use stress::{run_stress, stress_cases, Start, StressCase, StressReport, StressRow};
pub use transport::{run_transport_bench, TransportReport};
