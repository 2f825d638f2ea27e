//! The quasi-Newton preconditioner's factor, kept current without factoring anew: the contact
//! and friction springs that come and go are low-rank updates of it, and a turn of the whole
//! body is a rotation of what it solves for.
//!
//! Why: a body landing or rocking on a few corner points changes the springs acting several
//! times within one step, and each change cost a factorization of the 12K x 12K matrix. At
//! K = 17 a factorization took 250-354 us where a rank-r update took about 10 + 9 r us
//! (a scratch timing of faer's `cholesky_in_place` against `rank_r_update_clobber`, 204
//! unknowns, one thread, printed): a change of a few springs is several times cheaper as an
//! update, one of a few dozen is not.

use nalgebra::{DVector, Matrix3, Vector3};

use crate::error::Result;
use crate::linalg::DenseCholesky;

/// Rank past which a change of springs is factored anew. In the solver, an update of rank r
/// took 10 + 9.5 r us (r = 1-23, `bench sim` drops, printed) and a factorization with its
/// matrix about 0.2-0.25 ms: past 24, the creature's drop spent as long on 60 updates as on
/// the 60 factorizations they replaced; past 12, its factor time was 7.9 and 8.1 ms over 60 steps
/// against 9.4 and 17.9 ms, the rod's 3.4 and 3.5 ms against 4.6 and 4.9 ms (alternating
/// runs, printed, FEM left out).
const MOST_UPDATE_RANK: usize = 12;
/// Rank added and taken out since the last factorization past which it is factored anew, so
/// that round-off from taking out stiff springs cannot pile up.
const MOST_DRIFT: usize = 192;
/// A kept spring whose stiffness changed past this factor, either way, is replaced.
const STIFFNESS_CHANGE: f64 = 2.0;
/// A kept spring whose direction moved past this (largest entry of the difference of unit
/// directions, or of whole vectors over their size) is replaced.
const DIRECTION_CHANGE: f64 = 0.05;

/// What a spring term stands for: matched between one set of springs acting and the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum TermKey {
    /// The normal spring of a (contact, obstacle) pair in touch.
    Along(usize, usize),
    /// A friction stick's spring on a contact point along one of its two tangents.
    Across(usize, usize),
    /// One of the two axes of one rolling-friction term.
    Roll(usize, usize),
}

/// The vector u of a term alpha u u^T, in world axes.
#[derive(Clone, Debug)]
pub(super) enum TermShape {
    /// phi_point (x) direction: a spring on one contact point along a unit direction.
    Point(usize, Vector3<f64>),
    /// The whole vector in flat z order.
    Whole(DVector<f64>),
}

/// One term alpha u u^T of the preconditioner's springs.
#[derive(Clone, Debug)]
pub(super) struct SpringTerm {
    pub key: TermKey,
    pub alpha: f64,
    pub shape: TermShape,
}

impl SpringTerm {
    /// Whether `other` (the same key) is close enough to this one to leave this in the factor.
    fn matches(&self, other: &SpringTerm) -> bool {
        let ratio = self.alpha / other.alpha;
        let stiffness = (1.0 / STIFFNESS_CHANGE..=STIFFNESS_CHANGE).contains(&ratio);
        stiffness
            && match (&self.shape, &other.shape) {
                (TermShape::Point(a, u), TermShape::Point(b, v)) => {
                    a == b && (u - v).amax() <= DIRECTION_CHANGE
                }
                (TermShape::Whole(u), TermShape::Whole(v)) => {
                    (u - v).amax() <= DIRECTION_CHANGE * u.amax()
                }
                _ => false,
            }
    }
}

/// A factor of M' = (I (x) S)^T M (I (x) S) for the matrix M the preconditioner stands for:
/// the held elastic Hessian turned by the body's turn T0 when it was factored, inertia,
/// damping and pins, and `terms` given in world axes, each turned by S^T. S, the turn since
/// the factorization, leaves inertia, damping and pins as they are (they act on each axis
/// alike), so M x = b is solved as x = (I (x) S) M'^-1 (I (x) S)^T b: a body that only turned
/// needs no new factor.
pub(super) struct HeldFactor {
    cholesky: DenseCholesky,
    /// T0: the body's turn (from the held rotation) the elastic part was turned by.
    factored_turn: Matrix3<f64>,
    /// S = T T0^T for the turn T the factor stands for now.
    frame: Matrix3<f64>,
    /// The springs the factor holds, sorted by key, in world axes.
    terms: Vec<SpringTerm>,
    /// Rank added and taken out by updates since the factorization.
    drift: usize,
}

impl HeldFactor {
    /// A factor made at turn `turn` holding the springs `terms`.
    pub fn new(cholesky: DenseCholesky, turn: Matrix3<f64>, mut terms: Vec<SpringTerm>) -> Self {
        terms.sort_by_key(|t| t.key);
        Self {
            cholesky,
            factored_turn: turn,
            frame: Matrix3::identity(),
            terms,
            drift: 0,
        }
    }

