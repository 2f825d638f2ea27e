//! Fewer handles than a field has: the constant column and the smoothest others, so an object
//! that needs little detail pays for little.

use std::sync::Arc;

use nalgebra::Vector3;

use super::SkinningField;

/// A field restricted to some of its columns; column 0 (rigid) always stays first.
pub struct TruncatedField {
    inner: Arc<dyn SkinningField>,
    keep: Vec<usize>,
}

impl TruncatedField {
    /// Keeps the constant column and the `handles - 1` columns of lowest Dirichlet energy per
    /// unit variance over the sample `points` (normalized frame) with their `volumes`: the
    /// smoothest columns carry the low-frequency motion (sag, sway, bending) a coarse model must
    /// get right, as the lowest eigenmodes do for the eigenmode baseline.
    pub fn smoothest(
        inner: Arc<dyn SkinningField>,
        points: &[Vector3<f64>],
        volumes: &[f64],
        handles: usize,
    ) -> Self {
        let k = inner.handle_count();
        let handles = handles.clamp(1, k);
        let mut weights = vec![0.0; points.len() * k];
        let mut gradients = vec![Vector3::zeros(); points.len() * k];
        inner.evaluate(points, &mut weights, Some(&mut gradients));
        let total: f64 = volumes.iter().sum::<f64>().max(f64::MIN_POSITIVE);
        let mut roughness: Vec<(f64, usize)> = (1..k)
            .map(|j| {
                let mean: f64 = (0..points.len())
                    .map(|i| volumes[i] * weights[i * k + j])
                    .sum::<f64>()
                    / total;
                let (mut energy, mut variance) = (0.0, 0.0);
                for i in 0..points.len() {
                    energy += volumes[i] * gradients[i * k + j].norm_squared();
                    variance += volumes[i] * (weights[i * k + j] - mean).powi(2);
                }
                (energy / variance.max(f64::MIN_POSITIVE), j)
            })
            .collect();
        roughness.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut keep = vec![0];
        keep.extend(roughness.iter().take(handles - 1).map(|&(_, j)| j));
        Self { inner, keep }
    }
}

impl SkinningField for TruncatedField {
    fn handle_count(&self) -> usize {
        self.keep.len()
    }

    fn evaluate(
        &self,
        points: &[Vector3<f64>],
        weights: &mut [f64],
        gradients: Option<&mut [Vector3<f64>]>,
    ) {
        let k = self.inner.handle_count();
        let m = self.keep.len();
        let mut all = vec![0.0; points.len() * k];
        match gradients {
            Some(out) => {
                let mut all_gradients = vec![Vector3::zeros(); points.len() * k];
                self.inner
                    .evaluate(points, &mut all, Some(&mut all_gradients));
                for i in 0..points.len() {
                    for (c, &j) in self.keep.iter().enumerate() {
                        out[i * m + c] = all_gradients[i * k + j];
                    }
                }
            }
            None => self.inner.evaluate(points, &mut all, None),
        }
        for i in 0..points.len() {
            for (c, &j) in self.keep.iter().enumerate() {
                weights[i * m + c] = all[i * k + j];
            }
        }
    }

    fn kind(&self) -> &'static str {
        self.inner.kind()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns 1, x, x^3, sin(8x): the smoothest non-constant column is x, then x^3.
    struct Polynomials;
    impl SkinningField for Polynomials {
        fn handle_count(&self) -> usize {
            4
        }
        fn evaluate(&self, p: &[Vector3<f64>], w: &mut [f64], g: Option<&mut [Vector3<f64>]>) {
            for (i, x) in p.iter().map(|p| p.x).enumerate() {
                w[4 * i..4 * i + 4].copy_from_slice(&[1.0, (8.0 * x).sin(), x, x.powi(3)]);
            }
            if let Some(g) = g {
                for (i, x) in p.iter().map(|p| p.x).enumerate() {
                    let d = [0.0, 8.0 * (8.0 * x).cos(), 1.0, 3.0 * x * x];
                    for c in 0..4 {
                        g[4 * i + c] = Vector3::new(d[c], 0.0, 0.0);
                    }
                }
            }
        }
        fn kind(&self) -> &'static str {
            "test"
        }
    }

    #[test]
    fn keeps_the_constant_and_the_smoothest_columns() {
        let points: Vec<_> = (0..101)
            .map(|i| Vector3::new(-1.0 + i as f64 / 50.0, 0.0, 0.0))
            .collect();
        let volumes = vec![1.0; points.len()];
        let field = TruncatedField::smoothest(Arc::new(Polynomials), &points, &volumes, 3);
        assert_eq!(field.keep, vec![0, 2, 3]);
        let mut w = vec![0.0; 3];
        let mut g = vec![Vector3::zeros(); 3];
        field.evaluate(&[Vector3::new(0.5, 0.0, 0.0)], &mut w, Some(&mut g));
        assert_eq!(w, vec![1.0, 0.5, 0.125]);
        assert_eq!(g[2].x, 0.75);
    }
}
