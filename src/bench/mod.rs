//! Benchmarks that print tables (and JSON): speed next to error against the full-space reference.

mod basis;
mod contact;
mod fem_convergence;
mod fields;
mod input;
mod latency;
mod peer;
mod plot;
mod real_bench;
mod real_to_sim;
mod replay;
mod scene;
pub(crate) mod sim;
mod simulate;
mod soak;
mod soft_contact;
mod statics;
mod stats;
mod stress;
mod sweep;
mod track;
mod track_peer;
mod track_report;
mod track_sequences;
mod track_truth;
mod transport;
mod views;

pub use basis::{basis_plot, run_basis_bench, BasisOptions, BasisReport};
pub use contact::run_contact_bench;
pub use fem_convergence::{run_fem_convergence, FemMesh};
pub use fields::{evaluate_fields, EvalOptions, EvalReport};
pub use input::prepare_input;
pub use latency::run_latency_bench;
pub use peer::{peer_plot, run_peer_bench, PeerOptions};
pub use real_bench::run_real_bench;
pub use real_to_sim::{simulate_input, InputSimOptions, InputSimSummary};
pub use replay::run_replay_bench;
pub use scene::{run_scene, run_scene_bench, SceneRun, SceneRunOptions, WORKCELL};
pub use sim::{handles_plot, sim_plot, SimBenchOptions, SimBenchReport};
pub use simulate::{simulate, SimulateOptions};
pub use soak::{run_soak, SoakOptions};
pub use stress::{run_stress, stress_cases};
pub use sweep::run_sim_bench;
pub use track::{
    run_track_bench, track_plot, TrackBenchOptions, TrackSpread,
    DEFAULT_SEED as DEFAULT_TRACK_SEED, DEFAULT_VIEW as DEFAULT_TRACK_VIEW,
};
pub use transport::run_transport_bench;
pub use views::run_views_bench;
