//! `bench track`: a soft object watched by one depth camera at 30 Hz, against the full-space FEM
//! as the truth. The FEM runs each sequence (a ball poked, rolled and dropped, a block squeezed,
//! poked while the view is blocked for 0.5 s, and left at rest) with forces the node never hears
//! of; a z-buffer camera scans the FEM's surface every other step, with a depth camera's noise,
//! and the poker's rod hides what lies behind it. Each pixel's surface triangle is known, so every
//! observed point is a material point whose true place the FEM gives at every step. Given a
//! Python that imports mujoco, MuJoCo's soft block runs four sequences more, its paddles in
//! front of the camera (`track_peer`).
//!
//! Three modes per sequence: the object rebuilt from every frame (the node before tracking),
//! built once from the first frame and simulated without correction, and tracked (built once,
//! corrected by every frame, `pipeline::Tracker`).

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::error::Result;
use crate::geometry::{box_mesh, scan_faces, Camera, PointIndex, Shape};
use crate::pipeline::{build_seen, strided, SoftBody, Support, Tracker, TrackingOptions};
use crate::runtime::{NodeParams, REPLAY_REFINE};
use crate::skinning::NeuralModel;

use super::stats::{median, quantile};
use super::track_peer::run_mujoco_truth;
use super::track_report::spread_over_seeds;
pub use super::track_report::{TrackReport, TrackRow, TrackSpread};
use super::track_sequences::{sequences, Sequence, Source};
use super::track_truth::{run_truth, SubspaceFit, Truth};

/// Steps per frame: the simulation at 60 Hz, the camera at 30.
const STEPS_PER_FRAME: usize = 2;
/// Depth noise at 1 m, m, growing with the square of the depth (as `bench views`).
const DEPTH_NOISE_AT_1M: f64 = 0.002;
/// The camera's image.
const IMAGE: (usize, usize) = (160, 120);
/// Observed points a frame is thinned to before matching (the node's `tracking.max_points`).
const OBSERVED_POINTS: usize = 2000;

/// One frame: noisy points, where each truly lies (surface triangle, barycentrics).
struct Frame {
    points: Vec<Vector3<f64>>,
    material: Vec<(usize, [f64; 3])>,
    clean: Vec<Vector3<f64>>,
}

/// Which sequences and modes `run_track_bench` runs.
#[derive(Clone, Debug)]
pub struct TrackBenchOptions {
    /// Each sequence's length, s.
    pub seconds: f64,
    /// How observations correct the tracked body.
    pub tracking: TrackingOptions,
    /// Sequences whose name contains one of these (empty: all).
    pub sequences: Vec<String>,
    /// Modes run (empty: rebuild, uncorrected, tracked).
    pub modes: Vec<String>,
    /// Write the first sequence's frames here as a recording a replay tracks (see
    /// `write_stream`).
    pub write_stream: Option<std::path::PathBuf>,
    /// A Python that imports mujoco: MuJoCo's sequences run too (see `track_peer`).
    pub python: Option<std::path::PathBuf>,
    /// Direction from the object toward the camera (any length; see `DEFAULT_VIEW`).
    pub view: Vector3<f64>,
    /// Seeds of the camera's noise: each sequence runs once per seed (see `DEFAULT_SEED`).
    pub seeds: Vec<u64>,
}

/// The noise's seed by default. One seed's rows hang on it: a camera moved by a rounding moved
/// a row by 61 % (docs/tracking.md); several seeds give each row's spread.
pub const DEFAULT_SEED: u64 = 7;

/// The camera's side by default: in front, to the side and above, as a robot's head camera.
/// A gain of the tracker measured from one side alone has hung on that side before (see
/// docs/tracking.md): `--view` measures it from another.
pub const DEFAULT_VIEW: [f64; 3] = [1.0, 0.6, 0.8];

