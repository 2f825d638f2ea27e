//! The shape families and how each draws a random solid: its primitives, their sizes and
//! proportions, and how they are put together.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::sdf::Sdf;

/// The families, in the order the dataset cycles through them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeFamily {
    /// One primitive: an ellipsoid, a box, a capsule, a cylinder, a torus or a cone, with
    /// aspect ratios up to 8:1.
    Primitive,
    /// Two to four primitives, each placed near one already drawn, smoothly joined.
    Union,
    /// Three to seven capsules, each growing from the end of one already drawn.
    Limbs,
    /// An ellipsoid body on two, four or six capsule legs, with a neck, a head and often a tail.
    Animal,
    /// A thin plate, sometimes bent along a crease.
    Plate,
    /// The hollow wall of an ellipsoid, a rounded box or a capsule.
    Shell,
    /// A slab or a disc with one to three round holes through it.
    Holed,
    /// Unions, intersections and differences of four or eight primitives (a tree two or
    /// three levels deep).
    Csg,
}

impl ShapeFamily {
    /// Every family, in the order the dataset cycles through them.
    pub const ALL: [ShapeFamily; 8] = [
        ShapeFamily::Primitive,
        ShapeFamily::Union,
        ShapeFamily::Limbs,
        ShapeFamily::Animal,
        ShapeFamily::Plate,
        ShapeFamily::Shell,
        ShapeFamily::Holed,
        ShapeFamily::Csg,
    ];

    /// The family's name, as serialized: `primitive`, `union`, ..., `csg`.
    pub fn name(self) -> &'static str {
        match self {
            ShapeFamily::Primitive => "primitive",
            ShapeFamily::Union => "union",
            ShapeFamily::Limbs => "limbs",
            ShapeFamily::Animal => "animal",
            ShapeFamily::Plate => "plate",
            ShapeFamily::Shell => "shell",
            ShapeFamily::Holed => "holed",
            ShapeFamily::Csg => "csg",
        }
    }
}

/// The thinnest wall a family draws: it spans three of the mesher's cells (0.025), so the
/// surface of every wall is found.
const THINNEST: f64 = 0.08;

/// A random solid of `family`, before it is fitted to the mesher's cube.
pub(super) fn draw(family: ShapeFamily, rng: &mut ChaCha8Rng) -> Sdf {
    match family {
        ShapeFamily::Primitive => primitive(rng, 2.0),
        ShapeFamily::Union => union(rng),
        ShapeFamily::Limbs => limbs(rng),
        ShapeFamily::Animal => animal(rng),
        ShapeFamily::Plate => plate(rng),
        ShapeFamily::Shell => shell(rng),
        ShapeFamily::Holed => holed(rng),
        ShapeFamily::Csg => {
            let depth = 2 + usize::from(rng.random_bool(0.5));
            csg(rng, depth)
        }
    }
}

/// Two to four primitives, each placed near one already drawn, smoothly joined.
fn union(rng: &mut ChaCha8Rng) -> Sdf {
    let count = rng.random_range(2..=4);
    let mut parts = Vec::new();
    let mut centers = vec![Vector3::zeros()];
    for _ in 0..count {
        let anchor = centers[rng.random_range(0..centers.len())];
        let center = anchor + random_direction(rng) * rng.random_range(0.0..0.35);
        let size = rng.random_range(0.7..1.3);
        let rotation = random_rotation(rng);
        parts.push(primitive(rng, size).moved(rotation, center));
        centers.push(center);
    }
    Sdf::Union {
        parts,
        smooth: rng.random_range(0.0..0.1),
    }
}

/// Three to seven capsules, each growing from the end of one already drawn: a branching limb.
fn limbs(rng: &mut ChaCha8Rng) -> Sdf {
    let count = rng.random_range(3..=7);
    let mut joints = vec![Vector3::zeros()];
    let mut parts = Vec::new();
    for _ in 0..count {
        let start = joints[rng.random_range(0..joints.len())];
        let end = start + random_direction(rng) * rng.random_range(0.35..0.8);
        parts.push(Sdf::Capsule {
            a: start,
            b: end,
            radius: rng.random_range(0.06..0.14),
        });
        joints.push(end);
    }
    Sdf::Union {
        parts,
        smooth: rng.random_range(0.02..0.08),
    }
}