    /// Solves M x = b in place.
    pub fn solve(&self, rhs: &mut [f64]) {
        let turned = self.frame != Matrix3::identity();
        if turned {
            turn_vector(rhs, &self.frame.transpose());
        }
        self.cholesky.solve(rhs);
        if turned {
            turn_vector(rhs, &self.frame);
        }
    }

    /// Makes the factor hold `terms` (world axes) for the body at turn `turn`, by updates:
    /// springs gone are taken out, new ones or ones that changed put in, every one again when
    /// the body turned. `vector` gives a term's u turned by the 3 x 3 rotation it is passed.
    /// Returns the rank it changed by, or None when that would cost more than factoring anew
    /// or the update failed: the factor must then be made anew.
    pub fn update_to(
        &mut self,
        mut terms: Vec<SpringTerm>,
        turn: &Matrix3<f64>,
        vector: impl Fn(&SpringTerm, &Matrix3<f64>) -> DVector<f64>,
    ) -> Option<usize> {
        terms.sort_by_key(|t| t.key);
        let frame = turn * self.factored_turn.transpose();
        let turned = frame != self.frame;
        let (gone, new) = changes(&self.terms, &terms, turned);
        let rank = gone.len() + new.len();
        if rank > MOST_UPDATE_RANK || self.drift + rank > MOST_DRIFT {
            return None;
        }
        // New springs first: the matrix only grows until the old ones are taken out.
        let added = apply(
            &mut self.cholesky,
            new.iter().map(|&i| &terms[i]),
            &frame,
            1.0,
            &vector,
        );
        let old = (self.frame, &self.terms);
        let gone_terms = gone.iter().map(|&i| &old.1[i]);
        added
            .and_then(|()| apply(&mut self.cholesky, gone_terms, &old.0, -1.0, &vector))
            .ok()?;
        self.frame = frame;
        self.terms = terms;
        self.drift += rank;
        Some(rank)
    }
}

/// Adds `sign` alpha u u^T to the factor for each of `terms`, u turned into the factor's axes
/// from the frame `frame` (S: u' = (I (x) S)^T u).
fn apply<'a>(
    cholesky: &mut DenseCholesky,
    terms: impl Iterator<Item = &'a SpringTerm>,
    frame: &Matrix3<f64>,
    sign: f64,
    vector: &impl Fn(&SpringTerm, &Matrix3<f64>) -> DVector<f64>,
) -> Result<()> {
    let back = frame.transpose();
    let (mut vectors, mut alphas) = (Vec::new(), Vec::new());
    for term in terms {
        vectors.extend_from_slice(vector(term, &back).as_slice());
        alphas.push(sign * term.alpha);
    }
    cholesky.update(&vectors, &alphas)
}

/// The indices of `held` terms to take out and of `wanted` ones to put in: those whose key is
/// in only one of them, and those of a key in both that no longer match (all of them when the
/// body `turned`). Both are sorted by key; keys held twice pair up in order.
fn changes(held: &[SpringTerm], wanted: &[SpringTerm], turned: bool) -> (Vec<usize>, Vec<usize>) {
    let (mut gone, mut new) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    while i < held.len() || j < wanted.len() {
        let order = match (held.get(i), wanted.get(j)) {
            (Some(h), Some(w)) => h.key.cmp(&w.key),
            (Some(_), None) => std::cmp::Ordering::Less,
            _ => std::cmp::Ordering::Greater,
        };
        match order {
            std::cmp::Ordering::Less => {
                gone.push(i);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                new.push(j);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                if turned || !held[i].matches(&wanted[j]) {
                    gone.push(i);
                    new.push(j);
                }
                i += 1;
                j += 1;
            }
        }
    }
    (gone, new)
}

/// Turns every 3-block of a flat z vector by `r`: (I (x) R) v.
pub(super) fn turn_vector(v: &mut [f64], r: &Matrix3<f64>) {
    for block in v.chunks_exact_mut(3) {
        let turned = r * Vector3::new(block[0], block[1], block[2]);
        block.copy_from_slice(turned.as_slice());
    }
}

