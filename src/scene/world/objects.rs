//! Building a scene's objects from the file's specs: static and rigid ones as convex hulls,
//! deformable ones as bodies sized by the file or the error budget, pinned and attached.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use nalgebra::Vector3;
use parry3d::math::Vector;
use parry3d::shape::SharedShape;

use super::{FieldCache, SceneObject, SceneOptions, SceneRobot, Setup, ATTACHMENT_GROUP};
use crate::geometry::{self, Shape};
use crate::physics::{Obstacle, SimParams};
use crate::pipeline::{BodyOptions, SoftBody, Support};
use crate::scene::budget::choose_resolution;
use crate::scene::file::{
    ObjectKind, ObjectSpec, Region, Resolution, SceneFile, ShapeSpec, Source,
};
use crate::scene::SceneError;
use crate::skinning::NeuralModel;
use crate::skinning::RefineBudget;
use crate::Result;

/// The object's geometry placed in the world and the content hash of its geometry before the
/// placement (what identical objects at different places share); `None` for an object that
/// arrives on a topic.
pub(super) fn world_shape(spec: &ObjectSpec) -> Result<Option<(Shape, u64)>> {
    let named = |e: crate::Error| SceneError::Object {
        object: spec.name.clone(),
        reason: e.to_string(),
    };
    let local = match spec.source() {
        Source::Topic(_) => return Ok(None),
        Source::File(path) => geometry::load_geometry(path)
            .map_err(crate::Error::from)
            .and_then(Shape::from_raw)
            .map_err(named)?,
        Source::Shape(s) => match s {
            // Faces divided 40 times along the longest side: enough points to show
            // a dent.
            ShapeSpec::Box(size) => {
                let size = Vector3::from(*size);
                geometry::box_grid_mesh(size, size.max() / 40.0)
            }
            ShapeSpec::Sphere(r) => {
                let r = *r;
                geometry::sdf_mesh(&move |p: &Vector3<f64>| p.norm() - r, 1.2 * r, 40)
            }
            ShapeSpec::Capsule([length, r]) => geometry::capsule_mesh(*length, *r),
            ShapeSpec::Bundled(name) => {
                geometry::bundled(name).ok_or_else(|| SceneError::Object {
                    object: spec.name.clone(),
                    reason: format!(
                        "no bundled shape `{name}` (there are {:?})",
                        geometry::BUNDLED
                    ),
                })?
            }
        },
    };
    let offset = Vector3::from(spec.position);
    let positions = local.positions.iter().map(|p| p + offset).collect();
    let placed =
        Shape::new(positions, local.normals.clone(), local.triangles.clone()).map_err(named)?;
    let key = geometry::content_hash(&local.positions, &local.triangles);
    Ok(Some((placed, key)))
}

/// The indices of `robot` and its `link`; a link the robot lacks is an error naming `object`.
fn find_link(
    robots: &[SceneRobot],
    robot: &str,
    link: &str,
    object: &str,
) -> std::result::Result<(usize, usize), SceneError> {
    let r = robots
        .iter()
        .position(|r| r.name == robot)
        .expect("checked when the file was read");
    let l = robots[r]
        .robot
        .link(link)
        .ok_or_else(|| SceneError::Object {
            object: object.into(),
            reason: format!("robot `{robot}` has no link `{link}`"),
        })?;
    Ok((r, l))
}