/// A thin plate, sometimes bent along a crease.
fn plate(rng: &mut ChaCha8Rng) -> Sdf {
    let length = 2.0;
    let width = length * rng.random_range(0.2..1.0);
    let thickness = (length * rng.random_range(0.03f64..0.08)).max(THINNEST);
    let plate = Sdf::Box {
        half: Vector3::new(length / 2.0, width / 2.0, thickness / 2.0),
        round: rng.random_range(0.0..0.5) * thickness / 2.0,
    };
    if rng.random_bool(0.35) {
        // A plate bent along a crease: two slabs meeting at an angle.
        let angle = rng.random_range(0.3..1.4);
        let half = Sdf::Box {
            half: Vector3::new(length / 4.0, width / 2.0, thickness / 2.0),
            round: 0.0,
        };
        let tilt = |a: f64| *Rotation3::from_axis_angle(&Vector3::y_axis(), a).matrix();
        let offset = |a: f64| tilt(a) * Vector3::new(length / 4.0, 0.0, 0.0);
        Sdf::Union {
            parts: vec![
                half.clone().moved(tilt(-angle / 2.0), offset(-angle / 2.0)),
                half.moved(tilt(angle / 2.0), -offset(angle / 2.0)),
            ],
            smooth: 0.02,
        }
    } else {
        plate
    }
}

/// The hollow wall of an ellipsoid, a rounded box or a capsule.
fn shell(rng: &mut ChaCha8Rng) -> Sdf {
    let inner = match rng.random_range(0..3) {
        0 => Sdf::Ellipsoid {
            radii: Vector3::new(0.9, rng.random_range(0.5..0.9), rng.random_range(0.4..0.9)),
        },
        1 => Sdf::Box {
            half: Vector3::new(0.9, rng.random_range(0.4..0.9), rng.random_range(0.3..0.9)),
            round: 0.1,
        },
        _ => Sdf::Capsule {
            a: Vector3::new(-0.5, 0.0, 0.0),
            b: Vector3::new(0.5, 0.0, 0.0),
            radius: rng.random_range(0.3..0.45),
        },
    };
    Sdf::Shell {
        inner: Box::new(inner),
        thickness: (2.0 * rng.random_range(0.05f64..0.12)).max(THINNEST),
    }
}

/// A slab or a disc with one to three round holes through it.
fn holed(rng: &mut ChaCha8Rng) -> Sdf {
    let base = if rng.random_bool(0.5) {
        Sdf::Box {
            half: Vector3::new(1.0, rng.random_range(0.4..0.9), rng.random_range(0.1..0.5)),
            round: 0.05,
        }
    } else {
        Sdf::Cylinder {
            radius: 0.9,
            half_height: rng.random_range(0.1..0.5),
        }
    };
    let holes = rng.random_range(1..=3);
    let mut cut = Vec::new();
    for _ in 0..holes {
        let center = Vector3::new(
            rng.random_range(-0.55..0.55),
            rng.random_range(-0.25..0.25),
            0.0,
        );
        cut.push(
            Sdf::Cylinder {
                radius: rng.random_range(0.1..0.25),
                half_height: 2.0,
            }
            .moved(Matrix3::identity(), center),
        );
    }
    Sdf::Difference(
        Box::new(base),
        Box::new(Sdf::Union {
            parts: cut,
            smooth: 0.0,
        }),
    )
}

