//! `physskin infer`: skinning weights of a mesh or cloud file in one forward pass.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::bench::prepare_input;
use crate::geometry::{
    complete_view, load_geometry, write_ply, RawGeometry, Shape, SurfaceSamples,
};
use crate::io::{render_field_png, write_npy_f32};
use crate::skinning::{NeuralModel, SkinningField};
use crate::{Error, Result};

#[derive(clap::Args)]
pub struct InferArgs {
    /// A mesh or point cloud: OBJ, STL or PLY.
    input: PathBuf,
    /// Weights at the input's points: .ply (positions plus one float property per handle,
    /// weight_0 .. weight_K) or .npy (points x handles, float32). Not written when absent.
    #[arg(long)]
    out: Option<PathBuf>,
    /// A picture of the blended field (three views). Not drawn when absent.
    #[arg(long)]
    png: Option<PathBuf>,
    /// A model file instead of the bundled one.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Where a cloud was seen from, x,y,z in the file's coordinates: the cloud is one camera's
    /// view, completed before inference (its hidden side is estimated); weights are still
    /// written for the input's points only.
    #[arg(long, value_parser = super::simulate::parse_point, allow_hyphen_values = true)]
    viewpoint: Option<nalgebra::Vector3<f64>>,
}

pub fn run(args: InferArgs) -> Result<()> {
    let model = match &args.model {
        Some(path) => Arc::new(NeuralModel::load(path)?),
        None => NeuralModel::bundled()?,
    };
    let raw = load_geometry(&args.input)?;
    let shape = Shape::from_raw(raw.clone())?;
    shape.check_solid()?;
    let prepare_started = Instant::now();
    let seen = completed(&shape, args.viewpoint.as_ref())?;
    let map = seen.normalization();
    let input = prepare_input(&seen, 4096, 4096);
    let prepare_ms = prepare_started.elapsed().as_secs_f64() * 1e3;

    let started = Instant::now();
    let field = model.field(&input.surface, &input.reference, map)?;
    let points: Vec<_> = shape
        .positions
        .iter()
        .map(|p| map.to_normalized(p))
        .collect();
    let handles = field.handle_count();
    let mut weights = vec![0.0; points.len() * handles];
    field.evaluate(&points, &mut weights, None);
    let infer_ms = started.elapsed().as_secs_f64() * 1e3;

    if let Some(path) = &args.out {
        write_weights(path, &raw, &weights, handles)?;
    }
    if let Some(path) = &args.png {
        draw_field(path, &input.surface, &field, handles)?;
    }
    println!(
        "{}: {} points, {} handles (constant + {} learned); sampling {:.1} ms, inference {:.1} ms",
        args.input.display(),
        points.len(),
        handles,
        handles - 1,
        prepare_ms,
        infer_ms
    );
    match (&args.out, &args.png) {
        (None, None) => {
            println!("nothing written: --out FILE (.ply or .npy) and --png FILE say where")
        }
        (out, png) => {
            for (what, path) in [("weights", out), ("picture", png)] {
                if let Some(path) = path {
                    println!("{what}: {}", path.display());
                }
            }
        }
    }
    Ok(())
}

/// The blended field on the network's surface samples, three views.
fn draw_field(
    path: &Path,
    surface: &SurfaceSamples,
    field: &dyn SkinningField,
    handles: usize,
) -> Result<()> {
    let mut weights = vec![0.0; surface.points.len() * handles];
    field.evaluate(&surface.points, &mut weights, None);
    render_field_png(
        &surface.points,
        Some(&surface.normals),
        &weights,
        handles,
        360,
        &mut BufWriter::new(create(path)?),
    )
    .map_err(|e| Error::Geometry(e.to_string()))
}

fn create(path: &Path) -> Result<File> {
    File::create(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn write_weights(path: &Path, raw: &RawGeometry, weights: &[f64], handles: usize) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut out = BufWriter::new(create(path)?);
    let is_npy = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"));
    if is_npy {
        let flat: Vec<f32> = weights.iter().map(|w| *w as f32).collect();
        return write_npy_f32(&mut out, &[weights.len() / handles, handles], &flat).map_err(io);
    }
    let columns: Vec<Vec<f32>> = (0..handles)
        .map(|h| {
            weights
                .chunks_exact(handles)
                .map(|row| row[h] as f32)
                .collect()
        })
        .collect();
    let names: Vec<String> = (0..handles).map(|h| format!("weight_{h}")).collect();
    let extra: Vec<(&str, &[f32])> = names
        .iter()
        .map(String::as_str)
        .zip(columns.iter().map(Vec::as_slice))
        .collect();
    write_ply(raw, &extra, &mut out).map_err(io)
}

/// The shape the network reads: a cloud seen from `viewpoint` completed to a closed surface
/// (when it is one view), or the input itself.
fn completed(shape: &Shape, viewpoint: Option<&nalgebra::Vector3<f64>>) -> Result<Shape> {
    let Some(viewpoint) = viewpoint.filter(|_| shape.is_point_cloud()) else {
        return Ok(shape.clone());
    };
    match complete_view(&shape.positions, viewpoint, None)
        .map_err(|e| Error::Geometry(e.to_string()))?
    {
        Some(view) => {
            eprintln!(
                "completed one view ({}): observed {:.1} % of the surface",
                view.report.method,
                100.0 * view.report.observed_fraction
            );
            Shape::new(view.surface, None, Vec::new())
        }
        None => Ok(shape.clone()),
    }
}
