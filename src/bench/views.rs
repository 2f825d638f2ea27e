//! `bench views`: how one camera's view of an object completes from many sides. Fourteen
//! shapes (the bundled sphere, box, creature and rod; three the network and the completion
//! were not tuned on at first: a 0.3 m capsule, a turned ellipsoid, a torus; and seven variants
//! of those kinds, see `variants`) and eleven real objects' meshes from public packages
//! (`benches/meshes`, each scaled to a 0.5 m diagonal) are scanned from six sides at three image
//! sizes (the VGA scans thinned to the node's build cap, as the node reads them); each scan is
//! completed and its solid voxelized against the whole mesh's; every scan again with a depth
//! camera's noise. Geometry only: `bench real` simulates the bundled shapes' scans.

use nalgebra::{Rotation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::geometry::{
    box_mesh, bundled, capsule_mesh, complete_view, load_geometry, scan_points, sdf_mesh,
    view_downsample, Camera, Shape, VoxelGrid,
};
use crate::pipeline::DEFAULT_MAX_BUILD_POINTS;

/// The sides the camera looks from: `bench real`'s two, a low one almost square to a long
/// side, one nearly level, one from above, one from behind.
pub const VIEW_DIRECTIONS: [[f64; 3]; 6] = [
    [1.0, 0.6, 0.8],
    [-0.7, 1.0, 0.5],
    [0.2, -1.0, 0.3],
    [1.0, 0.1, 0.2],
    [0.3, 0.4, 1.0],
    [-1.0, -0.6, 0.6],
];
/// Two small images, and a VGA depth camera's, whose scans are thinned to the build cap first.
const IMAGES: [(usize, usize); 3] = [(160, 120), (240, 180), (640, 480)];
/// The volumes are compared at the inside test's default resolution.
const RESOLUTION: usize = 64;
/// The target: a completed volume within 30 % of the object's.
const VOLUME_TOLERANCE: f64 = 0.3;
/// The noisy scans' depth noise at 1 m, m; it grows with the square of the depth, as a stereo
/// or structured-light camera's does (2 mm at 1 m is a common stereo camera's, at 0.5 m a
/// quarter of it).
const DEPTH_NOISE_AT_1M: f64 = 0.002;

/// The real objects' meshes (see the folder's README), read when the bench runs.
const REAL_MESHES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/meshes");
/// Each real mesh is scaled to this bounding diagonal, m: a graspable object's size.
const REAL_DIAGONAL_M: f64 = 0.5;

/// One scan.
#[derive(Clone, Debug, Serialize)]
pub struct ViewRow {
    /// The shape scanned.
    pub shape: String,
    /// `primitive` (made here, from the kinds the completion fits) or `real` (a public mesh).
    pub kind: &'static str,
    /// The side the camera looks from.
    pub direction: [f64; 3],
    /// Image width and height, pixels.
    pub image: [usize; 2],
    /// The scan's depth noise at 1 m (standard deviation along the ray, m; 0 for a clean scan).
    pub depth_noise_m: f64,
    /// Points in the scan.
    pub points: usize,
    /// `completed`, `two-sided` (not one view: built as it is) or the refusal's reason.
    pub outcome: String,
    /// The completion's prior that placed the centre (empty unless completed).
    pub prior: &'static str,
    /// Completed solid's volume over the mesh's, both voxelized alike (0 unless completed).
    pub volume_ratio: f64,
    /// Intersection over union of the two solids.
    pub overlap: f64,
    /// Distance between the two solids' centroids over the mesh's bounding diagonal.
    pub centroid_offset: f64,
}

/// What `bench views` reports (serialized for `--json`): the clean scans' summary, then the
/// noisy ones'.
#[derive(Clone, Debug, Serialize)]
pub struct ViewsReport {
    /// One row per shape, image size and direction, in that nesting order: the clean scans,
    /// then the same scans with depth noise.
    pub rows: Vec<ViewRow>,
    /// The primitives' clean scans' figures, at the top level of the JSON.
    #[serde(flatten)]
    pub clean: ViewsSummary,
    /// The primitives' noisy scans' figures.
    pub noisy: ViewsSummary,
    /// The real meshes' clean scans' figures.
    pub real: ViewsSummary,
    /// The real meshes' noisy scans' figures.
    pub real_noisy: ViewsSummary,
}

/// How the completed scans of one kind (clean or noisy) compare with their meshes.
#[derive(Clone, Debug, Serialize)]
pub struct ViewsSummary {
    /// The scans' depth noise at 1 m, m.
    pub depth_noise_m: f64,
    /// Scans completed.
    pub completed: usize,
    /// Completed scans whose volume is within 30 % of the mesh's.
    pub within_30_pct: usize,
    /// Mean `overlap` of the completed scans.
    pub mean_overlap: f64,
    /// Largest factor between a completed volume and the mesh's (above or below).
    pub worst_volume_factor: f64,
}

/// Seven more, one of each kind above but the creature and the rod, sized and turned otherwise:
/// a smaller ball, an egg, a ring standing up, a turned cylinder, a turned box, a shorter
/// capsule and a box of other proportions. Added with the ellipsoid and box fits of the
/// completion, to check them on shapes they were not made on.
fn variants() -> Vec<(&'static str, Shape)> {
    let turned = |x, y, z| Rotation3::from_euler_angles(x, y, z).inverse();
    let egg = ellipsoid(Vector3::new(0.08, 0.11, 0.07), (-0.5, 0.4, 1.2));
    let upright_ring = |p: &Vector3<f64>| {
        let ring = (p.x * p.x + p.z * p.z).sqrt() - 0.08;
        (ring * ring + p.y * p.y).sqrt() - 0.025
    };
    let cylinder_turn = turned(0.2, 0.6, -0.3);
    let cylinder = move |p: &Vector3<f64>| {
        let q = cylinder_turn * p;
        let (r, h) = ((q.x * q.x + q.y * q.y).sqrt() - 0.05, q.z.abs() - 0.12);
        r.max(h).min(0.0) + Vector3::new(r.max(0.0), h.max(0.0), 0.0).norm()
    };
    let box_turn = turned(0.4, -0.3, 0.7);
    let turned_box = move |p: &Vector3<f64>| {
        let q = (box_turn * p).abs() - Vector3::new(0.12, 0.08, 0.05);
        q.map(|x| x.max(0.0)).norm() + q.max().min(0.0)
    };
    vec![
        (
            "small ball",
            sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.07, 0.09, 40),
        ),
        ("egg", sdf_mesh(&*egg, 0.14, 48)),
        ("upright ring", sdf_mesh(&upright_ring, 0.13, 48)),
        ("cylinder", sdf_mesh(&cylinder, 0.16, 48)),
        ("turned box", sdf_mesh(&turned_box, 0.16, 48)),
        ("short capsule", capsule_mesh(0.2, 0.05)),
        ("long box", box_mesh(Vector3::new(0.3, 0.2, 0.15))),
    ]
}

