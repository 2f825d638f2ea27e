//! The signed distance trees the generated training shapes are made of: primitives, their
//! placements and their combinations, evaluated at a point.

use nalgebra::{Matrix3, Vector3};

/// A signed distance tree. Distances are exact for the primitives and bounds for the
/// combinations, which is all the mesher and the inside test need.
#[derive(Clone, Debug)]
pub(super) enum Sdf {
    Ellipsoid {
        radii: Vector3<f64>,
    },
    Box {
        half: Vector3<f64>,
        round: f64,
    },
    Capsule {
        a: Vector3<f64>,
        b: Vector3<f64>,
        radius: f64,
    },
    /// Along z, capped.
    Cylinder {
        radius: f64,
        half_height: f64,
    },
    /// Around z.
    Torus {
        major: f64,
        minor: f64,
    },
    /// A frustum along z, radii at -h and +h.
    Cone {
        bottom: f64,
        top: f64,
        half_height: f64,
    },
    Moved {
        rotation: Matrix3<f64>,
        offset: Vector3<f64>,
        inner: Box<Sdf>,
    },
    Union {
        parts: Vec<Sdf>,
        smooth: f64,
    },
    Intersection(Box<Sdf>, Box<Sdf>),
    Difference(Box<Sdf>, Box<Sdf>),
    /// The inner solid moved so `center` is at the origin, then scaled by `scale`.
    Scaled {
        scale: f64,
        center: Vector3<f64>,
        inner: Box<Sdf>,
    },
    /// The wall of thickness `thickness` around the inner solid's surface, half of it inside.
    Shell {
        inner: Box<Sdf>,
        thickness: f64,
    },
}

impl Sdf {
    pub(super) fn at(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Sdf::Ellipsoid { radii } => {
                let k0 = p.component_div(radii).norm();
                let k1 = p.component_div(&radii.component_mul(radii)).norm();
                if k1 > 0.0 {
                    k0 * (k0 - 1.0) / k1
                } else {
                    -radii.min()
                }
            }
            Sdf::Box { half, round } => {
                let q = p.abs() - (half - Vector3::repeat(*round));
                q.sup(&Vector3::zeros()).norm() + q.max().min(0.0) - round
            }
            Sdf::Capsule { a, b, radius } => {
                let ab = b - a;
                let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                (p - (a + ab * t)).norm() - radius
            }
            Sdf::Cylinder {
                radius,
                half_height,
            } => {
                let d = [p.xy().norm() - radius, p.z.abs() - half_height];
                d[0].max(d[1]).min(0.0) + (d[0].max(0.0).powi(2) + d[1].max(0.0).powi(2)).sqrt()
            }
            Sdf::Torus { major, minor } => {
                let q = nalgebra::Vector2::new(p.xy().norm() - major, p.z);
                q.norm() - minor
            }
            Sdf::Cone {
                bottom,
                top,
                half_height,
            } => {
                let t = ((p.z + half_height) / (2.0 * half_height)).clamp(0.0, 1.0);
                let radius = bottom + (top - bottom) * t;
                let slope = ((top - bottom) / (2.0 * half_height)).atan().cos();
                ((p.xy().norm() - radius) * slope).max(p.z.abs() - half_height)
            }
            Sdf::Moved {
                rotation,
                offset,
                inner,
            } => inner.at(&(rotation.transpose() * (p - offset))),
            Sdf::Union { parts, smooth } => parts
                .iter()
                .map(|s| s.at(p))
                .reduce(|a, b| smooth_min(a, b, *smooth))
                .unwrap_or(f64::INFINITY),
            Sdf::Intersection(a, b) => a.at(p).max(b.at(p)),
            Sdf::Difference(a, b) => a.at(p).max(-b.at(p)),
            Sdf::Shell { inner, thickness } => inner.at(p).abs() - thickness / 2.0,
            Sdf::Scaled {
                scale,
                center,
                inner,
            } => inner.at(&(p / *scale + center)) * scale,
        }
    }

    pub(super) fn moved(self, rotation: Matrix3<f64>, offset: Vector3<f64>) -> Sdf {
        Sdf::Moved {
            rotation,
            offset,
            inner: Box::new(self),
        }
    }
}

fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    if k <= 0.0 {
        return a.min(b);
    }
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b * (1.0 - h) + a * h - k * h * (1.0 - h)
}