/// Runs the chosen sequences in the chosen modes.
pub fn run_track_bench(
    options: &TrackBenchOptions,
    progress: impl Fn(&str),
) -> Result<TrackReport> {
    let seconds = options.seconds;
    let view = options
        .view
        .try_normalize(1e-9)
        .filter(|v| v.iter().all(|c| c.is_finite()))
        .ok_or_else(|| crate::Error::InvalidParameter {
            name: "view",
            reason: format!("{:?} gives no direction toward the camera", options.view),
        })?;
    let wanted = |list: &[String], name: &str| {
        list.is_empty() || list.iter().any(|w| name.contains(w.as_str()))
    };
    let model = Arc::new(NeuralModel::bundled()?);
    let mut params = NodeParams::default();
    params.simulation.support = Support::Floor;
    params.fixed_frame = "world".into();
    params.floor_z = 0.0;
    let (mut rows, mut floor, mut mujoco_version) = (Vec::new(), Vec::new(), None);
    for sequence in sequences(seconds, options.python.is_some())
        .into_iter()
        .filter(|s| wanted(&options.sequences, s.name))
    {
        progress(&format!("{}: the truth's run", sequence.name));
        let truth = match &sequence.source {
            Source::Fem {
                shape,
                lifted,
                pokes,
            } => run_truth(shape, *lifted, pokes, &params, seconds)?,
            Source::Mujoco(scenario) => {
                let python = options
                    .python
                    .as_deref()
                    .expect("MuJoCo's sequences need it");
                let (truth, version) = run_mujoco_truth(python, scenario, &params, seconds)?;
                mujoco_version = Some(version);
                truth
            }
        };
        // The direction as given: the camera normalizes it, and a second rounding moved the
        // default view's rows (the poked ball 0.2893 -> 0.2747 %, printed).
        let camera = camera_for(&truth, &options.view);
        for &seed in &options.seeds {
            let frames = scan_frames(&sequence, &truth, &camera, seconds, seed)?;
            if let Some(path) = options.write_stream.as_ref().filter(|_| rows.is_empty()) {
                write_stream(path, &frames, &camera, params.sim_params().dt)?;
                progress(&format!(
                    "{}: its frames written to {}",
                    sequence.name,
                    path.display()
                ));
            }
            add_observation_errors(&frames, &truth, &mut floor);
            for mode in ["rebuild", "uncorrected", "tracked"]
                .into_iter()
                .filter(|m| wanted(&options.modes, m))
            {
                progress(&format!("{}: {mode}, seed {seed}", sequence.name));
                let run = Run {
                    truth: &truth,
                    frames: &frames,
                    camera: &camera,
                    model: &model,
                    params: &params,
                    options: &options.tracking,
                    seed,
                };
                rows.push(run.mode(&sequence, mode)?);
            }
        }
    }
    let observation_floor_pct =
        100.0 * (floor.iter().sum::<f64>() / floor.len().max(1) as f64).sqrt();
    let spread = if options.seeds.len() > 1 {
        spread_over_seeds(&rows)
    } else {
        Vec::new()
    };
    Ok(TrackReport {
        observation_floor_pct,
        rows,
        mujoco_version,
        camera_direction: [view.x, view.y, view.z],
        spread,
    })
}

/// Adds each observed point's squared error against its true place (a fraction of the
/// diagonal) to `floor`.
fn add_observation_errors(frames: &[Option<Frame>], truth: &Truth, floor: &mut Vec<f64>) {
    for (k, f) in frames
        .iter()
        .enumerate()
        .filter_map(|(k, f)| Some((k, f.as_ref()?)))
    {
        for (p, m) in f.points.iter().zip(&f.material) {
            floor.push(((p - truth.at(k, *m)).norm() / truth.diagonal).powi(2));
        }
    }
}

/// A camera 1.5 diagonals away along `view` from the object's first pose.
fn camera_for(truth: &Truth, view: &Vector3<f64>) -> Camera {
    let points: Vec<Vector3<f64>> = truth.positions[0].clone();
    let shape = Shape::new(points, None, truth.surface.clone()).expect("the FEM's surface");
    Camera::looking_at(&shape, *view, 1.5, IMAGE.0, IMAGE.1)
}

