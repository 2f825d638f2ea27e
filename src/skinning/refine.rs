//! Learned, then refined: the network's weight columns as the warm start of the skinning
//! eigenmodes' own eigenproblem. On the tetrahedral mesh [`EigenmodeField::compute`] would use,
//! the same Laplacian L and lumped mass M are assembled and L + sigma M is factored once; each
//! iteration applies A = (L + sigma M)^-1 M to the block X and keeps the k lowest Ritz vectors
//! of a search space around it (Rayleigh-Ritz), in the M-orthogonal complement of the
//! constant. A start near the eigenmodes' span is most of the way there after one iteration,
//! where the eigen-solve starts from random columns. The Ritz values never increase (the
//! search space holds X; for [`RefineSearch::Subspace`], by the monotonicity of inverse
//! subspace iteration), so stopping anywhere, as a time budget does, leaves a span at least as
//! good in the Rayleigh-quotient sense as the start's.

use std::time::Instant;

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::eigenmodes::ModeProblem;
use super::{EigenmodeField, SkinningField};
use crate::error::{Error, Result};
use crate::geometry::{Normalization, TetMesh};
use crate::linalg::{product, transpose_product, SparseCholesky};

/// Directions of a new block that lie within this (relative M-norm) of the span already held
/// are dropped: they carry only rounding.
const DROP: f64 = 1e-8;

/// A span none of whose Ritz values moves by more than this (relative) in one iteration has
/// settled ([`RefineBudget::Settled`]): the refinement's own convergence test, looser. On
/// `bench track`'s ball a span one iteration short of it (its values still moving by 2.4e-3)
/// tracked the poked ball to 1.32 % where the settled one and the fully converged one gave
/// 0.79 and 0.77 % (printed); the sum of the values had moved by only 6e-4 there.
pub const SETTLED: f64 = 1e-3;

/// The refinement budget a body gets unless told otherwise (ms): with the network's ~45 ms and
/// the tet mesh, a new shape's basis within 150 ms on 2 cores.
pub const DEFAULT_REFINE_MS: u32 = 60;

/// How long the refinement may run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum RefineBudget {
    /// No iteration: the start block's span itself, on the mesh.
    Off,
    /// Iterations while the time since the refinement began (assembly and factorization
    /// included) plus the last iteration's time stays under this many milliseconds.
    Millis(u32),
    /// At most this many iterations.
    Iterations(u32),
    /// At most this many iterations, ending early once the span has settled: no Ritz value
    /// moved by more than [`SETTLED`] of itself in the last iteration. Reproducible, as
    /// `Iterations` is, and short where the start is good.
    Settled(u32),
    /// Until the Ritz values settle (the refinement's tolerance).
    Full,
}

impl std::str::FromStr for RefineBudget {
    type Err = String;

    /// `off`, `full`, or a budget in milliseconds (`80`), as the node's `inference.refine`
    /// and `eval --refine` take it.
    fn from_str(text: &str) -> std::result::Result<Self, String> {
        match text.trim() {
            "off" => Ok(Self::Off),
            "full" => Ok(Self::Full),
            ms => ms
                .parse()
                .map(Self::Millis)
                .map_err(|_| format!("`{ms}`: want `off`, `full` or milliseconds")),
        }
    }
}

/// The space each iteration's Rayleigh-Ritz picks the k lowest Ritz vectors from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum RefineSearch {
    /// span(A X), k columns: block inverse (subspace) iteration. Mode j converges by
    /// lambda_j / lambda_(k+1) per iteration, slowly where the cut falls in a cluster.
    Subspace,
    /// span[X, A X], up to 2k columns.
    Enriched,
    /// span[X, A X, P], up to 3k columns, P the previous step's update (LOBPCG with the exact
    /// inverse as preconditioner). In a prototype on the crate example's bar, 8 modes from a
    /// random start took 13 to 20 iterations, where subspace iteration took 80 to 220.
    #[default]
    LocallyOptimal,
}

/// How the refinement runs.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefineOptions {
    /// When to stop. Default [`RefineBudget::Full`].
    pub budget: RefineBudget,
    /// The search space per iteration. Default `RefineSearch::LocallyOptimal`.
    pub search: RefineSearch,
    /// Converged when no Ritz value moves by more than this, relative, in one iteration.
    /// Default 1e-10. Every budget stops there.
    pub tolerance: f64,
    /// Iterations at most, whatever the budget. Default 200.
    pub max_iterations: usize,
    /// Extra columns iterated beside the k wanted (seeded at random) and dropped at the end.
    /// They bring in directions the start lacks entirely, which no iteration could create (a
    /// symmetric start misses every mode of the other symmetry), and speed up the k-th mode.
    /// Each costs one more solve per iteration. Default 2.
    pub guard: usize,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self {
            budget: RefineBudget::Full,
            search: RefineSearch::default(),
            tolerance: 1e-10,
            max_iterations: 200,
            guard: 2,
        }
    }
}