fn animal(rng: &mut ChaCha8Rng) -> Sdf {
    let body = Vector3::new(
        rng.random_range(0.45..0.7),
        rng.random_range(0.18..0.3),
        rng.random_range(0.16..0.28),
    );
    let mut parts = vec![Sdf::Ellipsoid { radii: body }];
    let legs = 2 * rng.random_range(1..=3);
    let leg_length = rng.random_range(0.3..0.6);
    let leg_radius = rng.random_range(0.05..0.09);
    for i in 0..legs / 2 {
        let x = if legs == 2 {
            0.0
        } else {
            -0.7 * body.x + 1.4 * body.x * i as f64 / (legs / 2 - 1) as f64
        };
        for side in [-1.0, 1.0] {
            let top = Vector3::new(x, side * 0.6 * body.y, -0.3 * body.z);
            let foot = top + Vector3::new(rng.random_range(-0.1..0.1), side * 0.05, -leg_length);
            parts.push(Sdf::Capsule {
                a: top,
                b: foot,
                radius: leg_radius,
            });
        }
    }
    let neck_base = Vector3::new(0.8 * body.x, 0.0, 0.3 * body.z);
    let head_at = neck_base
        + Vector3::new(
            rng.random_range(0.1..0.35),
            0.0,
            rng.random_range(0.15..0.5),
        );
    parts.push(Sdf::Capsule {
        a: neck_base,
        b: head_at,
        radius: rng.random_range(0.06..0.1),
    });
    parts.push(
        Sdf::Ellipsoid {
            radii: Vector3::new(
                rng.random_range(0.12..0.22),
                rng.random_range(0.09..0.14),
                rng.random_range(0.09..0.14),
            ),
        }
        .moved(Matrix3::identity(), head_at),
    );
    if rng.random_bool(0.7) {
        let base = Vector3::new(-0.95 * body.x, 0.0, 0.2 * body.z);
        parts.push(Sdf::Capsule {
            a: base,
            b: base
                + Vector3::new(
                    -rng.random_range(0.2..0.5),
                    0.0,
                    rng.random_range(-0.1..0.4),
                ),
            radius: rng.random_range(0.04..0.07),
        });
    }
    Sdf::Union {
        parts,
        smooth: 0.05,
    }
}

fn csg(rng: &mut ChaCha8Rng, depth: usize) -> Sdf {
    if depth == 0 {
        let center = random_direction(rng) * rng.random_range(0.0..0.3);
        let size = rng.random_range(1.0..1.8);
        let rotation = random_rotation(rng);
        return primitive(rng, size).moved(rotation, center);
    }
    let a = Box::new(csg(rng, depth - 1));
    let b = Box::new(csg(rng, depth - 1));
    match rng.random_range(0..3) {
        0 => Sdf::Union {
            parts: vec![*a, *b],
            smooth: 0.03,
        },
        1 => Sdf::Intersection(a, b),
        _ => Sdf::Difference(a, b),
    }
}

pub(super) fn random_rotation(rng: &mut impl Rng) -> Matrix3<f64> {
    let axis = random_direction(rng);
    *Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(axis),
        rng.random_range(0.0..std::f64::consts::TAU),
    )
    .matrix()
}

fn random_direction(rng: &mut impl Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// One primitive about `size` across with aspect ratios up to 8:1.
fn primitive(rng: &mut impl Rng, size: f64) -> Sdf {
    let r = size / 2.0;
    let aspect = |rng: &mut ChaCha8Rng| rng.random_range(0.25..1.0);
    let mut local = ChaCha8Rng::seed_from_u64(rng.random());
    let thick = |x: f64| x.max(THINNEST);
    match rng.random_range(0..6) {
        0 => Sdf::Ellipsoid {
            radii: Vector3::new(
                r,
                thick(r * aspect(&mut local)),
                thick(r * aspect(&mut local) * 0.8),
            ),
        },
        1 => {
            let half = Vector3::new(
                r,
                thick(r * aspect(&mut local)),
                thick(r * aspect(&mut local)),
            );
            Sdf::Box {
                round: rng.random_range(0.0..0.5) * half.min(),
                half,
            }
        }
        2 => {
            let radius = thick(r * rng.random_range(0.12..0.5));
            Sdf::Capsule {
                a: Vector3::new(-(r - radius).max(0.0), 0.0, 0.0),
                b: Vector3::new((r - radius).max(0.0), 0.0, 0.0),
                radius,
            }
        }
        3 => Sdf::Cylinder {
            radius: thick(r * rng.random_range(0.15..1.0)),
            half_height: thick(r * rng.random_range(0.2..1.0)),
        },
        4 => {
            let minor = thick(r * rng.random_range(0.12..0.35));
            Sdf::Torus {
                major: (r - minor).max(minor * 1.3),
                minor,
            }
        }
        _ => Sdf::Cone {
            bottom: thick(r * rng.random_range(0.3..0.9)),
            top: thick(r * rng.random_range(0.05..0.6)),
            half_height: r * rng.random_range(0.4..1.0),
        },
    }
}