/// A static or rigid object: not simulated, it collides as the convex hull of its points,
/// carried by its link when it is rigid and attached.
pub(super) fn kinematic_object(
    spec: &ObjectSpec,
    shape: Shape,
    robots: &[SceneRobot],
) -> Result<SceneObject> {
    let points: Vec<Vector> = shape
        .positions
        .iter()
        .map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32))
        .collect();
    let hull = SharedShape::convex_hull(&points).ok_or_else(|| SceneError::Object {
        object: spec.name.clone(),
        reason: "its points are flat: no convex hull to collide with".into(),
    })?;
    let held = match (&spec.attach, spec.kind) {
        (Some(a), ObjectKind::Rigid) => Some(find_link(robots, &a.robot, &a.link, &spec.name)?),
        _ => None,
    };
    let decision = match (spec.kind, held) {
        (ObjectKind::Static, _) => "static: not simulated, collides as its convex hull".into(),
        (_, Some(_)) => {
            "rigid: carried by its link, not simulated, collides as its convex hull".into()
        }
        _ => "rigid and not attached: stays put, not simulated, collides as its convex hull".into(),
    };
    Ok(SceneObject {
        name: spec.name.clone(),
        kind: spec.kind,
        body: None,
        setup: None,
        held,
        hull: Some(hull),
        rest: shape.positions,
        decision,
    })
}

/// A deformable object: its body built on the cached field cut to the size the file or the
/// error budget gives it, then put on the floor, among `obstacles`, pinned and attached.
#[allow(clippy::too_many_arguments)]
pub(super) fn deformable_object(
    spec: &ObjectSpec,
    shape: Shape,
    key: u64,
    file: &SceneFile,
    model: &Arc<NeuralModel>,
    cache: &FieldCache,
    options: &SceneOptions,
    robots: &[SceneRobot],
    obstacles: Option<&Vec<Obstacle>>,
) -> Result<SceneObject> {
    let (sim, floor, mut body_options) = body_setup(spec, file, &shape, options.decisions);
    let (field, cached) = cache.field(key, model, &shape, &body_options)?;
    let full = field.handle_count();
    let (handles, cubature, why) = match (spec.handles, spec.cubature, options.decisions) {
        (Resolution::Fixed(h), Resolution::Fixed(c), _) => {
            (h.min(full), c, "fixed in the scene file".to_string())
        }
        (h, c, false) => (
            match h {
                Resolution::Fixed(h) => h.min(full),
                Resolution::Auto => full,
            },
            match c {
                Resolution::Fixed(c) => c,
                Resolution::Auto => 256,
            },
            "no budget: all handles, 256 cubature points".to_string(),
        ),
        (h, c, true) => {
            let choice_key = budget_key(key, &sim, file.error_budget_pct, h, c);
            let choice = cache.choice(choice_key, || {
                choose_resolution(&field, &shape, &body_options, h, c, file.error_budget_pct)
            })?;
            (
                choice.handles,
                choice.cubature,
                choice.describe(file.error_budget_pct),
            )
        }
    };
    body_options.cubature = cubature;
    let field = cache.truncated(key, field, &shape, &body_options, handles, options.refine)?;
    let mut body = SoftBody::with_field(field, &shape, &shape.positions, &body_options)?;
    let (held, attach) = hold_in_place(&mut body, spec, floor, obstacles, robots)?;
    let inference = if cached {
        "inference reused (same geometry)"
    } else {
        "inferred"
    };
    let refined = match options.refine {
        _ if handles < full => String::new(),
        RefineBudget::Off => String::new(),
        RefineBudget::Iterations(n) => format!("; refined toward the eigenmodes ({n} iterations)"),
        RefineBudget::Settled(n) => {
            format!("; refined toward the eigenmodes (until settled, at most {n} iterations)")
        }
        RefineBudget::Millis(ms) => format!("; refined toward the eigenmodes (within {ms} ms)"),
        RefineBudget::Full => "; refined to the eigenmodes".to_string(),
    };
    let decision = format!(
        "{handles} of {full} handles, {cubature} cubature points: {why}; {inference}{refined}"
    );
    body.set_decision(decision.clone());
    Ok(SceneObject {
        name: spec.name.clone(),
        kind: spec.kind,
        body: Some(body),
        setup: Some(Setup {
            shape,
            sim,
            support: body_options.support,
            floor,
            pins: spec.pins.clone(),
            attach,
            obstacles: obstacles.cloned().unwrap_or_default(),
        }),
        held,
        hull: None,
        rest: Vec::new(),
        decision,
    })
}