/// What the refinement did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RefineReport {
    /// Iterations run.
    pub iterations: usize,
    /// Whether the Ritz values settled to [`RefineOptions::tolerance`].
    pub converged: bool,
    /// The k Ritz values (Rayleigh quotients of the span's Ritz vectors, ascending, 1/m^2):
    /// of the start block first, then after each iteration.
    pub ritz_values: Vec<Vec<f64>>,
    /// Wall time of each iteration, ms.
    pub iteration_ms: Vec<f64>,
    /// Evaluating the start block from a field (`refine_field`; 0 for [`refine`]), ms.
    pub start_ms: f64,
    /// Assembly of L and M, the factorization and the start block's Rayleigh-Ritz, ms.
    pub setup_ms: f64,
    /// The whole refinement, the field's construction (and `start_ms`) included, ms.
    pub total_ms: f64,
}

impl RefineReport {
    /// The sum of the Ritz values per entry of `ritz_values`: it never increases.
    pub fn traces(&self) -> Vec<f64> {
        self.ritz_values.iter().map(|v| v.iter().sum()).collect()
    }
}

/// A refined field and how it was made.
pub struct Refined {
    /// The refined columns on the mesh, interpolated linearly like the eigenmodes (kind
    /// "refined"); its `eigenvalues` are the last Ritz values after the constant's 0.
    pub field: EigenmodeField,
    /// Iterations, Ritz values and times.
    pub report: RefineReport,
}

/// The start block of `field`: its non-constant columns (handles 1..) at the vertices of
/// `mesh` (world units), vertices x (handles - 1). `normalization` maps the mesh into the
/// field's frame. The field is evaluated at the vertices of every other grid line and
/// interpolated (trilinearly, from up to 8 of them) at the rest: a network costs a few
/// microseconds a point, the start only has to hold the field's span, which the iterations
/// then refine, and the field is smooth at the scale of two cells. Vertices whose coarse
/// neighbours are not all in the mesh (near its boundary) are evaluated themselves.
pub fn start_block(
    field: &dyn SkinningField,
    mesh: &TetMesh,
    normalization: &Normalization,
) -> DMatrix<f64> {
    let handles = field.handle_count();
    let plan = CoarseSampling::new(mesh);
    let points: Vec<_> = plan
        .evaluated
        .iter()
        .map(|&v| normalization.to_normalized(&mesh.vertices[v]))
        .collect();
    let mut weights = vec![0.0; points.len() * handles];
    field.evaluate(&points, &mut weights, None);
    DMatrix::from_fn(mesh.vertices.len(), handles.saturating_sub(1), |v, h| {
        plan.stencils[v]
            .iter()
            .map(|&(sample, w)| w * weights[sample * handles + h + 1])
            .sum()
    })
}

/// Which vertices a start block evaluates, and how every vertex is made of them.
struct CoarseSampling {
    /// Vertices evaluated.
    evaluated: Vec<usize>,
    /// Per vertex: (index into `evaluated`, weight), weights adding up to 1.
    stencils: Vec<Vec<(usize, f64)>>,
}

impl CoarseSampling {
    fn new(mesh: &TetMesh) -> Self {
        let grid = mesh.grid();
        let corner = |p: &nalgebra::Vector3<f64>| {
            [0, 1, 2].map(|a| ((p[a] - grid.origin[a]) / grid.cell).round() as i64)
        };
        let corners: Vec<[i64; 3]> = mesh.vertices.iter().map(corner).collect();
        let mut evaluated = Vec::new();
        let mut coarse = std::collections::HashMap::new();
        for (v, c) in corners.iter().enumerate() {
            if c.iter().all(|i| i % 2 == 0) {
                coarse.insert(*c, evaluated.len());
                evaluated.push(v);
            }
        }
        let stencils = corners
            .iter()
            .enumerate()
            .map(|(v, c)| {
                if let Some(&s) = coarse.get(c) {
                    return vec![(s, 1.0)];
                }
                let stencil = coarse_stencil(c, &coarse);
                stencil.unwrap_or_else(|| {
                    evaluated.push(v);
                    vec![(evaluated.len() - 1, 1.0)]
                })
            })
            .collect();
        Self {
            evaluated,
            stencils,
        }
    }
}