/// phi (x) d in flat z order (index 3a + k): a spring on a point with weights `phi` along `d`.
pub(super) fn point_vector(phi: impl Iterator<Item = f64>, d: &Vector3<f64>) -> DVector<f64> {
    DVector::from_vec(phi.flat_map(|p| [p * d.x, p * d.y, p * d.z]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};

    fn random_matrix(rng: &mut impl Rng, n: usize) -> DMatrix<f64> {
        let a = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5);
        &a * a.transpose() + DMatrix::identity(n, n) * (n as f64)
    }

    /// The matrix a factor at `turn` holding `terms` stands for, made whole.
    fn whole(
        elastic: &DMatrix<f64>,
        quadratic: &DMatrix<f64>,
        phis: &DMatrix<f64>,
        turn: &Matrix3<f64>,
        terms: &[SpringTerm],
    ) -> DMatrix<f64> {
        let mut m = super::super::held::turn_blocks(elastic, turn) + quadratic;
        for t in terms {
            let u = term_vector(phis, t, &Matrix3::identity());
            m += &u * u.transpose() * t.alpha;
        }
        m
    }

    fn term_vector(phis: &DMatrix<f64>, t: &SpringTerm, r: &Matrix3<f64>) -> DVector<f64> {
        match &t.shape {
            TermShape::Point(c, d) => point_vector(phis.column(*c).iter().copied(), &(r * d)),
            TermShape::Whole(u) => {
                let mut u = u.clone();
                turn_vector(u.as_mut_slice(), r);
                u
            }
        }
    }

    fn floor_terms(points: &[usize], stiffness: f64) -> Vec<SpringTerm> {
        points
            .iter()
            .map(|&c| SpringTerm {
                key: TermKey::Along(c, 0),
                alpha: stiffness,
                shape: TermShape::Point(c, Vector3::z()),
            })
            .collect()
    }

    /// Springs put in and taken out, and turns of the body, leave a factor that solves as a
    /// fresh factorization of the matrix it stands for does, to 1e-9 relative.
    #[test]
    fn an_updated_held_factor_solves_as_a_fresh_factorization() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (blocks, points) = (12, 30);
        let n = 3 * blocks;
        let elastic = random_matrix(&mut rng, n);
        // Inertia and pins act on each axis alike: Q (x) I_3.
        let q = random_matrix(&mut rng, blocks);
        let quadratic = DMatrix::from_fn(n, n, |i, j| {
            if i % 3 == j % 3 {
                q[(i / 3, j / 3)]
            } else {
                0.0
            }
        });
        let phis = DMatrix::from_fn(blocks, points, |_, _| rng.random::<f64>());
        let roll = SpringTerm {
            key: TermKey::Roll(0, 1),
            alpha: 40.0,
            shape: TermShape::Whole(DVector::from_fn(n, |_, _| rng.random::<f64>() - 0.5)),
        };
        let turn_by = |angle: f64| {
            *nalgebra::Rotation3::from_scaled_axis(Vector3::new(0.2, -0.5, 0.9) * angle).matrix()
        };
        let mut terms = floor_terms(&[1, 4, 7], 1e4);
        let start = whole(&elastic, &quadratic, &phis, &turn_by(0.3), &terms);
        let cholesky = DenseCholesky::new(start.as_slice(), n).expect("definite");
        let mut factor = HeldFactor::new(cholesky, turn_by(0.3), terms.clone());
        // Gained and lost springs, a roll, a spring stiffened past the factor, two turns.
        let stages: Vec<(f64, Vec<SpringTerm>)> = vec![
            (0.3, floor_terms(&[1, 4, 9, 12], 1e4)),
            (0.35, floor_terms(&[4, 9, 12], 1e4)),
            (
                0.35,
                [floor_terms(&[4, 9], 1e4), vec![roll.clone()]].concat(),
            ),
            (
                0.5,
                [floor_terms(&[4], 1e4), floor_terms(&[9], 5e4), vec![roll]].concat(),
            ),
            (0.5, Vec::new()),
        ];
        for (angle, wanted) in stages {
            terms = wanted;
            let vector = |t: &SpringTerm, r: &Matrix3<f64>| term_vector(&phis, t, r);
            assert!(factor
                .update_to(terms.clone(), &turn_by(angle), vector)
                .is_some());
            let matrix = whole(&elastic, &quadratic, &phis, &turn_by(angle), &terms);
            let fresh = DenseCholesky::new(matrix.as_slice(), n).expect("definite");
            let rhs = DVector::from_fn(n, |_, _| rng.random::<f64>() - 0.5);
            let (mut x, mut y) = (rhs.clone(), rhs);
            factor.solve(x.as_mut_slice());
            fresh.solve(y.as_mut_slice());
            assert!(
                (&x - &y).norm() <= 1e-9 * y.norm(),
                "angle {angle}: {}",
                (&x - &y).norm() / y.norm()
            );
        }
    }

    /// A change of more springs than an update is worth is left to a factorization.
    #[test]
    fn a_large_change_of_springs_asks_for_a_new_factor() {
        let n = 6;
        let cholesky = DenseCholesky::new(DMatrix::<f64>::identity(n, n).as_slice(), n).unwrap();
        let mut factor = HeldFactor::new(cholesky, Matrix3::identity(), Vec::new());
        let phis = DMatrix::from_element(2, 40, 0.5);
        let many = floor_terms(&(0..MOST_UPDATE_RANK + 1).collect::<Vec<_>>(), 1.0);
        let vector = |t: &SpringTerm, r: &Matrix3<f64>| term_vector(&phis, t, r);
        assert!(factor
            .update_to(many, &Matrix3::identity(), vector)
            .is_none());
    }
}
