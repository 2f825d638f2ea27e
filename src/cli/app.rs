//! The physskin command line: one subcommand per job, parsed here and run by the modules
//! beside this one.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "physskin",
    version,
    about = "Physically based motion for any 3D object in real time"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job: replay the bundled demo recording through the whole pipeline, record the
    /// result to MCAP, compare with the full-space FEM, draw a grid of frames.
    Demo(crate::cli::demo::DemoArgs),
    /// Feed a recording's inputs through the pipeline on the log's time; record the outputs.
    Replay(crate::cli::bag::ReplayArgs),
    /// Rewrite a recording cut short by a crash into a complete file.
    Recover(crate::cli::bag::RecoverArgs),
    /// Simulate a bundled shape, or any mesh or cloud file (one camera's scan included), in its
    /// skinning subspace and compare with the full-space FEM.
    Simulate(crate::cli::simulate::SimulateArgs),
    /// One depth camera's view of a mesh (its visible side), as a PLY cloud; prints the
    /// camera's position (the viewpoint for `simulate` and `infer`).
    Scan(crate::cli::scan::ScanArgs),
    /// Train the neural skinning field on generated shapes (self-supervised).
    Train(crate::cli::train::TrainArgs),
    /// Skinning weights of a mesh or cloud file in one forward pass, and a picture of them.
    Infer(crate::cli::infer::InferArgs),
    /// Evaluate the learned fields on unseen shapes: metrics, inference time, simulation error.
    Eval(crate::cli::eval::EvalArgs),
    /// Run a scene file (robots, several objects) offline: what was decided for each object,
    /// step time, error against the FEM.
    Scene(crate::cli::scene::SceneArgs),
    /// The ROS 2 node: clouds and meshes in, skinning weights and deformed clouds out.
    Node(crate::cli::node::NodeArgs),
    /// Benchmarks; with no name, all of them.
    Bench {
        #[command(subcommand)]
        which: Option<BenchCommand>,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// ROS 2 node latency: cloud in to first deformed cloud out (10k, 100k points), and 60 Hz
    /// publish jitter while another shape is inferred. DDS stays on 127.0.0.1.
    Latency {
        #[arg(long)]
        json: bool,
        /// ROS domain for the run (keeps it apart from other runs on this machine).
        #[arg(long, default_value_t = 77)]
        domain_id: u16,
        /// A Python with rclpy (Fast DDS) and sensor_msgs, e.g. target/ros-venv/bin/python (made
        /// by the ROS tests): adds the rclpy case, a cloud from rclpy to an rclpy subscriber.
        #[arg(long)]
        rclpy_python: Option<std::path::PathBuf>,
        /// The node's `inference.refine` for the run (`off`, `full` or milliseconds); the
        /// node's default when not given.
        #[arg(long)]
        refine: Option<String>,
        /// Run a second instance (a `physskin node` process) beside the measured one (shards
        /// 0/2 and 1/2 of the frames), stepping a 10k-point object of its own through the
        /// jitter phase.
        #[arg(long)]
        shards: bool,
    },
    /// A 100k-point deformed cloud delivered each frame over iceoryx2 and over DDS (run it in a
    /// private network namespace: `unshare -n tests/peers/private_net.sh`).
    Transport {
        #[arg(long)]
        json: bool,
        #[arg(long, default_value_t = 78)]
        domain_id: u16,
    },
    /// MCAP: the demo bag's replay speed (output recorded) and what recording adds to a 60 Hz
    /// step of a 10k-point cloud.
    Replay {
        #[arg(long)]
        json: bool,
    },
    /// The bundled robot cell: the 2 objects the robot moves alone, the 10-object scene with
    /// its decisions (error-budget sizes, sleeping) and without; step time next to FEM error.
    Scene {
        #[arg(long)]
        json: bool,
        /// Simulated seconds of motion.
        #[arg(long, default_value_t = 3.5)]
        seconds: f64,
    },
    /// The node for a long run under changing shapes, pokes, pins and bad inputs, recording:
    /// memory over time, ticks missed, NaN states, the recording read back (run it in a private
    /// network namespace: `unshare -n tests/peers/private_net.sh`).
    Soak {
        #[arg(long)]
        json: bool,
        #[arg(long, default_value_t = 600.0)]
        seconds: f64,
        #[arg(long, default_value_t = 79)]
        domain_id: u16,
        #[arg(long, default_value = "target/soak/soak.mcap")]
        record: PathBuf,
    },
    /// Time to an accurate basis: the network's field, refined toward the skinning eigenmodes
    /// iteration by iteration, and the exact eigenmodes, each against the FEM.
    Basis(crate::cli::basis::BasisArgs),
    /// Numerical stress: stiff to soft, nu toward 0.5, large steps, inverted starts, a thin
    /// sheet, violent pokes; each case's NaN, energy bound, Newton iterations and fallbacks.
    Stress {
        #[arg(long)]
        json: bool,
    },
    /// Contact at rest: balls placed on the floor, how far they roll in 2 s.
    Contact {
        #[arg(long)]
        json: bool,
    },
    /// One camera's scans of the bundled shapes, completed and simulated: volume, error
    /// against the FEM of the whole object beside the whole mesh's body, step times.
    Real {
        #[arg(long)]
        json: bool,
    },
    /// A soft object's stream from one depth camera (poked, squeezed, dropped, the view
    /// blocked), against the FEM: rebuilt per frame, built once, and tracked.
    Track(crate::cli::track::TrackArgs),
    /// One camera's view of fourteen shapes and eleven real objects' meshes from six sides,
    /// completed: volume and overlap against the whole mesh's solid (geometry only).
    Views {
        #[arg(long)]
        json: bool,
    },
    /// How far `bench sim`'s FEM reference is from converged: each shape's hanging equilibrium
    /// at several resolutions (sag, largest displacement, Rayleigh's lowest frequency).
    Fem {
        #[arg(long)]
        json: bool,
        /// Small meshes (16, 24, 32 cells) only: fits in a test.
        #[arg(long)]
        quick: bool,
        /// Only these shapes (plate, rod, creature); all when absent.
        #[arg(long, value_delimiter = ',')]
        shapes: Vec<String>,
        /// Meshes whose cells tile each shape's bounds, a cell solid when half of it is (the
        /// demo's reference), instead of `bench sim`'s, which keep every cell the surface cuts.
        #[arg(long)]
        fitted: bool,
        /// Quadratic tetrahedra (a node at each edge's middle) instead of linear ones, at half
        /// the cells across.
        #[arg(long)]
        quadratic: bool,
    },
    /// The same soft block in MuJoCo (flexcomp: full, trilinear and quadratic dofs) and in
    /// physskin, dropped and poked, each against our FEM: step time next to error.
    Peer {
        #[arg(long)]
        json: bool,
        /// A Python that imports mujoco, e.g. target/mujoco-venv/bin/python.
        #[arg(long)]
        python: PathBuf,
        /// Frames per scenario (1/60 s).
        #[arg(long, default_value_t = 60)]
        steps: usize,
        /// MuJoCo grid vertices along an edge.
        #[arg(long, default_value_t = 5)]
        count: usize,
        /// MuJoCo steps per frame, one set of rows per count (comma-separated).
        #[arg(long, value_delimiter = ',', default_value = "1,4,16")]
        substeps: Vec<usize>,
        /// Where to write the step-time-against-error plot (SVG).
        #[arg(long, default_value = "target/bench/peer.svg")]
        plot: PathBuf,
    },
    /// Reduced simulation against the FEM reference: step time next to error.
    Sim(crate::cli::bench_sim::SimArgs),
}