/// The trilinear stencil of grid corner `c` over the even corners around it, None when one of
/// them is not a mesh vertex.
fn coarse_stencil(
    c: &[i64; 3],
    coarse: &std::collections::HashMap<[i64; 3], usize>,
) -> Option<Vec<(usize, f64)>> {
    // Per axis: the even line itself, or the two around an odd one, half each.
    let axis = |i: i64| -> Vec<(i64, f64)> {
        if i % 2 == 0 {
            vec![(i, 1.0)]
        } else {
            vec![(i - 1, 0.5), (i + 1, 0.5)]
        }
    };
    let mut stencil = Vec::with_capacity(8);
    for (x, wx) in axis(c[0]) {
        for (y, wy) in axis(c[1]) {
            for (z, wz) in axis(c[2]) {
                stencil.push((*coarse.get(&[x, y, z])?, wx * wy * wz));
            }
        }
    }
    Some(stencil)
}

/// [`refine`] started from `field`'s columns at the mesh's vertices ([`start_block`]); the
/// report's `start_ms` is that evaluation's time.
pub fn refine_field(
    field: &dyn SkinningField,
    mesh: TetMesh,
    normalization: Normalization,
    options: &RefineOptions,
) -> Result<Refined> {
    refine_field_until(field, mesh, normalization, options, &|| false)
}

/// [`refine_field`] that also stops, with what it has, once `stop` says so (checked before
/// each iteration): a node's refinement gives way to a new object's build.
pub fn refine_field_until(
    field: &dyn SkinningField,
    mesh: TetMesh,
    normalization: Normalization,
    options: &RefineOptions,
    stop: &dyn Fn() -> bool,
) -> Result<Refined> {
    let started = Instant::now();
    let start = start_block(field, &mesh, &normalization);
    let start_ms = milliseconds(started);
    let mut refined = refine_until(mesh, normalization, &start, options, stop)?;
    refined.report.start_ms = start_ms;
    refined.report.total_ms += start_ms;
    Ok(refined)
}

/// Refines the span of `start` (vertices x k columns at the vertices of `mesh`, world units;
/// any scale, the constant is removed) toward the k lowest skinning eigenmodes of `mesh`, the
/// modes [`EigenmodeField::compute`] finds with `modes: k`. The field answers in the frame of
/// `normalization`. Fails when `start` does not fit the mesh or a factorization fails.
#[cfg(test)]
pub(crate) fn refine(
    mesh: TetMesh,
    normalization: Normalization,
    start: &DMatrix<f64>,
    options: &RefineOptions,
) -> Result<Refined> {
    refine_until(mesh, normalization, start, options, &|| false)
}

fn refine_until(
    mesh: TetMesh,
    normalization: Normalization,
    start: &DMatrix<f64>,
    options: &RefineOptions,
    stop: &dyn Fn() -> bool,
) -> Result<Refined> {
    let started = Instant::now();
    let (n, k) = (mesh.vertices.len(), start.ncols());
    if start.nrows() != n || k == 0 || k + 1 >= n {
        return Err(Error::InvalidParameter {
            name: "start",
            reason: format!(
                "a start block of {} x {k} for a mesh of {n} vertices (want {n} x 1..{})",
                start.nrows(),
                n.saturating_sub(2)
            ),
        });
    }
    let problem = ModeProblem::assemble(&mesh);
    let cholesky = problem.shifted_cholesky()?;
    let refiner = Refiner { problem, cholesky };
    let (span, span_values) = refiner.start_span(start)?;
    // The block: the start's Ritz vectors and the guard columns, k + guard <= n - 1.
    let guard = options.guard.min(n - 1 - k);
    let (mut x, mut values) = refiner.add_guard(&span, &span_values, guard)?;
    let mut report = RefineReport {
        ritz_values: vec![span_values.clone()],
        setup_ms: milliseconds(started),
        ..Default::default()
    };
    let mut direction: Option<DMatrix<f64>> = None;
    let mut last_ms = 0.0;
    while !stop() && may_iterate(options, report.iterations, milliseconds(started), last_ms) {
        let iteration = Instant::now();
        let step = refiner.step(&x, direction.as_ref(), options.search)?;
        let change = values[..k]
            .iter()
            .zip(&step.values[..k])
            .map(|(&old, &new)| relative_change(old, new))
            .fold(0.0, f64::max);
        (x, values, direction) = (step.x, step.values, step.direction);
        last_ms = milliseconds(iteration);
        report.iteration_ms.push(last_ms);
        report.ritz_values.push(values[..k].to_vec());
        report.iterations += 1;
        if change < options.tolerance {
            report.converged = true;
            break;
        }
        if change < SETTLED && matches!(options.budget, RefineBudget::Settled(_)) {
            break;
        }
    }
    // Without an iteration the field is the start's span itself, untouched by the guard.
    let (columns, values) = if report.iterations == 0 {
        (span, span_values)
    } else {
        (x.columns(0, k).into_owned(), values[..k].to_vec())
    };
    let field = EigenmodeField::from_modes(
        mesh,
        normalization,
        &columns,
        &values,
        report.iterations,
        "refined",
    );
    report.total_ms = milliseconds(started);
    Ok(Refined { field, report })
}