/// A signed distance function, m.
type SignedDistance = Box<dyn Fn(&Vector3<f64>) -> f64>;

/// The signed distance (to first order) of an ellipsoid with semi-axes `radii`, turned by the
/// Euler angles `turn`.
fn ellipsoid(radii: Vector3<f64>, turn: (f64, f64, f64)) -> SignedDistance {
    let turned = Rotation3::from_euler_angles(turn.0, turn.1, turn.2).inverse();
    let smallest = radii.min();
    Box::new(move |p| ((turned * p).component_div(&radii).norm() - 1.0) * smallest)
}

/// The shapes scanned, by name.
fn shapes() -> Vec<(&'static str, Shape)> {
    let turned_ellipsoid = ellipsoid(Vector3::new(0.16, 0.09, 0.06), (0.3, 0.2, 0.5));
    let torus = |p: &Vector3<f64>| {
        let ring = (p.x * p.x + p.y * p.y).sqrt() - 0.1;
        (ring * ring + p.z * p.z).sqrt() - 0.04
    };
    let mut shapes: Vec<_> = ["sphere", "box", "creature", "rod"]
        .into_iter()
        .map(|name| (name, bundled(name).expect("bundled")))
        .collect();
    shapes.push(("capsule", capsule_mesh(0.3, 0.04)));
    shapes.push(("ellipsoid", sdf_mesh(&*turned_ellipsoid, 0.2, 48)));
    shapes.push(("torus", sdf_mesh(&torus, 0.16, 48)));
    shapes.extend(variants());
    shapes
}