/// The camera's frames, its noise drawn from `seed`: one every `STEPS_PER_FRAME` steps (None
/// between them and while the view is blocked).
fn scan_frames(
    sequence: &Sequence,
    truth: &Truth,
    camera: &Camera,
    seconds: f64,
    seed: u64,
) -> Result<Vec<Option<Frame>>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let unit = Normal::new(0.0, 1.0).expect("a unit normal distribution");
    let dt = seconds / (truth.positions.len() - 1) as f64;
    let mut frames = Vec::with_capacity(truth.positions.len());
    let box_faces = box_mesh(Vector3::repeat(1.0)).triangles;
    for (step, positions) in truth.positions.iter().enumerate() {
        let t = step as f64 * dt;
        let blocked = sequence.blocked.is_some_and(|(a, b)| t >= a && t < b);
        if step % STEPS_PER_FRAME != 0 || blocked {
            frames.push(None);
            continue;
        }
        let (mut vertices, mut triangles) = (positions.clone(), truth.surface.clone());
        let faces = triangles.len();
        for corners in &truth.occluders[step] {
            let base = vertices.len() as u32;
            vertices.extend_from_slice(corners);
            triangles.extend(box_faces.iter().map(|f| f.map(|i| base + i)));
        }
        let mut frame = Frame {
            points: Vec::new(),
            material: Vec::new(),
            clean: Vec::new(),
        };
        for (hit, face) in scan_faces(&vertices, &triangles, camera)?
            .into_iter()
            .flatten()
        {
            if face >= faces {
                continue; // the poker: segmented out, as a labelled camera would
            }
            let tri = truth.surface[face].map(|i| positions[i as usize]);
            let ray = hit - camera.position;
            let depth = ray.norm();
            let noise = unit.sample(&mut rng) * DEPTH_NOISE_AT_1M * depth * depth;
            frame.points.push(hit + ray / depth * noise);
            frame.material.push((face, barycentric(&hit, &tri)));
            frame.clean.push(hit);
        }
        frames.push(Some(frame));
    }
    Ok(frames)
}

/// The barycentric coordinates of `p` in triangle `t`.
fn barycentric(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> [f64; 3] {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], p - t[0]);
    let (a, b, c) = (e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
    let (x, y) = (d.dot(&e1), d.dot(&e2));
    let det = (a * c - b * b).max(1e-30);
    let v = (c * x - b * y) / det;
    let w = (a * y - b * x) / det;
    [1.0 - v - w, v, w]
}

/// One mode's run over one sequence.
struct Run<'a> {
    truth: &'a Truth,
    frames: &'a [Option<Frame>],
    camera: &'a Camera,
    model: &'a Arc<NeuralModel>,
    params: &'a NodeParams,
    options: &'a TrackingOptions,
    /// The seed of the frames' noise, for the row.
    seed: u64,
}

/// A body and what its points are: the material points of the frame it was built from, and
/// the surface the camera had not seen then.
struct Tracked {
    body: SoftBody,
    material: Vec<(usize, [f64; 3])>,
    hidden: Vec<usize>,
    hidden_lifter: crate::physics::Lifter,
    surface_lifter: crate::physics::Lifter,
    /// The subspace's best fit to the material points (tracked mode only: it costs).
    fit: Option<SubspaceFit>,
}

