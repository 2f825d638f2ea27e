//! The ellipse or ellipsoid through points that sample part of its surface: a least-squares
//! fit of the general quadric, which is exact for points on one and needs no starting guess.
//! One camera sees about half of a smooth object; the fitted quadric's centre is where the
//! prior's reflection needs it, which the outline's last pixels (short of where the surface
//! turns away) do not show.

use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// A fitted ellipse's or ellipsoid's extent across the view, against half the outline's along
/// the same direction, lies in this range where it is the object's: the outline shows it (its
/// last pixels a little short of it), as it shows a circle's radius.
pub(super) const ACROSS_BOUNDS: std::ops::Range<f64> = 0.85..1.2;
/// Its half-depth along the view, against half the outline's breadth: a shape three times as
/// deep as it is broad is not trusted to a fit of the side that faces the camera.
pub(super) const DEPTH_BOUNDS: std::ops::Range<f64> = 0.33..3.0;

/// An ellipse (D = 2) or ellipsoid (D = 3): the points x with (x - centre)^T shape (x - centre)
/// = 1.
pub(super) struct Quadric<const D: usize> {
    pub centre: SVector<f64, D>,
    shape: SMatrix<f64, D, D>,
    /// The fitted points' root-mean-square distance from it (to first order: Sampson's).
    pub misfit: f64,
}

impl<const D: usize> Quadric<D> {
    /// The quadric that best fits `points` in the algebraic sense (the least squares of
    /// x^T Q x + g.x = 1 about the points' mean, which lies inside the convex patch they
    /// sample); None where it is no ellipse or ellipsoid around the mean, or the points do
    /// not fix one (too few, on a line or a plane).
    pub fn fit(points: &[SVector<f64, D>]) -> Option<Self> {
        let unknowns = D * (D + 1) / 2 + D;
        if points.len() < unknowns {
            return None;
        }
        let mean = points.iter().sum::<SVector<f64, D>>() / points.len() as f64;
        // Scaled to unit spread, so that the squared and linear terms are of one size.
        let spread = points
            .iter()
            .map(|p| (p - mean).norm_squared())
            .sum::<f64>();
        let scale = (spread / points.len() as f64).sqrt();
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let scaled: Vec<SVector<f64, D>> = points.iter().map(|p| (p - mean) / scale).collect();
        let mut normal = DMatrix::zeros(unknowns, unknowns);
        let mut right = DVector::zeros(unknowns);
        let mut row = DVector::zeros(unknowns);
        for q in &scaled {
            monomials(q, &mut row);
            normal.ger(1.0, &row, &row, 1.0);
            right += &row;
        }
        let solved = normal.cholesky()?.solve(&right);
        let (quadratic, linear) = coefficients::<D>(&solved);
        // f(x) = x^T Q x + g.x - 1 is zero on the quadric, with its centre where 2 Q x = -g.
        let centre = -(quadratic.try_inverse()? * linear) / 2.0;
        let level = 1.0 + centre.dot(&(quadratic * centre));
        if !(level > 0.0 && level.is_finite() && quadratic.cholesky().is_some()) {
            return None;
        }
        let squared: f64 = scaled
            .iter()
            .map(|q| {
                let value = q.dot(&(quadratic * q)) + linear.dot(q) - 1.0;
                let gradient = quadratic * q * 2.0 + linear;
                (value / gradient.norm().max(1e-300)).powi(2)
            })
            .sum();
        Some(Self {
            centre: mean + centre * scale,
            shape: quadratic / (level * scale * scale),
            misfit: (squared / points.len() as f64).sqrt() * scale,
        })
    }

    /// How far it reaches from its centre along the unit direction `u`.
    pub fn half_extent(&self, u: &SVector<f64, D>) -> f64 {
        self.shape
            .try_inverse()
            .map_or(0.0, |inverse| u.dot(&(inverse * u)).max(0.0).sqrt())
    }

    /// Its smallest semi-axis.
    pub fn minor(&self) -> f64 {
        let shape = DMatrix::from_column_slice(D, D, self.shape.as_slice());
        let largest = shape.symmetric_eigenvalues().max();
        1.0 / largest.max(1e-300).sqrt()
    }
}

/// The fit's monomials at `q`: the products q_i q_j (i <= j), then q itself.
fn monomials<const D: usize>(q: &SVector<f64, D>, row: &mut DVector<f64>) {
    let mut k = 0;
    for i in 0..D {
        for j in i..D {
            row[k] = q[i] * q[j];
            k += 1;
        }
    }
    for i in 0..D {
        row[k + i] = q[i];
    }
}