/// The public meshes in `REAL_MESHES`, by file stem, each centred and scaled to
/// `REAL_DIAGONAL_M`. Errs when the folder or a mesh cannot be read.
fn real_meshes() -> Result<Vec<(String, Shape)>> {
    let unreadable = |reason: String| Error::InvalidParameter {
        name: "benches/meshes",
        reason,
    };
    let mut paths: Vec<_> = std::fs::read_dir(REAL_MESHES)
        .map_err(|e| unreadable(format!("{REAL_MESHES}: {e}")))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("stl" | "ply" | "obj")
            )
        })
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|path| {
            let raw =
                load_geometry(&path).map_err(|e| unreadable(format!("{}: {e}", path.display())))?;
            let mesh = Shape::from_raw(raw)?;
            let (lo, hi) = mesh.bounds();
            let (centre, scale) = ((lo + hi) * 0.5, REAL_DIAGONAL_M / (hi - lo).norm());
            let positions = mesh
                .positions
                .iter()
                .map(|p| (p - centre) * scale)
                .collect();
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
            Ok((
                stem.to_string(),
                Shape::new(positions, None, mesh.triangles.clone())?,
            ))
        })
        .collect()
}

/// Scans every shape from every side at both image sizes and compares each completed solid
/// with the mesh's; `progress` gets a line per shape. Errs when a scan fails or a real mesh
/// cannot be read.
pub fn run_views_bench(mut progress: impl FnMut(&str)) -> Result<ViewsReport> {
    let mut rows = Vec::new();
    let mut noisy_rows = Vec::new();
    // One seed for the whole run: every run draws the same noise.
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    let primitives = shapes()
        .into_iter()
        .map(|(n, s)| (n.to_string(), s, "primitive"));
    let real = real_meshes()?.into_iter().map(|(n, s)| (n, s, "real"));
    for (name, shape, kind) in primitives.chain(real) {
        let truth = VoxelGrid::from_shape(&shape, RESOLUTION, None);
        for (width, height) in IMAGES {
            for direction in VIEW_DIRECTIONS {
                let camera = Camera::looking_at(&shape, direction.into(), 1.5, width, height);
                // Read as the node reads a cloud: at most its build cap of points.
                let points = view_downsample(
                    &scan_points(&shape, &camera)?,
                    &camera.position,
                    DEFAULT_MAX_BUILD_POINTS,
                );
                let noisy = with_depth_noise(&points, &camera.position, &mut rng);
                for (points, noise, out) in [
                    (points, 0.0, &mut rows),
                    (noisy, DEPTH_NOISE_AT_1M, &mut noisy_rows),
                ] {
                    let mut row = compare(&points, &camera.position, &shape, &truth);
                    row.shape = name.clone();
                    row.kind = kind;
                    row.direction = direction;
                    row.image = [width, height];
                    row.depth_noise_m = noise;
                    out.push(row);
                }
            }
        }
        progress(&format!("{name}: scanned"));
    }
    let of = |rows: &[ViewRow], kind: &str, noise| {
        let chosen: Vec<ViewRow> = rows.iter().filter(|r| r.kind == kind).cloned().collect();
        summarize(&chosen, noise)
    };
    let clean = of(&rows, "primitive", 0.0);
    let noisy = of(&noisy_rows, "primitive", DEPTH_NOISE_AT_1M);
    let real = of(&rows, "real", 0.0);
    let real_noisy = of(&noisy_rows, "real", DEPTH_NOISE_AT_1M);
    rows.extend(noisy_rows);
    Ok(ViewsReport {
        rows,
        clean,
        noisy,
        real,
        real_noisy,
    })
}

