//! Running a scene for a while, timed, with its error against the full-space FEM; and the
//! bench that asks what a scene's decisions (model sizes from an error budget, sleeping) save:
//! the objects that act alone, the full scene with the decisions, and without them.

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::scene::{
    reference_errors, FieldCache, ObjectError, ObjectReport, Recorder, Scene, SceneFile,
    SceneOptions,
};
use crate::skinning::NeuralModel;
use crate::Result;

/// The bundled scene.
pub const WORKCELL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/config/scenes/workcell.yaml");
/// The objects of the bundled scene that the robot moves.
pub const WORKCELL_ACTIVE: [&str; 2] = ["sponge", "column"];

/// How a scene is run.
#[derive(Clone, Debug)]
pub struct SceneRunOptions {
    /// How the scene is built: decisions, which objects, scripted robots.
    pub scene: SceneOptions,
    /// Simulated seconds of motion after settling.
    pub seconds: f64,
    /// Before the motion, objects settle under gravity with the robots still: until all sleep
    /// (at most this many steps), or exactly this many when `settle_exactly`.
    pub settle_steps: usize,
    /// Settle exactly `settle_steps` steps, even once every object sleeps.
    pub settle_exactly: bool,
    /// Objects compared with the FEM (none: no reference run).
    pub compare: Vec<String>,
}

/// What a run did.
#[derive(Clone, Debug, Serialize)]
pub struct SceneRun {
    /// Each built object's state at the end of the run.
    pub objects: Vec<ObjectReport>,
    /// Building the scene, inference included, ms.
    pub build_ms: f64,
    /// Skinning fields inferred in this run (geometry the cache had not seen).
    pub inferences: usize,
    /// Fields the cache gave in this run instead of an inference.
    pub inferences_reused: usize,
    /// Settling steps taken.
    pub settle_steps: usize,
    /// Steps of motion timed: `seconds` at the scene's rate, rounded.
    pub steps: usize,
    /// Wall time of one scene step (robots, colliders, every awake object), ms.
    pub step_ms: f64,
    /// 99th percentile of the scene step, ms.
    pub step_ms_p99: f64,
    /// Deformable objects awake, averaged over the steps.
    pub awake_mean: f64,
    /// Objects with a simulated body (more than 0 handles).
    pub deformable: usize,
    /// Each compared object's error against its FEM; empty when none was compared.
    pub errors: Vec<ObjectError>,
}

impl SceneRun {
    /// The largest error among the objects named, %.
    pub fn error_of(&self, names: &[&str]) -> f64 {
        self.errors
            .iter()
            .filter(|e| names.contains(&e.name.as_str()))
            .map(|e| e.error_pct)
            .fold(f64::NAN, f64::max)
    }
}

/// Builds `file`'s scene, settles it, steps it for `options.seconds`, timing each
/// step, and measures the objects in `options.compare` against their FEM. Errs when
/// the scene does not build, a compared object is missing or not deformable, or an
/// FEM run fails.
pub fn run_scene(
    file: &SceneFile,
    model: &Arc<NeuralModel>,
    cache: &FieldCache,
    options: &SceneRunOptions,
) -> Result<SceneRun> {
    use std::sync::atomic::Ordering::Relaxed;
    let (hits, misses) = (cache.hits.load(Relaxed), cache.misses.load(Relaxed));
    let started = Instant::now();
    let mut scene = Scene::build(file, model, cache, &options.scene)?;
    let build_ms = started.elapsed().as_secs_f64() * 1e3;
    let mut recorder = Recorder::new(&scene, &options.compare)?;
    let mut settle_steps = 0;
    while settle_steps < options.settle_steps {
        if !options.settle_exactly && scene.awake() == 0 {
            break;
        }
        scene.settle(1);
        recorder.record(&scene, false);
        settle_steps += 1;
    }
    let steps = (options.seconds * file.rate_hz).round() as usize;
    let mut times = Vec::with_capacity(steps);
    let mut awake = 0usize;
    for _ in 0..steps {
        let t = Instant::now();
        scene.step();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        awake += scene.awake();
        recorder.record(&scene, true);
    }
    let errors = if options.compare.is_empty() {
        Vec::new()
    } else {
        reference_errors(&recorder)?
    };
    let objects = scene.report();
    let mean = times.iter().sum::<f64>() / times.len().max(1) as f64;
    times.sort_by(f64::total_cmp);
    Ok(SceneRun {
        deformable: objects.iter().filter(|o| o.handles > 0).count(),
        objects,
        build_ms,
        inferences: cache.misses.load(Relaxed) - misses,
        inferences_reused: cache.hits.load(Relaxed) - hits,
        settle_steps,
        steps,
        step_ms: mean,
        step_ms_p99: times
            .get((times.len() * 99) / 100)
            .copied()
            .unwrap_or(f64::NAN),
        awake_mean: awake as f64 / steps.max(1) as f64,
        errors,
    })
}

