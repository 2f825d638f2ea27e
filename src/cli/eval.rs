//! `physskin eval`: the learned fields on shapes the model never saw.

use std::path::PathBuf;
use std::sync::Arc;

use crate::bench::{evaluate_fields, EvalOptions, EvalReport};
use crate::geometry::{bundled, load_geometry, Shape};
use crate::skinning::{NeuralModel, RefineBudget, RefineOptions};
use crate::training::{dataset, TrainingConfig};
use crate::{Error, Result};

#[derive(clap::Args)]
pub struct EvalArgs {
    /// A directory of meshes or clouds (OBJ, STL, PLY). Without it, the held-out split of the
    /// generated training shapes and the bench's bundled plate, rod and creature.
    dir: Option<PathBuf>,
    /// How many held-out shapes (without DIR).
    #[arg(long, default_value_t = 12)]
    held_out: usize,
    /// A model file instead of the bundled one.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Metrics and timing only, no simulation against the FEM.
    #[arg(long)]
    no_sim: bool,
    /// FEM grid cells across the longest side.
    #[arg(long, default_value_t = 24)]
    resolution: usize,
    #[arg(long, default_value_t = 40)]
    steps: usize,
    /// How long the network's field is refined toward the eigenmodes: milliseconds, `off` or
    /// `full` (until the eigenmodes' span).
    #[arg(long, default_value = "60")]
    refine: RefineBudget,
    #[arg(long)]
    json: bool,
}

pub fn run(args: EvalArgs) -> Result<()> {
    let model = match &args.model {
        Some(path) => Arc::new(NeuralModel::load(path)?),
        None => NeuralModel::bundled()?,
    };
    let shapes = match &args.dir {
        Some(dir) => shapes_in(dir)?,
        None => {
            let (_, held_out) = dataset(&TrainingConfig::shipped().dataset());
            let mut shapes: Vec<(String, Shape)> = held_out
                .iter()
                .take(args.held_out)
                .map(|s| (s.name.clone(), s.mesh(96)))
                .collect();
            for name in ["plate", "rod", "creature"] {
                shapes.push((name.to_string(), bundled(name).expect("a bundled shape")));
            }
            shapes
        }
    };
    let options = EvalOptions {
        simulate: !args.no_sim,
        resolution: args.resolution,
        steps: args.steps,
        refine: RefineOptions {
            budget: args.refine,
            ..Default::default()
        },
        ..Default::default()
    };
    let report = evaluate_fields(&model, &shapes, &options, |line| eprintln!("{line}"))?;
    if args.json {
        super::print_json(&report);
    } else {
        print_table(&report);
    }
    Ok(())
}

fn shapes_in(dir: &PathBuf) -> Result<Vec<(String, Shape)>> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Io {
        path: dir.clone(),
        source,
    })?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "obj" | "stl" | "ply"))
        })
        .collect();
    paths.sort();
    if paths.is_empty() {
        return Err(Error::Geometry(format!(
            "no .obj, .stl or .ply files in {}",
            dir.display()
        )));
    }
    paths
        .iter()
        .map(|path| {
            let name = path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("shape")
                .to_string();
            Ok((name, Shape::from_raw(load_geometry(path)?)?))
        })
        .collect()
}

fn print_table(report: &EvalReport) {
    println!(
        "{:<16} {:>6} {:>11} {:>9} {:>8} {:>11} {:>9} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9}",
        "shape",
        "points",
        "omega_x100",
        "kappa_log",
        "h_spec",
        "whitened_x100",
        "infer_ms",
        "100k_ms",
        "learn_%",
        "eigen_%",
        "ratio",
        "refined_%",
        "refine_ms"
    );
    for r in &report.shapes {
        println!(
            "{:<16} {:>6} {:>11.5} {:>9.4} {:>8.5} {:>11.5} {:>9.1} {:>8.1} {:>8.3} {:>8.3} {:>8.3} {:>9.3} {:>9.1}",
            r.name,
            r.points,
            r.omega_orth * 100.0,
            r.kappa_log,
            r.h_spec,
            r.whitened.omega_orth * 100.0,
            r.infer_ms,
            r.decode_100k_ms,
            r.sim_error_pct,
            r.eigen_error_pct,
            r.sim_error_pct / r.eigen_error_pct,
            r.refined_error_pct,
            r.refine_ms
        );
    }
    let m = &report.mean;
    println!(
        "{:<16} {:>6} {:>11.5} {:>9.4} {:>8.5} {:>11.5} {:>9.1} {:>8.1} {:>8.3} {:>8.3} {:>8.3} {:>9.3} {:>9.1}",
        "mean",
        "",
        m.omega_orth * 100.0,
        m.kappa_log,
        m.h_spec,
        m.whitened_omega_orth * 100.0,
        m.infer_ms,
        m.decode_100k_ms,
        m.sim_error_pct,
        m.eigen_error_pct,
        m.error_ratio,
        m.refined_error_pct,
        m.refine_ms
    );
    println!(
        "refined / eigenmodes: mean {:.3}, worst {:.3}; a new shape's basis in {:.1} ms",
        m.refined_error_ratio, m.refined_error_ratio_max, m.build_ms
    );
    println!(
        "whitened (the product's weights): kappa_log {:.4}, h_spec {:.5}",
        m.whitened_kappa_log, m.whitened_h_spec
    );
    let (s, f) = (&m.static_error_pct, &m.frequency_ratio);
    println!(
        "hanging, solved statically, against the FEM: error learned {:.3} %, eigenmodes {:.3} %, \
         refined {:.3} %; lowest frequency x{:.3}, x{:.3}, x{:.3}",
        s.learned, s.eigen, s.refined, f.learned, f.eigen, f.refined
    );
}