impl Run<'_> {
    fn mode(&self, sequence: &Sequence, mode: &str) -> Result<TrackRow> {
        let seconds = (self.truth.positions.len() - 1) as f64 * self.params.sim_params().dt;
        let (mut builds, mut cpu) = (0, 0.0);
        let mut tracked: Option<(Tracked, Tracker)> = None;
        let (mut seen, mut hidden, mut chamfer, mut blocked) = (vec![], vec![], vec![], vec![]);
        let mut fitted = vec![];
        let (mut corrections, mut steps, mut over_time) = (vec![], vec![], vec![]);
        let options = self.options;
        for step in 0..self.truth.positions.len() {
            let frame = self.frames[step].as_ref();
            let mut built_now = false;
            if let Some(frame) = frame {
                let rebuild = tracked.is_none() || mode == "rebuild";
                if rebuild {
                    built_now = true;
                    let started = Instant::now();
                    let body = self.build(frame, step, mode == "tracked")?;
                    cpu += started.elapsed().as_secs_f64();
                    builds += 1;
                    let tracker = Tracker::new(&body.body, options);
                    tracked = Some((body, tracker));
                } else if mode == "tracked" {
                    let (body, tracker) = tracked.as_mut().expect("built above");
                    let points = strided(&frame.points, OBSERVED_POINTS);
                    let fit = tracker.observe(&mut body.body, &points, &self.camera.position)?;
                    corrections.push(fit.ms);
                    cpu += fit.ms / 1e3;
                }
            }
            let (body, tracker) = tracked.as_mut().expect("the first frame builds");
            // A body built from this step's frame is where the frame saw it.
            if !built_now {
                let report = body.body.step();
                steps.push(report.seconds * 1e3);
                cpu += report.seconds;
                tracker.stepped(&mut body.body);
            }
            let (s, h, c) = self.errors(body, step);
            if let Some(fit) = &body.fit {
                let truth: Vec<_> = body
                    .material
                    .iter()
                    .map(|m| self.truth.at(step, *m))
                    .collect();
                fitted.push((fit.error(&truth) / self.truth.diagonal).powi(2));
            }
            let t = step as f64 * self.params.sim_params().dt;
            if sequence.blocked.is_some_and(|(a, b)| t >= a && t < b) {
                blocked.push(s * s);
            }
            seen.push(s * s);
            hidden.push(h * h);
            chamfer.push(c);
            over_time.push((t, 100.0 * s));
        }
        let rms = |v: &[f64]| 100.0 * (v.iter().sum::<f64>() / v.len().max(1) as f64).sqrt();
        Ok(TrackRow {
            sequence: sequence.name.into(),
            mode: mode.into(),
            seed: self.seed,
            builds,
            frames: self.frames.iter().flatten().count(),
            seen_error_pct: rms(&seen),
            hidden_error_pct: rms(&hidden),
            blocked_error_pct: (!blocked.is_empty()).then(|| rms(&blocked)),
            subspace_fit_pct: (!fitted.is_empty()).then(|| rms(&fitted)),
            chamfer_pct: 100.0 * chamfer.iter().sum::<f64>() / chamfer.len().max(1) as f64,
            correction_ms_median: median(&corrections),
            correction_ms_p99: quantile(&corrections, 0.99),
            step_ms_median: median(&steps),
            step_ms_p99: quantile(&steps, 0.99),
            cpu_share: cpu / seconds,
            over_time,
        })
    }

    /// The body of `frame` (taken at `step`), as the node builds a cloud in the fixed frame
    /// with a replay's refinement; the FEM's surface vertices no frame point lies near are its
    /// hidden side.
    fn build(&self, frame: &Frame, step: usize, with_fit: bool) -> Result<Tracked> {
        let mut options = self.params.body_options()?;
        options.refine = REPLAY_REFINE;
        let built = build_seen(
            self.model,
            &frame.points,
            &[],
            Some(&self.camera.position),
            self.params.inference.max_build_points,
            &options,
        )?;
        let positions = &self.truth.positions[step];
        let near = 0.06 * self.truth.diagonal;
        let index = PointIndex::for_surface(&frame.clean);
        let on_surface: Vec<usize> = {
            let mut v: Vec<usize> = self
                .truth
                .surface
                .iter()
                .flatten()
                .map(|&i| i as usize)
                .collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        let hidden: Vec<usize> = on_surface
            .iter()
            .copied()
            .filter(|&i| distance(&index, &frame.clean, &positions[i]) > near)
            .collect();
        let rest: Vec<Vector3<f64>> = hidden.iter().map(|&i| positions[i]).collect();
        let surface = built.body.surface_samples().points.clone();
        let fit = with_fit
            .then(|| SubspaceFit::new(&built.body.lifter_for(&frame.points)))
            .flatten();
        Ok(Tracked {
            fit,
            hidden_lifter: built.body.lifter_for(&rest),
            surface_lifter: built.body.lifter_for(&surface),
            body: built.body,
            material: frame.material.clone(),
            hidden,
        })
    }

    /// At `step`: the seen points' and the hidden surface's RMS error, and the Chamfer
    /// distance, as fractions of the diagonal.
    fn errors(&self, body: &Tracked, step: usize) -> (f64, f64, f64) {
        let d = self.truth.diagonal;
        let deformed = body.body.deformed();
        let seen = rms_of(body.material.iter().enumerate().map(|(i, m)| {
            let p = Vector3::new(
                deformed[3 * i] as f64,
                deformed[3 * i + 1] as f64,
                deformed[3 * i + 2] as f64,
            );
            (p - self.truth.at(step, *m)).norm_squared()
        }));
        let lift = |lifter: &crate::physics::Lifter| {
            let mut out = vec![0f32; 3 * lifter.len()];
            lifter.lift(body.body.state(), &mut out);
            out.chunks_exact(3)
                .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .collect::<Vec<_>>()
        };
        let hidden_now = lift(&body.hidden_lifter);
        let hidden = rms_of(
            body.hidden
                .iter()
                .zip(&hidden_now)
                .map(|(&i, p)| (p - self.truth.positions[step][i]).norm_squared()),
        );
        let surface = lift(&body.surface_lifter);
        let truth = self.truth.dense_surface(step);
        let chamfer = 0.5 * (mean_nearest(&surface, &truth) + mean_nearest(&truth, &surface));
        (seen / d, hidden / d, chamfer / d)
    }
}