/// Sets RAYON_NUM_THREADS, when unset, to the thread count rayon would pick anyway. candle
/// asks for its thread count before every parallel kernel and, without the variable, counts
/// the physical cores by reading /proc/cpuinfo each time: a fifth of a model build on 2 cores
/// (`physskin scene`: 8.7 s against 7.0 s). candle then uses every logical core rather than
/// one per physical core; a user's own RAYON_NUM_THREADS is kept.
fn settle_thread_count() {
    if std::env::var_os("RAYON_NUM_THREADS").is_none() {
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        // First thing in main, before any thread exists to read the environment meanwhile.
        std::env::set_var("RAYON_NUM_THREADS", threads.to_string());
    }
}

/// Keeps freed memory in the process instead of handing it back to the kernel: every build
/// allocates and frees tens of megabytes (the network's activations, voxel grids), and fresh
/// pages fault in one by one, a tenth of a scan's build in `perf` (a 6000-point scan built eight
/// times, four runs each: median 75.0 ms against 89.7 ms, printed). Blocks under 32 MB come from
/// the heap, which is trimmed past 1 GB of free space only.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // SAFETY: mallopt only sets allocator tunables; called first in main, before any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

/// Runs the command line of this process: what `physskin` does.
pub fn main() -> ExitCode {
    keep_freed_memory();
    settle_thread_count();
    // rcl's arguments (`--ros-args ... [--]`) are taken out before clap reads the rest.
    let argv: Vec<String> = std::env::args().collect();
    let (own, ros) = match crate::node::split_ros_args(&argv) {
        Ok(split) => split,
        Err(e) => {
            eprintln!("physskin: {e}");
            return ExitCode::from(2);
        }
    };
    let cli = Cli::parse_from(own);
    // Every command logs through the one facade; `--log-level` (node, replay) sets its level.
    let level = ros.log_level.unwrap_or(crate::node::LogLevel::Info);
    crate::node::install_logger(level.filter());
    let takes_ros_args = matches!(cli.command, Command::Node(_) | Command::Replay(_));
    if !takes_ros_args && ros != crate::node::RosArgs::default() {
        eprintln!("physskin: --ros-args is taken by `node` and `replay` only");
        return ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Simulate(args) => crate::cli::simulate::run(args),
        Command::Scan(args) => crate::cli::scan::run(args),
        Command::Demo(args) => crate::cli::demo::run(args),
        Command::Replay(args) => crate::cli::bag::run_replay(args, ros),
        Command::Recover(args) => crate::cli::bag::run_recover(args),
        Command::Train(args) => crate::cli::train::run(args),
        Command::Eval(args) => crate::cli::eval::run(args),
        Command::Infer(args) => crate::cli::infer::run(args),
        Command::Node(args) => crate::cli::node::run(args, ros),
        Command::Scene(args) => crate::cli::scene::run(args),
        Command::Bench { which } => match which
            .unwrap_or_else(|| BenchCommand::Sim(crate::cli::bench_sim::SimArgs::default()))
        {
            BenchCommand::Sim(args) => crate::cli::bench_sim::run(args),
            BenchCommand::Latency {
                json,
                domain_id,
                rclpy_python,
                refine,
                shards,
            } => run_bench_latency(json, domain_id, rclpy_python.as_deref(), refine, shards),
            BenchCommand::Replay { json } => run_bench_replay(json),
            BenchCommand::Scene { json, seconds } => crate::cli::scene::bench(seconds, json),
            BenchCommand::Transport { json, domain_id } => run_bench_transport(json, domain_id),
            BenchCommand::Stress { json } => run_bench_stress(json),
            BenchCommand::Basis(args) => crate::cli::basis::run(args),
            BenchCommand::Contact { json } => run_bench_contact(json),
            BenchCommand::Real { json } => run_bench_real(json),
            BenchCommand::Views { json } => run_bench_views(json),
            BenchCommand::Fem {
                json,
                quick,
                shapes,
                fitted,
                quadratic,
            } => run_bench_fem(json, quick, (fitted, quadratic), &shapes),
            BenchCommand::Track(args) => crate::cli::track::run(args),
            BenchCommand::Peer {
                json,
                python,
                steps,
                count,
                substeps,
                plot,
            } => {
                let options = crate::bench::PeerOptions {
                    python,
                    steps,
                    count,
                    substeps,
                };
                run_bench_peer(&options, json, &plot)
            }
            BenchCommand::Soak {
                json,
                seconds,
                domain_id,
                record,
            } => run_bench_soak(json, seconds, domain_id, record),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("physskin: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run_bench_transport(json: bool, domain_id: u16) -> crate::Result<()> {
    let r = crate::bench::run_transport_bench(domain_id, |line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
    } else {
        println!(
            "{} points ({} bytes) per frame, {} frames   median      p99",
            r.points, r.bytes, r.frames
        );
        println!(
            "iceoryx2 (shared memory, one copy in)          {:8.4} ms {:8.4} ms",
            r.iceoryx2_median_ms, r.iceoryx2_p99_ms
        );
        println!(
            "DDS (ros2-client, PointCloud2, reliable)       {:8.3} ms {:8.3} ms ({} of {} frames)",
            r.dds_median_ms, r.dds_p99_ms, r.dds_received, r.frames
        );
    }
    Ok(())
}

fn run_bench_soak(json: bool, seconds: f64, domain_id: u16, record: PathBuf) -> crate::Result<()> {
    let options = crate::bench::SoakOptions {
        seconds,
        domain_id,
        record,
    };
    let r = crate::bench::run_soak(&options, |line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!(
        "{:.0} s: {} shapes, {} pokes and pins, {} bad inputs sent",
        r.seconds, r.shapes_sent, r.pokes_sent, r.bad_inputs_sent
    );
    println!("ticks {}, missed {}", r.ticks, r.missed_ticks);
    println!(
        "states received {}, with NaN or Inf {}",
        r.states_received, r.non_finite_states
    );
    println!(
        "RSS warm {:.1} MB, end {:.1} MB, max {:.1} MB, growth {:+.3} MB/min (heap in use {:+.3})",
        r.rss_warm_mb,
        r.rss_end_mb,
        r.rss_max_mb,
        r.rss_growth_mb_per_min,
        r.heap_growth_mb_per_min
    );
    println!("statuses {:?}", r.statuses);
    println!(
        "recording: {} files, complete {}, {:?}",
        r.recording_files, r.recording_complete, r.recorded
    );
    Ok(())
}

fn run_bench_real(json: bool) -> crate::Result<()> {
    let r = crate::bench::run_real_bench(|line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!("| shape | camera from | scenario | points | volume / true | error % | whole mesh error % | ratio | step ms median / p99 / max | build ms |");
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in &r.rows {
        println!(
            "| {} | {:?} | {} | {} | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} / {:.3} / {:.3} | {:.1} |",
            r.shape, r.direction, r.scenario, r.points, r.volume_ratio, r.error_pct,
            r.whole_mesh_error_pct, r.error_ratio, r.step_ms, r.step_p99_ms, r.step_max_ms, r.build_ms
        );
    }
    println!(
        "worst: volume off by {:.1} %, error {:.2}x the whole mesh's, step {:.3} ms",
        r.worst_volume_error_pct, r.worst_error_ratio, r.worst_step_ms
    );
    Ok(())
}

fn run_bench_fem(
    json: bool,
    quick: bool,
    (fitted, quadratic): (bool, bool),
    shapes: &[String],
) -> crate::Result<()> {
    use crate::bench::FemMesh;
    use crate::physics::FemElement;
    let mesh = if fitted {
        FemMesh::Fitted
    } else {
        FemMesh::CutCells
    };
    let element = if quadratic {
        FemElement::Quadratic
    } else {
        FemElement::Linear
    };
    let progress = |line: &str| eprintln!("{line}");
    let r = crate::bench::run_fem_convergence(shapes, quick, mesh, element, progress)?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!("| shape | cells across | bench's | vertices | volume / shape's | sag, m | vs finest | largest, m | Rayleigh, Hz | vs finest | steps | solve, s |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &r.rows {
        println!(
            "| {} | {} | {} | {} | {:.3} | {:.6} | {:+.2} % | {:.6} | {:.4} | {:+.2} % | {}{} | {:.1} |",
            r.shape,
            r.resolution,
            if r.bench { "yes" } else { "" },
            r.vertices,
            r.volume_ratio,
            r.sag_m,
            r.sag_off_finest_pct,
            r.max_displacement_m,
            r.rayleigh_hz,
            r.rayleigh_off_finest_pct,
            r.steps,
            if r.settled { "" } else { " (not settled)" },
            r.solve_s
        );
    }
    Ok(())
}

fn run_bench_views(json: bool) -> crate::Result<()> {
    let r = crate::bench::run_views_bench(|line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!("| shape | image | camera from | depth noise at 1 m | points | outcome | prior | volume / true | overlap | centroid off / diagonal |");
    println!("|---|---|---|---:|---:|---|---|---:|---:|---:|");
    for r in &r.rows {
        println!(
            "| {} | {}x{} | {:?} | {} | {} | {} | {} | {:.3} | {:.3} | {:.3} |",
            r.shape,
            r.image[0],
            r.image[1],
            r.direction,
            r.depth_noise_m,
            r.points,
            r.outcome,
            r.prior,
            r.volume_ratio,
            r.overlap,
            r.centroid_offset
        );
    }
    for (kind, s) in [
        ("primitives", &r.clean),
        ("primitives", &r.noisy),
        ("real meshes", &r.real),
        ("real meshes", &r.real_noisy),
    ] {
        println!(
            "{kind}, depth noise {} m at 1 m: {} of {} completed scans within 30 % of the volume; mean overlap {:.3}; worst volume factor {:.3}",
            s.depth_noise_m, s.within_30_pct, s.completed, s.mean_overlap, s.worst_volume_factor
        );
    }
    Ok(())
}

fn run_bench_contact(json: bool) -> crate::Result<()> {
    let r = crate::bench::run_contact_bench(|line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!("| ball radius m | size | E Pa | rolling friction m | moved in 2 s, mm | step median ms | step p99 ms | decision |");
    println!("|---:|---|---:|---:|---:|---:|---:|---|");
    for row in &r.resting_ball {
        println!(
            "| {} | {} | {:.0e} | {} | {:.3} | {:.3} | {:.3} | {} |",
            row.radius_m,
            row.size,
            row.young_pa,
            row.rolling_friction_m,
            row.drift_mm,
            row.step_ms_median,
            row.step_ms_p99,
            row.decision
        );
    }
    println!();
    println!("| grasp friction | lifted m | moved in the grip in 10 s, mm | step median ms | step p99 ms |");
    println!("|---:|---:|---:|---:|---:|");
    for g in &r.grasp {
        println!(
            "| {} | {:.4} | {:.3} | {:.3} | {:.3} |",
            g.friction, g.lifted_m, g.drift_mm, g.step_ms_median, g.step_ms_p99
        );
    }
    println!();
    println!("| scene | object | error % | sag mm | FEM sag mm | step mean ms | step p99 ms |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for s in &r.soft {
        println!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            s.scene, s.object, s.error_pct, s.sag_mm, s.fem_sag_mm, s.step_ms, s.step_ms_p99
        );
    }
    let show = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.3}"));
    println!(
        "stack sag error {} %, slab error ratio {}",
        show(r.stack_sag_error_pct),
        show(r.slab_error_ratio)
    );
    Ok(())
}

fn run_bench_peer(
    options: &crate::bench::PeerOptions,
    json: bool,
    plot: &std::path::Path,
) -> crate::Result<()> {
    let r = crate::bench::run_peer_bench(options, |line| eprintln!("{line}"))?;
    crate::cli::write_plot(plot, &crate::bench::peer_plot(&r))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!(
        "MuJoCo {}; FEM reference {} vertices",
        r.mujoco_version, r.fem_vertices
    );
    println!("| scenario | engine | setting | dofs | step median ms | step p99 ms | error % | beaten by |");
    println!("|---|---|---|---:|---:|---:|---:|---|");
    for row in &r.rows {
        println!(
            "| {} | {} | {} | {} | {:.3} | {:.3} | {} | {} |",
            row.scenario,
            row.engine,
            row.variant,
            row.dofs,
            row.step_ms,
            row.step_ms_p99,
            row.error_pct
                .map_or_else(|| "not finite".into(), |e| format!("{e:.3}")),
            row.beaten_by.as_deref().unwrap_or("")
        );
    }
    Ok(())
}

fn run_bench_stress(json: bool) -> crate::Result<()> {
    let cases = crate::bench::stress_cases();
    let r = crate::bench::run_stress(&cases, |line| eprintln!("{line}"))?;
    if json {
        crate::cli::print_json(&r);
        return Ok(());
    }
    println!(
        "| case | E Pa | nu | dt s | steps | NaN steps | energy peak J | after J | end J | bounded | Newton iterations mean / max | fallback steps | extended steps | stiffened steps | unconverged steps | pin drift mm | max moved m | ms/step |"
    );
    println!(
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for row in &r.rows {
        let c = &row.case;
        println!(
            "| {} | {:.0e} | {} | {:.4} | {} | {} | {:.4e} | {:.4e} | {:.4e} | {} | {:.2} / {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.3} |",
            c.name,
            c.young,
            c.poisson,
            c.dt,
            row.steps,
            row.non_finite_steps,
            row.energy_peak_j,
            row.energy_after_j,
            row.energy_end_j,
            if row.bounded { "yes" } else { "NO" },
            row.iterations_mean,
            row.iterations_max,
            row.fallback_steps,
            row.extended_steps,
            row.stiffened_steps,
            row.unconverged_steps,
            row.pin_drift_mm,
            row.max_displacement_m,
            row.step_ms_mean
        );
    }
    println!("{} of {} cases fail a check", r.failures, r.rows.len());
    Ok(())
}

fn run_bench_replay(json: bool) -> crate::Result<()> {
    let r = crate::bench::run_replay_bench(
        crate::demo::DEMO_BAG,
        std::path::Path::new("target/bench"),
        |line| eprintln!("{line}"),
    )?;
    if json {
        crate::cli::print_json(&r);
    } else {
        println!(
            "demo bag replay, output recorded   {:6.1}x real time ({:.2} s simulated in {:.3} s)",
            r.realtime_factor, r.replay_sim_s, r.replay_wall_s
        );
        println!(
            "60 Hz tick, {} points               {:.3} ms without recording, {:.3} ms with: {:+.2} % ({} ticks each)",
            r.points, r.tick_ms_without, r.tick_ms_with, r.record_overhead_pct, r.ticks_per_side
        );
    }
    Ok(())
}

fn run_bench_latency(
    json: bool,
    domain_id: u16,
    rclpy_python: Option<&std::path::Path>,
    refine: Option<String>,
    shards: bool,
) -> crate::Result<()> {
    let r = crate::bench::run_latency_bench(domain_id, rclpy_python, refine, shards, |line| {
        eprintln!("{line}")
    })?;
    if json {
        crate::cli::print_json(&r);
    } else {
        println!(
            "first deformed cloud after a new 10k-point cloud   {:8.1} ms",
            r.latency_10k_ms
        );
        println!(
            "first deformed cloud after a new 100k-point cloud  {:8.1} ms",
            r.latency_100k_ms
        );
        println!(
            "first deformed cloud after a ~6k-point camera scan {:8.1} ms median, {:.1} ms max of {}",
            r.latency_scan_ms,
            r.latency_scan_max_ms,
            r.scan_latencies_ms.len()
        );
        match &r.rclpy {
            Some(p) => println!(
                "the same ~10k cloud, rclpy to rclpy (Fast DDS)     {:8.1} ms first, median {:.1} ms, max {:.1} ms of {}",
                p.first_ms,
                p.median_ms,
                p.max_ms,
                p.latencies_ms.len()
            ),
            None => println!("rclpy case not run (give --rclpy-python)"),
        }
        println!(
            "publish jitter at {} Hz while shapes are inferred   p99 {:.3} ms, max {:.3} ms ({} intervals)",
            r.rate_hz, r.jitter_p99_ms, r.jitter_max_ms, r.jitter_intervals
        );
        println!(
            "receive jitter (DDS delivery included)             p99 {:.3} ms, max {:.3} ms",
            r.receive_jitter_p99_ms, r.receive_jitter_max_ms
        );
    }
    Ok(())
}