/// Whether the budget leaves room for one more iteration.
fn may_iterate(options: &RefineOptions, done: usize, elapsed_ms: f64, last_ms: f64) -> bool {
    done < options.max_iterations
        && match options.budget {
            RefineBudget::Off => false,
            RefineBudget::Millis(budget) => elapsed_ms + last_ms < budget as f64,
            RefineBudget::Iterations(count) | RefineBudget::Settled(count) => done < count as usize,
            RefineBudget::Full => true,
        }
}

fn relative_change(old: f64, new: f64) -> f64 {
    (old - new).abs() / new.abs().max(1e-300)
}

fn milliseconds(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// One iteration's outcome: the new Ritz vectors, their values, and (locally optimal search)
/// the update P.
struct Step {
    x: DMatrix<f64>,
    values: Vec<f64>,
    direction: Option<DMatrix<f64>>,
}

/// The assembled problem and its factorization.
struct Refiner {
    problem: ModeProblem,
    cholesky: SparseCholesky,
}

impl Refiner {
    /// The Ritz vectors (M-orthonormal, orthogonal to the constant) and values of the start
    /// block's span; directions it lacks (a rank-deficient start) are filled at random.
    fn start_span(&self, start: &DMatrix<f64>) -> Result<(DMatrix<f64>, Vec<f64>)> {
        let k = start.ncols();
        let mut block = start.clone();
        self.problem.deflate_columns(&mut block);
        let mut basis = self.orthonormalize(&block, None)?;
        if basis.ncols() < k {
            let fill = self.random_directions(k - basis.ncols(), &basis, 7)?;
            basis = side_by_side(&basis, &fill);
        }
        if basis.ncols() < k {
            return Err(Error::LinearAlgebra(format!(
                "refine: only {} of {k} start directions are independent",
                basis.ncols()
            )));
        }
        let (values, coefficients) = self.rayleigh_ritz(&basis, k);
        Ok((&basis * &coefficients, values))
    }

    /// The block iterated: `span` (Ritz vectors, `values`) and `guard` random directions, as
    /// Ritz vectors of their joint span, ascending.
    fn add_guard(
        &self,
        span: &DMatrix<f64>,
        values: &[f64],
        guard: usize,
    ) -> Result<(DMatrix<f64>, Vec<f64>)> {
        if guard == 0 {
            return Ok((span.clone(), values.to_vec()));
        }
        let basis = side_by_side(span, &self.random_directions(guard, span, 11)?);
        let (values, coefficients) = self.rayleigh_ritz(&basis, basis.ncols());
        Ok((&basis * &coefficients, values))
    }

    /// `count` random directions (a seeded draw), M-orthonormal, orthogonal to the constant
    /// and to `against` (M-orthonormal columns).
    fn random_directions(
        &self,
        count: usize,
        against: &DMatrix<f64>,
        seed: u64,
    ) -> Result<DMatrix<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut block =
            DMatrix::<f64>::from_fn(self.problem.size(), count, |_, _| rng.random::<f64>() - 0.5);
        self.problem.deflate_columns(&mut block);
        self.orthonormalize(&block, Some(against))
    }

    /// One iteration from the block `x` (Ritz vectors) and, for the locally optimal search,
    /// the previous update `direction`: the new block, as wide as `x`.
    fn step(
        &self,
        x: &DMatrix<f64>,
        direction: Option<&DMatrix<f64>>,
        search: RefineSearch,
    ) -> Result<Step> {
        let k = x.ncols();
        let y = self.problem.inverse_iterate(&self.cholesky, x);
        let basis = match (search, direction) {
            (RefineSearch::Subspace, _) => self.orthonormalize(&y, None)?,
            (RefineSearch::LocallyOptimal, Some(p)) => {
                side_by_side(x, &self.orthonormalize(&side_by_side(&y, p), Some(x))?)
            }
            _ => side_by_side(x, &self.orthonormalize(&y, Some(x))?),
        };
        if basis.ncols() < k {
            return Err(Error::LinearAlgebra(format!(
                "refine: the iterated block kept {} of {k} directions",
                basis.ncols()
            )));
        }
        let (values, coefficients) = self.rayleigh_ritz(&basis, k);
        let rest = basis.ncols() - k;
        let direction = (search == RefineSearch::LocallyOptimal && rest > 0).then(|| {
            // The part of the new X that did not come from the old X.
            basis.columns(k, rest) * coefficients.rows(k, rest)
        });
        Ok(Step {
            x: product(&basis, &coefficients),
            values,
            direction,
        })
    }

    /// The k lowest Ritz values of L on span(`basis`) (M-orthonormal columns), ascending, and
    /// their coefficients in `basis` (columns x k).
    fn rayleigh_ritz(&self, basis: &DMatrix<f64>, k: usize) -> (Vec<f64>, DMatrix<f64>) {
        let lb = self.problem.laplacian_times(basis);
        let eig = symmetric(transpose_product(basis, &lb)).symmetric_eigen();
        let mut order: Vec<usize> = (0..basis.ncols()).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        order.truncate(k);
        let values: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i]).collect();
        let coefficients = DMatrix::from_fn(basis.ncols(), order.len(), |r, c| {
            eig.eigenvectors[(r, order[c])]
        });
        (values, coefficients)
    }

    /// An M-orthonormal basis of the part of span(`z`) M-orthogonal to `against` (M-orthonormal
    /// columns) and to the constant. `z` is orthogonal to the constant already; directions of
    /// `z` (each column scaled to a unit M-norm) within [`DROP`] of span(`against`) or of the
    /// other columns are dropped, so the basis may have fewer columns than `z`.
    fn orthonormalize(
        &self,
        z: &DMatrix<f64>,
        against: Option<&DMatrix<f64>>,
    ) -> Result<DMatrix<f64>> {
        let n = self.problem.size();
        let mz = self.problem.mass_times(z);
        let norms: Vec<f64> = (0..z.ncols())
            .map(|j| z.column(j).dot(&mz.column(j)).sqrt())
            .collect();
        let keep: Vec<usize> = (0..z.ncols()).filter(|&j| norms[j] > 1e-300).collect();
        if keep.is_empty() {
            return Ok(DMatrix::zeros(n, 0));
        }
        let mut z = DMatrix::from_fn(n, keep.len(), |r, c| z[(r, keep[c])] / norms[keep[c]]);
        self.project_out(&mut z, against);
        // Independent directions: the eigenvectors of the Gram matrix above the drop level,
        // each scaled to a unit M-norm.
        let eig = self.gram(&z).symmetric_eigen();
        let strong: Vec<usize> = (0..z.ncols())
            .filter(|&i| eig.eigenvalues[i] > DROP * DROP)
            .collect();
        if strong.is_empty() {
            return Ok(DMatrix::zeros(n, 0));
        }
        let scale = DMatrix::from_fn(z.ncols(), strong.len(), |r, c| {
            eig.eigenvectors[(r, strong[c])] / eig.eigenvalues[strong[c]].sqrt()
        });
        let mut z = product(&z, &scale);
        // The scaling magnified what rounding left along `against` and the constant: project
        // again, then a Cholesky pass restores unit M-norms.
        self.project_out(&mut z, against);
        self.problem.deflate_columns(&mut z);
        let l_inv = self
            .gram(&z)
            .cholesky()
            .and_then(|c| c.l().try_inverse())
            .ok_or_else(|| {
                Error::LinearAlgebra("refine: the block lost rank while orthonormalized".into())
            })?;
        Ok(product(&z, &l_inv.transpose()))
    }

    /// z -= X (X^T M z): removes from z its M-projection on span(`x`) (M-orthonormal columns).
    fn project_out(&self, z: &mut DMatrix<f64>, x: Option<&DMatrix<f64>>) {
        if let Some(x) = x.filter(|x| x.ncols() > 0) {
            let coefficients = transpose_product(x, &self.problem.mass_times(z));
            *z -= product(x, &coefficients);
        }
    }

    /// z^T M z, symmetrized.
    fn gram(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        symmetric(transpose_product(z, &self.problem.mass_times(z)))
    }
}

/// (a + a^T) / 2.
fn symmetric(a: DMatrix<f64>) -> DMatrix<f64> {
    (&a + a.transpose()) * 0.5
}

/// [a, b]: the columns of `a`, then those of `b`.
fn side_by_side(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    DMatrix::from_iterator(
        a.nrows(),
        a.ncols() + b.ncols(),
        a.iter().chain(b.iter()).copied(),
    )
}

#[cfg(test)]
mod tests;
