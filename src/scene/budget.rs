//! How many handles and cubature points an object needs: the smallest model whose motion stays
//! within an error budget of the full-space FEM on a probe (the object standing on its base,
//! sagging under gravity and pushed sideways at its top), measured with the simulation core.

use std::sync::Arc;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::Serialize;

use super::file::Resolution;
use crate::geometry::Shape;
use crate::geometry::{bottom_vertices, reference_mesh};
use crate::physics::FemSim;
use crate::pipeline::{BodyOptions, SoftBody, Support};
use crate::skinning::SkinningField;
use crate::Result;

/// Probe length: 0.75 s at 60 Hz, the push lasting its first third.
const PROBE_STEPS: usize = 45;
const PUSH_STEPS: usize = 15;
/// The push, in the object's weights: enough to bend a slender object by a fraction of its
/// length and to dent a compact one, not to fold either.
const PUSH_WEIGHTS: f64 = 0.1;
/// Handle counts tried, the field's full count added.
const HANDLE_STEPS: [usize; 3] = [5, 9, 13];
const CUBATURE_STEPS: [usize; 3] = [64, 128, 256];

/// The size chosen for one object, and the evidence.
#[derive(Clone, Debug, Serialize)]
pub struct Choice {
    /// Handles, the constant one included.
    pub handles: usize,
    /// Cubature points.
    pub cubature: usize,
    /// Its probe error against the FEM, % of the object's size.
    pub error_pct: f64,
    /// Whether it meets the budget (if none does, the most accurate size was taken).
    pub met: bool,
    /// The largest size tried and its error.
    pub largest: (usize, usize, f64),
    /// Sizes (handles, cubature) probed.
    pub tried: usize,
}

impl Choice {
    /// Why this size, in a sentence for the state topic and the log.
    pub fn describe(&self, budget_pct: f64) -> String {
        let (h, c, e) = self.largest;
        if self.met {
            format!(
                "smallest of {} sizes within the {budget_pct} % budget ({:.2} % against the FEM; \
                 {h} handles, {c} points give {e:.2} %)",
                self.tried, self.error_pct
            )
        } else {
            format!(
                "no size meets the {budget_pct} % budget: the most accurate of {} ({:.2} % \
                 against the FEM)",
                self.tried, self.error_pct
            )
        }
    }
}

/// Tries the sizes that `handles` and `cubature` allow (`auto`: 5, 9, 13 and all handles; 64,
/// 128 and 256 cubature points) on the probe, cheapest first, and takes the cheapest within
/// `budget_pct`.
pub fn choose_resolution(
    field: &Arc<dyn SkinningField>,
    shape: &Shape,
    options: &BodyOptions,
    handles: Resolution,
    cubature: Resolution,
    budget_pct: f64,
) -> Result<Choice> {
    let full = field.handle_count();
    let handle_options: Vec<usize> = match handles {
        Resolution::Fixed(h) => vec![h.min(full)],
        Resolution::Auto => HANDLE_STEPS
            .iter()
            .copied()
            .filter(|&h| h < full)
            .chain([full])
            .collect(),
    };
    let cubature_options: Vec<usize> = match cubature {
        Resolution::Fixed(c) => vec![c],
        Resolution::Auto => CUBATURE_STEPS.to_vec(),
    };
    let mut sizes: Vec<(usize, usize)> = handle_options
        .iter()
        .flat_map(|&h| cubature_options.iter().map(move |&c| (h, c)))
        .collect();
    // Step cost grows with cubature points times the square of the handle count.
    sizes.sort_by_key(|&(h, c)| (c * h * h, h));

    let probe = Probe::run(shape, options)?;
    let errors: Vec<f64> = sizes
        .par_iter()
        .map(|&(h, c)| probe.error_of(field, shape, options, h, c))
        .collect::<Result<_>>()?;
    let within = sizes
        .iter()
        .zip(&errors)
        .position(|(_, &e)| e <= budget_pct);
    let pick = within.unwrap_or_else(|| {
        (0..errors.len())
            .min_by(|&a, &b| errors[a].total_cmp(&errors[b]))
            .expect("at least one size")
    });
    let largest = (0..sizes.len())
        .max_by_key(|&i| (sizes[i].0, sizes[i].1))
        .expect("at least one size");
    Ok(Choice {
        handles: sizes[pick].0,
        cubature: sizes[pick].1,
        error_pct: errors[pick],
        met: within.is_some(),
        largest: (sizes[largest].0, sizes[largest].1, errors[largest]),
        tried: sizes.len(),
    })
}

/// The FEM's answer to the probe, at its mesh vertices.
struct Probe {
    vertices: Vec<Vector3<f64>>,
    diagonal: f64,
    /// The pushed vertices and the force on each.
    top: Vec<Vector3<f64>>,
    push: Vector3<f64>,
    steps: Vec<Vec<f64>>,
}

impl Probe {
    fn run(shape: &Shape, options: &BodyOptions) -> Result<Self> {
        let reference = reference_mesh(shape);
        let mesh = reference.mesh.clone();
        let g = options.sim.gravity;
        let up = if g.norm() > 0.0 {
            -g.normalize()
        } else {
            Vector3::z()
        };
        let side = if up.cross(&Vector3::x()).norm() > 0.5 {
            (Vector3::x() - up * up.x).normalize()
        } else {
            (Vector3::y() - up * up.y).normalize()
        };
        let mut fem = FemSim::new(mesh.clone(), options.sim.clone())?;
        fem.pin_vertices(&bottom_vertices(&mesh, &g));
        let mass: f64 = fem.vertex_masses().iter().sum();
        // The push is spread over the top slab: a point load on one vertex would measure the
        // FEM's local dent, which no smooth subspace has, rather than the object's motion.
        let top: Vec<Vector3<f64>> = bottom_vertices(&mesh, &-g)
            .into_iter()
            .map(|v| mesh.vertices[v])
            .collect();
        let push = side * (PUSH_WEIGHTS * mass * g.norm().max(9.81) / top.len() as f64);
        for point in &top {
            fem.add_poke(crate::physics::Poke {
                point: *point,
                force: push,
                start: 0.0,
                end: PUSH_STEPS as f64 * options.sim.dt,
            });
        }
        let mut steps = Vec::with_capacity(PROBE_STEPS);
        for _ in 0..PROBE_STEPS {
            fem.step()?;
            steps.push(fem.positions().to_vec());
        }
        Ok(Self {
            vertices: mesh.vertices.clone(),
            diagonal: reference.diagonal,
            top,
            push,
            steps,
        })
    }

    /// RMS distance to the FEM over vertices and steps, % of the diagonal, of the reduced model
    /// with `handles` and `cubature` points.
    fn error_of(
        &self,
        field: &Arc<dyn SkinningField>,
        shape: &Shape,
        options: &BodyOptions,
        handles: usize,
        cubature: usize,
    ) -> Result<f64> {
        let options = BodyOptions {
            handles: Some(handles),
            cubature,
            support: Support::PinBottom,
            sleep: None,
            ..options.clone()
        };
        let mut body = SoftBody::with_field(field.clone(), shape, &self.vertices, &options)?;
        for point in &self.top {
            body.push(*point, self.push, PUSH_STEPS as f64 * options.sim.dt);
        }
        let mut squared = 0.0;
        for fem in &self.steps {
            body.step();
            squared += body
                .deformed()
                .iter()
                .zip(fem)
                .map(|(r, f)| (*r as f64 - f).powi(2))
                .sum::<f64>();
        }
        let samples = (self.steps.len() * self.vertices.len()) as f64;
        Ok((squared / samples).sqrt() / self.diagonal * 100.0)
    }
}