/// `points` seen from `camera`, each moved along its ray by Gaussian depth noise of
/// `DEPTH_NOISE_AT_1M` times the square of its depth in metres.
fn with_depth_noise(
    points: &[Vector3<f64>],
    camera: &Vector3<f64>,
    rng: &mut ChaCha8Rng,
) -> Vec<Vector3<f64>> {
    let unit = Normal::new(0.0, 1.0).expect("a unit normal distribution");
    points
        .iter()
        .map(|p| {
            let ray = p - camera;
            let depth = ray.norm();
            p + ray / depth * (unit.sample(rng) * DEPTH_NOISE_AT_1M * depth * depth)
        })
        .collect()
}

/// The completion of `points` seen from `viewpoint` against `truth`, the mesh's solid.
fn compare(
    points: &[Vector3<f64>],
    viewpoint: &Vector3<f64>,
    shape: &Shape,
    truth: &VoxelGrid,
) -> ViewRow {
    let mut row = ViewRow {
        shape: String::new(),
        kind: "primitive",
        direction: [0.0; 3],
        image: [0, 0],
        depth_noise_m: 0.0,
        points: points.len(),
        outcome: "completed".into(),
        prior: "",
        volume_ratio: 0.0,
        overlap: 0.0,
        centroid_offset: 0.0,
    };
    let view = match complete_view(points, viewpoint, None) {
        Ok(Some(view)) => view,
        Ok(None) => {
            row.outcome = "two-sided".into();
            return row;
        }
        Err(refused) => {
            row.outcome = refused.to_string();
            return row;
        }
    };
    row.prior = view.report.prior.name();
    let as_shape = |p: &[Vector3<f64>]| Shape::new(p.to_vec(), None, Vec::new());
    let (Ok(solid), Ok(surface)) = (as_shape(&view.solid), as_shape(&view.surface)) else {
        row.outcome = "the completed cloud is not a shape".into();
        return row;
    };
    let mut grid = VoxelGrid::from_filled_cloud(&solid, &surface, RESOLUTION, &view.centre);
    grid.keep_largest_component();
    let (lo, hi) = shape.bounds();
    row.volume_ratio = solid_volume(&grid) / solid_volume(truth);
    row.overlap = overlap(truth, &grid);
    row.centroid_offset =
        (grid.solid_centroid() - truth.solid_centroid()).norm() / (hi - lo).norm();
    row
}

/// Whole cells only: both grids are compared cell by cell.
fn solid_volume(grid: &VoxelGrid) -> f64 {
    grid.solid_count() as f64 * grid.cell.powi(3)
}

/// Intersection over union, the intersection counted on `truth`'s cells.
fn overlap(truth: &VoxelGrid, other: &VoxelGrid) -> f64 {
    let shared = (0..truth.len())
        .filter(|&i| truth.solid[i] && other.contains(&truth.cell_center(truth.coords(i))))
        .count() as f64
        * truth.cell.powi(3);
    shared / (solid_volume(truth) + solid_volume(other) - shared)
}

fn summarize(rows: &[ViewRow], depth_noise_m: f64) -> ViewsSummary {
    let done: Vec<&ViewRow> = rows.iter().filter(|r| r.outcome == "completed").collect();
    let within = done
        .iter()
        .filter(|r| (r.volume_ratio - 1.0).abs() <= VOLUME_TOLERANCE)
        .count();
    let mean_overlap = done.iter().map(|r| r.overlap).sum::<f64>() / done.len().max(1) as f64;
    let worst = done
        .iter()
        .map(|r| r.volume_ratio.max(1.0 / r.volume_ratio))
        .fold(1.0, f64::max);
    ViewsSummary {
        depth_noise_m,
        completed: done.len(),
        within_30_pct: within,
        mean_overlap,
        worst_volume_factor: worst,
    }
}