/// A deformable object's simulation parameters, the height of its floor (the scene's, or its
/// own lowest point when it stands on a floor of its own) and the options of its body, with
/// all handles and the default cubature until its size is chosen.
fn body_setup(
    spec: &ObjectSpec,
    file: &SceneFile,
    shape: &Shape,
    decisions: bool,
) -> (SimParams, Option<f64>, BodyOptions) {
    let sim = SimParams {
        young: spec.material.young,
        poisson: spec.material.poisson,
        density: spec.material.density,
        dt: 1.0 / file.rate_hz,
        gravity: Vector3::from(file.gravity),
        damping: file.damping,
        friction: file.friction,
        rolling_friction: file.rolling_friction,
        ..SimParams::default()
    };
    let support = spec.support.unwrap_or(if file.floor.is_some() {
        Support::Floor
    } else {
        Support::PinBottom
    });
    let floor = match (file.floor, support) {
        (Some(z), _) => Some(z),
        (None, Support::Floor) => Some(shape.bounds().0.z),
        _ => None,
    };
    let body_options = BodyOptions {
        sim: sim.clone(),
        // The floor is added below at the scene's height, not at the object's lowest point.
        support: if support == Support::Floor {
            Support::Free
        } else {
            support
        },
        sleep: if decisions { file.sleep } else { None },
        // The scene refines through its field cache, per geometry and handle count.
        refine: RefineBudget::Off,
        ..BodyOptions::default()
    };
    (sim, floor, body_options)
}

/// The key of a budget choice: the geometry's content hash, the simulation parameters, the
/// budget and the sizes the file asks for. Objects that agree on all of them share one choice.
fn budget_key(key: u64, sim: &SimParams, budget_pct: f64, h: Resolution, c: Resolution) -> u64 {
    let mut choice_key = DefaultHasher::new();
    key.hash(&mut choice_key);
    for v in [
        sim.young,
        sim.poisson,
        sim.density,
        sim.dt,
        sim.damping,
        sim.friction,
        sim.rolling_friction,
        budget_pct,
    ] {
        v.to_bits().hash(&mut choice_key);
    }
    sim.gravity
        .iter()
        .for_each(|g| g.to_bits().hash(&mut choice_key));
    format!("{h:?}{c:?}").hash(&mut choice_key);
    choice_key.finish()
}

/// Puts a deformable object's body on the floor at `floor`, among `obstacles`, and pins and
/// attaches it as its spec says. Returns the robot and link that carry it and the attached
/// region; a pin or an attachment that holds no material is an error.
fn hold_in_place(
    body: &mut SoftBody,
    spec: &ObjectSpec,
    floor: Option<f64>,
    obstacles: Option<&Vec<Obstacle>>,
    robots: &[SceneRobot],
) -> Result<(Option<(usize, usize)>, Option<Region>)> {
    if let Some(z) = floor {
        body.add_floor(z);
    }
    if let Some(obstacles) = obstacles {
        body.enable_contacts();
        for o in obstacles {
            body.add_obstacle(o.clone());
        }
    }
    for pin in &spec.pins {
        if body.pin(&Vector3::from(pin.center), pin.radius) == 0 {
            return Err(SceneError::Object {
                object: spec.name.clone(),
                reason: format!(
                    "no material within {} m of pin {:?}",
                    pin.radius, pin.center
                ),
            }
            .into());
        }
    }
    let mut held = None;
    let mut attach = None;
    if let Some(a) = &spec.attach {
        held = Some(find_link(robots, &a.robot, &a.link, &spec.name)?);
        let region = a.region.expect("checked when the file was read");
        if body.attach(
            &Vector3::from(region.center),
            region.radius,
            ATTACHMENT_GROUP,
        ) == 0
        {
            return Err(SceneError::Object {
                object: spec.name.clone(),
                reason: format!(
                    "no material within {} m of the attachment at {:?}",
                    region.radius, region.center
                ),
            }
            .into());
        }
        attach = Some(region);
    }
    Ok((held, attach))
}