/// The quadratic form Q and linear term g whose coefficients, in `monomials`' order, are
/// `solved`: an off-diagonal product's coefficient is split between Q_ij and Q_ji.
fn coefficients<const D: usize>(solved: &DVector<f64>) -> (SMatrix<f64, D, D>, SVector<f64, D>) {
    let mut quadratic = SMatrix::<f64, D, D>::zeros();
    let mut k = 0;
    for i in 0..D {
        for j in i..D {
            let half = if i == j { 1.0 } else { 0.5 };
            quadratic[(i, j)] = solved[k] * half;
            quadratic[(j, i)] = solved[k] * half;
            k += 1;
        }
    }
    let linear = SVector::<f64, D>::from_fn(|i, _| solved[k + i]);
    (quadratic, linear)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector2, Vector3};

    /// An ellipse's half arc gives back its centre, semi-axes and no misfit; points on a line
    /// or a hyperbola give no ellipse.
    #[test]
    fn an_elliptic_arc_gives_its_ellipse_and_others_none() {
        let pi = std::f64::consts::PI;
        let arc: Vec<Vector2<f64>> = (0..40)
            .map(|k| {
                let t = pi + pi * k as f64 / 39.0;
                Vector2::new(2.0 + 0.09 * t.cos(), -1.0 + 0.05 * t.sin())
            })
            .collect();
        let ellipse = Quadric::fit(&arc).expect("fits");
        assert!((ellipse.centre - Vector2::new(2.0, -1.0)).norm() < 1e-9);
        assert!((ellipse.half_extent(&Vector2::x()) - 0.09).abs() < 1e-9);
        assert!((ellipse.half_extent(&Vector2::y()) - 0.05).abs() < 1e-9);
        assert!((ellipse.minor() - 0.05).abs() < 1e-9);
        assert!(ellipse.misfit < 1e-9, "{}", ellipse.misfit);
        let line: Vec<_> = (0..20)
            .map(|k| Vector2::new(k as f64, 0.5 * k as f64))
            .collect();
        assert!(Quadric::fit(&line).is_none());
        let hyperbola: Vec<_> = (0..20)
            .map(|k| {
                let s = -1.0 + 0.1 * k as f64;
                Vector2::new(s.cosh(), s.sinh())
            })
            .collect();
        assert!(Quadric::fit(&hyperbola).is_none());
    }

    /// The half of a turned ellipsoid that faces one way gives back its centre and extents;
    /// a patch of a plane, and a saddle, give none.
    #[test]
    fn half_a_turned_ellipsoid_gives_its_ellipsoid_and_others_none() {
        let turn = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let (radii, centre) = (
            Vector3::new(0.12, 0.07, 0.045),
            Vector3::new(0.3, -0.2, 1.1),
        );
        let facing = Vector3::new(0.2, -1.0, 0.3);
        let mut half = Vec::new();
        for i in 0..30 {
            for j in 0..60 {
                let (polar, around) = (
                    std::f64::consts::PI * (i as f64 + 0.5) / 30.0,
                    std::f64::consts::TAU * j as f64 / 60.0,
                );
                let unit = Vector3::new(
                    polar.sin() * around.cos(),
                    polar.sin() * around.sin(),
                    polar.cos(),
                );
                let normal = turn * unit.component_div(&radii);
                if normal.dot(&facing) > 0.0 {
                    half.push(centre + turn * unit.component_mul(&radii));
                }
            }
        }
        let fitted = Quadric::fit(&half).expect("fits");
        assert!((fitted.centre - centre).norm() < 1e-9, "{}", fitted.centre);
        let long = turn * Vector3::x();
        assert!((fitted.half_extent(&long) - 0.12).abs() < 1e-9);
        assert!((fitted.minor() - 0.045).abs() < 1e-9);
        assert!(fitted.misfit < 1e-9);
        let plane: Vec<_> = (0..100)
            .map(|k| Vector3::new((k % 10) as f64, (k / 10) as f64, 0.0))
            .collect();
        assert!(Quadric::fit(&plane).is_none());
        let saddle: Vec<_> = (0..100)
            .map(|k| {
                let (x, y) = ((k % 10) as f64 / 10.0, (k / 10) as f64 / 10.0);
                Vector3::new(x, y, x * x - y * y)
            })
            .collect();
        assert!(Quadric::fit(&saddle).is_none());
    }
}