/// `bench scene`: the bundled scene three ways.
#[derive(Clone, Debug, Serialize)]
pub struct SceneBenchReport {
    /// Mean step with only the active objects built, ms.
    pub active_alone_step_ms: f64,
    /// Mean step of the full scene with the decisions, ms.
    pub full_scene_step_ms: f64,
    /// Largest error of the active objects against the FEM when alone, % of
    /// their bounding diagonal.
    pub active_alone_error_pct: f64,
    /// The same in the full scene with the decisions, %.
    pub full_scene_error_pct: f64,
    /// full_scene_step_ms / active_alone_step_ms (target 1.3 or less).
    pub step_ratio: f64,
    /// Mean step of the full scene without the decisions (every deformable object with
    /// all handles and 256 cubature points unless the file fixes its size, none
    /// sleeping), ms.
    pub no_decisions_step_ms: f64,
    /// Largest error of the active objects in that run, %.
    pub no_decisions_error_pct: f64,
    /// The largest error of the objects that sat still, with the decisions (they sleep).
    pub idle_error_pct: f64,
    /// The same without the decisions, %.
    pub idle_error_pct_no_decisions: f64,
    /// The objects the robot moves ([`WORKCELL_ACTIVE`]).
    pub active: Vec<String>,
    /// The run with the active objects alone.
    pub active_alone: SceneRun,
    /// The run of the full scene with the decisions.
    pub full_scene: SceneRun,
    /// The run of the full scene without the decisions.
    pub no_decisions: SceneRun,
}

/// Settling lasts at most 8 s: every object of the bundled scene sleeps well before.
const SETTLE_STEPS: usize = 480;

/// Runs the bundled scene ([`WORKCELL`]) three ways, `seconds` of motion each: in
/// full with the decisions, its active objects alone, and in full without the
/// decisions (these two settle as many steps as the first); each run compares the
/// deformable objects it built with their FEM. Errs when the scene file does not
/// load or a run fails.
pub fn run_scene_bench(seconds: f64, log: impl Fn(&str)) -> Result<SceneBenchReport> {
    let file = SceneFile::load(std::path::Path::new(WORKCELL))?;
    let model = NeuralModel::bundled()?;
    let cache = FieldCache::default();
    let active: Vec<String> = WORKCELL_ACTIVE.iter().map(|s| s.to_string()).collect();
    let every: Vec<String> = file
        .objects
        .iter()
        .filter(|o| o.kind == crate::scene::ObjectKind::Deformable)
        .map(|o| o.name.clone())
        .collect();
    let run = |scene: SceneOptions, compare: &[String], settle: usize, exactly: bool| {
        run_scene(
            &file,
            &model,
            &cache,
            &SceneRunOptions {
                scene,
                seconds,
                settle_steps: settle,
                settle_exactly: exactly,
                compare: compare.to_vec(),
            },
        )
    };
    log("full scene with decisions (sizes from the error budget, sleeping) ...");
    let full_scene = run(SceneOptions::default(), &every, SETTLE_STEPS, false)?;
    let settle = full_scene.settle_steps;
    log(&format!(
        "  settled in {settle} steps; {:.3} ms a step; now the active objects alone ...",
        full_scene.step_ms
    ));
    let active_alone = run(
        SceneOptions {
            decisions: true,
            only: active.clone(),
            scripted: true,
            ..SceneOptions::default()
        },
        &active,
        settle,
        true,
    )?;
    log(&format!(
        "  {:.3} ms a step; now the full scene without decisions ...",
        active_alone.step_ms
    ));
    let no_decisions = run(
        SceneOptions {
            decisions: false,
            only: Vec::new(),
            scripted: true,
            ..SceneOptions::default()
        },
        &every,
        settle,
        true,
    )?;
    let names: Vec<&str> = active.iter().map(|s| s.as_str()).collect();
    let idle: Vec<&str> = every
        .iter()
        .map(|s| s.as_str())
        .filter(|n| !names.contains(n))
        .collect();
    Ok(SceneBenchReport {
        active_alone_step_ms: active_alone.step_ms,
        full_scene_step_ms: full_scene.step_ms,
        active_alone_error_pct: active_alone.error_of(&names),
        full_scene_error_pct: full_scene.error_of(&names),
        step_ratio: full_scene.step_ms / active_alone.step_ms,
        no_decisions_step_ms: no_decisions.step_ms,
        no_decisions_error_pct: no_decisions.error_of(&names),
        idle_error_pct: full_scene.error_of(&idle),
        idle_error_pct_no_decisions: no_decisions.error_of(&idle),
        active,
        active_alone,
        full_scene,
        no_decisions,
    })
}
