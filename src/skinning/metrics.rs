//! The paper's quality metrics of a weight matrix (Tables 1 and 2): orthogonality, conditioning
//! and spectral entropy of the column-normalized Gram matrix.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Omega_orth, kappa_log and H_spec of one weight matrix.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldMetrics {
    /// ||G - I||_F^2 / (K (K - 1)); lower is better (the paper prints it x 100).
    pub omega_orth: f64,
    /// log2(1 + lambda_max(G) / lambda_min(G)); 1 is the best possible.
    pub kappa_log: f64,
    /// Spectral entropy of G over log K; 1 is the best possible.
    pub h_spec: f64,
}

impl FieldMetrics {
    /// From `weights` (row-major, points x handles): G = What^T What with What the columns
    /// scaled to unit length.
    pub fn of(weights: &[f64], handles: usize) -> FieldMetrics {
        let points = weights.len() / handles;
        let w = DMatrix::from_row_slice(points, handles, weights);
        let mut unit = w.clone();
        for mut column in unit.column_iter_mut() {
            let norm = column.norm();
            if norm > 0.0 {
                column /= norm;
            }
        }
        let gram = unit.transpose() * &unit;
        let k = handles as f64;
        let off = &gram - DMatrix::identity(handles, handles);
        let omega_orth = off.norm_squared() / (k * (k - 1.0)).max(1.0);
        let eigen = gram.symmetric_eigen().eigenvalues;
        let largest = eigen.max();
        let smallest = eigen.min().max(0.0);
        let kappa_log = if smallest > 0.0 {
            (1.0 + largest / smallest).log2()
        } else {
            f64::INFINITY
        };
        let total: f64 = eigen.iter().map(|l| l.max(0.0)).sum();
        let entropy: f64 = eigen
            .iter()
            .map(|l| l.max(0.0) / total)
            .filter(|p| *p > 0.0)
            .map(|p| -p * p.ln())
            .sum();
        FieldMetrics {
            omega_orth,
            kappa_log,
            h_spec: if handles > 1 { entropy / k.ln() } else { 1.0 },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthonormal_columns_are_ideal() {
        // Columns of a 4-point Hadamard matrix: orthogonal, equal norms.
        let w = [
            1.0, 1.0, 1.0, 1.0, -1.0, 1.0, 1.0, 1.0, -1.0, 1.0, -1.0, -1.0,
        ];
        let m = FieldMetrics::of(&w, 3);
        assert!(m.omega_orth < 1e-15);
        assert!((m.kappa_log - 1.0).abs() < 1e-12);
        assert!((m.h_spec - 1.0).abs() < 1e-12);
    }

    #[test]
    fn dependent_columns_are_penalized() {
        // Two equal columns: G = [[1,1],[1,1]], eigenvalues 2 and 0.
        let w = [1.0, 1.0, 2.0, 2.0, 3.0, 3.0];
        let m = FieldMetrics::of(&w, 2);
        assert!((m.omega_orth - 1.0).abs() < 1e-12);
        assert!(m.kappa_log.is_infinite());
        assert!(m.h_spec.abs() < 1e-12);
    }
}
