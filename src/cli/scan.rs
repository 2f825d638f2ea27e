//! `physskin scan`: one depth camera's view of a mesh (the visible side only, a z-buffer), as a
//! PLY cloud, for trying `simulate --input ... --viewpoint ...` and `infer --viewpoint` on what a
//! robot's camera would see.

use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

use crate::geometry::{
    bundled, load_geometry, scan_points, write_obj, write_ply, Camera, RawGeometry, Shape,
};
use crate::{Error, Result};
use nalgebra::Vector3;

#[derive(clap::Args)]
pub struct ScanArgs {
    /// The mesh to scan (OBJ, STL, PLY).
    #[arg(long, conflicts_with = "shape", required_unless_present = "shape")]
    input: Option<PathBuf>,
    /// A bundled shape to scan instead: plate, rod, creature, box, sphere.
    #[arg(long)]
    shape: Option<String>,
    /// The cloud to write (PLY).
    #[arg(long, default_value = "scan.ply")]
    out: PathBuf,
    /// Also write the whole mesh here (OBJ), the reference for `simulate --reference`.
    #[arg(long)]
    mesh_out: Option<PathBuf>,
    /// The side the camera looks from, x,y,z (from the object's centre).
    #[arg(long, default_value = "1,0.6,0.8", allow_hyphen_values = true)]
    direction: String,
    /// Distance from the object's centre in bounding diagonals.
    #[arg(long, default_value_t = 1.5)]
    diagonals: f64,
    #[arg(long, default_value_t = 160)]
    width: usize,
    #[arg(long, default_value_t = 120)]
    height: usize,
}

pub fn run(args: ScanArgs) -> Result<()> {
    let shape = match (&args.input, &args.shape) {
        (Some(path), _) => Shape::from_raw(load_geometry(path)?)?,
        (None, Some(name)) => bundled(name).ok_or_else(|| Error::InvalidParameter {
            name: "shape",
            reason: format!("unknown shape {name:?} (plate, rod, creature, box, sphere)"),
        })?,
        (None, None) => unreachable!("clap requires --input or --shape"),
    };
    let direction = super::simulate::parse_point(&args.direction).map_err(|reason| {
        Error::InvalidParameter {
            name: "direction",
            reason,
        }
    })?;
    let camera = Camera::looking_at(&shape, direction, args.diagonals, args.width, args.height);
    let points = scan_points(&shape, &camera)?;
    let raw = |positions: &[Vector3<f64>], triangles: Vec<[u32; 3]>| RawGeometry {
        positions: positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
        normals: None,
        triangles,
    };
    let create = |path: &PathBuf| {
        File::create(path)
            .map(BufWriter::new)
            .map_err(|e| Error::Geometry(format!("{}: {e}", path.display())))
    };
    let write_error =
        |path: &PathBuf, e: std::io::Error| Error::Geometry(format!("{}: {e}", path.display()));
    write_ply(&raw(&points, Vec::new()), &[], &mut create(&args.out)?)
        .map_err(|e| write_error(&args.out, e))?;
    if let Some(path) = &args.mesh_out {
        write_obj(
            &raw(&shape.positions, shape.triangles.clone()),
            &mut create(path)?,
        )
        .map_err(|e| write_error(path, e))?;
    }
    let v = camera.position;
    eprintln!(
        "{} points seen of {} pixels, written to {}",
        points.len(),
        args.width * args.height,
        args.out.display()
    );
    println!("{},{},{}", v.x, v.y, v.z);
    Ok(())
}