fn rms_of(squares: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = squares.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// The mean distance from each point of `from` to the nearest of `to`.
fn mean_nearest(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> f64 {
    let index = PointIndex::for_surface(to);
    from.iter().map(|p| distance(&index, to, p)).sum::<f64>() / from.len().max(1) as f64
}

/// The distance from `p` to the nearest of the indexed `points`.
fn distance(index: &PointIndex, points: &[Vector3<f64>], p: &Vector3<f64>) -> f64 {
    index
        .nearest(p, 1, None)
        .first()
        .map_or(f64::INFINITY, |&i| (points[i] - p).norm())
}

/// Error over time of the first sequence's three modes, as an SVG line plot.
pub fn track_plot(report: &TrackReport) -> String {
    use std::fmt::Write;
    let Some(first) = report.rows.first() else {
        return String::new();
    };
    let rows: Vec<&TrackRow> = report
        .rows
        .iter()
        .filter(|r| r.sequence == first.sequence && r.seed == first.seed)
        .collect();
    let (w, h, m) = (760.0, 420.0, 60.0);
    let t_hi = rows
        .iter()
        .flat_map(|r| r.over_time.iter().map(|p| p.0))
        .fold(1e-9, f64::max);
    let e_hi = rows
        .iter()
        .flat_map(|r| r.over_time.iter().map(|p| p.1))
        .fold(1e-9, f64::max);
    let px = |t: f64| m + (w - 2.0 * m) * t / t_hi;
    let py = |e: f64| h - m - (h - 2.0 * m) * e / e_hi;
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12"><rect width="100%" height="100%" fill="white"/><text x="{}" y="24" text-anchor="middle">{}: material-point error over time</text>"#,
        w / 2.0,
        first.sequence
    );
    let _ = write!(
        svg,
        r##"<line x1="{m}" y1="{}" x2="{}" y2="{}" stroke="#000"/><line x1="{m}" y1="{m}" x2="{m}" y2="{}" stroke="#000"/>"##,
        h - m,
        w - m,
        h - m,
        h - m
    );
    let _ = write!(
        svg,
        r#"<text x="{}" y="{}" text-anchor="middle">time, s (0 to {t_hi:.2})</text><text x="14" y="{}" transform="rotate(-90 14 {})" text-anchor="middle">error, % of the diagonal (0 to {e_hi:.2})</text>"#,
        w / 2.0,
        h - 20.0,
        h / 2.0,
        h / 2.0
    );
    for (i, (r, colour)) in rows
        .iter()
        .zip(["#c0392b", "#7f8c8d", "#2471a3"])
        .enumerate()
    {
        let points: Vec<String> = r
            .over_time
            .iter()
            .map(|(t, e)| format!("{:.1},{:.1}", px(*t), py(*e)))
            .collect();
        let _ = write!(
            svg,
            r#"<polyline fill="none" stroke="{colour}" stroke-width="1.5" points="{}"/>"#,
            points.join(" ")
        );
        let y = m + 16.0 * i as f64;
        let _ = write!(
            svg,
            r#"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{colour}" stroke-width="3"/><text x="{}" y="{}">{}</text>"#,
            w - m - 150.0,
            w - m - 130.0,
            w - m - 124.0,
            y + 4.0,
            r.mode
        );
    }
    svg.push_str("</svg>\n");
    svg
}

/// The camera's optical frame in a written stream.
const STREAM_CAMERA: &str = "camera_optical";

/// `frames` as a camera driver records them: each a PointCloud2 of its noisy points in the
/// camera's optical frame on /physskin/points, stamped at its step, after the camera's pose in
/// `world` on /tf_static. Replayed with `fixed_frame: world` and `simulation.support: floor`
/// (config/stream.yaml) the object is built from the first frame and tracked.
fn write_stream(
    path: &std::path::Path,
    frames: &[Option<Frame>],
    camera: &Camera,
    dt: f64,
) -> Result<()> {
    use crate::bag::{BagWriter, RecordOptions};
    use crate::msg::cloud::encode_cloud;
    use crate::msg::{self as m, encode, to_cdr, Header, PointCloud2, TFMessage, Time};
    use crate::msg::{QosProfile, TopicInfo};
    let pose = camera.optical_pose();
    let (t, q) = (pose.translation.vector, pose.rotation);
    let mut writer = BagWriter::create(RecordOptions {
        path: path.to_path_buf(),
        ..Default::default()
    })?;
    writer.add_topic(TopicInfo::of::<TFMessage>(
        "/tf_static",
        QosProfile::reliable(1, true),
    ))?;
    writer.add_topic(TopicInfo::of::<PointCloud2>(
        "/physskin/points",
        QosProfile::sensor(5),
    ))?;
    let placed = TFMessage {
        transforms: vec![m::TransformStamped {
            header: Header {
                stamp: Time::default(),
                frame_id: "world".into(),
            },
            child_frame_id: STREAM_CAMERA.into(),
            transform: m::Transform {
                translation: m::Vector3 {
                    x: t.x,
                    y: t.y,
                    z: t.z,
                },
                rotation: m::Quaternion {
                    x: q.i,
                    y: q.j,
                    z: q.k,
                    w: q.w,
                },
            },
        }],
    };
    writer.write("/tf_static", 0, 0, &to_cdr(&placed))?;
    let into_camera = pose.inverse();
    for (step, frame) in frames.iter().enumerate() {
        let Some(frame) = frame else { continue };
        let ns = (step as f64 * dt * 1e9).round() as i64;
        let xyz: Vec<f32> = frame
            .points
            .iter()
            .flat_map(|p| {
                let q = into_camera * nalgebra::Point3::from(*p);
                [q.x as f32, q.y as f32, q.z as f32]
            })
            .collect();
        let header = Header {
            stamp: Time::from_nanos(ns),
            frame_id: STREAM_CAMERA.into(),
        };
        writer.write(
            "/physskin/points",
            ns,
            ns,
            &encode(&encode_cloud(header, &xyz, &[], &[])),
        )?;
    }
    writer.finish()?;
    Ok(())
}
