//! Linear algebra glue: a symmetric sparse pattern assembled from elements, its sparse Cholesky
//! (faer), and a dense Cholesky for the reduced systems.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{MatMut, Par, Side};
use rayon::prelude::*;

use nalgebra::Vector3;

use crate::error::{Error, Result};

/// The upper triangle (row <= column) of a symmetric matrix whose nonzeros couple the nodes of
/// each element, with `block` scalar unknowns per node (1 for a Laplacian, 3 for elasticity).
/// Element-local entries map to value slots precomputed once, so assembly is a scatter.
pub struct ElementPattern {
    size: usize,
    block: usize,
    nodes_per_element: usize,
    symbolic: SymbolicSparseColMat<usize>,
    /// Per element, per local (row, col) scalar pair with global row <= global col: the slot,
    /// or `usize::MAX` for the lower half.
    slots: Vec<u32>,
}

impl ElementPattern {
    /// The pattern of `elements` (each a list of node indices, all as long as the first) over
    /// `node_count` nodes with `block` unknowns each. Panics when an element names a node past
    /// `node_count`.
    pub fn new(node_count: usize, block: usize, elements: &[impl AsRef<[u32]>]) -> Self {
        let size = node_count * block;
        let nodes_per_element = elements.first().map_or(0, |e| e.as_ref().len());
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); size];
        for e in elements {
            for &a in e.as_ref() {
                for &b in e.as_ref() {
                    for d in 0..block {
                        for f in 0..block {
                            let (r, c) = (a as usize * block + d, b as usize * block + f);
                            if r <= c {
                                columns[c].push(r);
                            }
                        }
                    }
                }
            }
        }
        let mut col_ptr = vec![0usize; size + 1];
        let mut row_idx = Vec::new();
        for (c, rows) in columns.iter_mut().enumerate() {
            rows.sort_unstable();
            rows.dedup();
            row_idx.extend_from_slice(rows);
            col_ptr[c + 1] = row_idx.len();
        }
        let local = nodes_per_element * block;
        let mut slots = Vec::with_capacity(elements.len() * local * local);
        for e in elements {
            let e = e.as_ref();
            for i in 0..local {
                for j in 0..local {
                    let r = e[i / block] as usize * block + i % block;
                    let c = e[j / block] as usize * block + j % block;
                    slots.push(if r <= c {
                        let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                        (col_ptr[c] + rows.binary_search(&r).expect("in pattern")) as u32
                    } else {
                        u32::MAX
                    });
                }
            }
        }
        let symbolic = SymbolicSparseColMat::new_checked(size, size, col_ptr, None, row_idx);
        Self {
            size,
            block,
            nodes_per_element,
            symbolic,
            slots,
        }
    }

    /// The number of stored entries (the upper triangle).
    pub fn nonzeros(&self) -> usize {
        self.symbolic.row_idx().len()
    }

    /// Zeroed values for this pattern.
    pub fn zeros(&self) -> Vec<f64> {
        vec![0.0; self.nonzeros()]
    }

    /// Adds the element's dense local matrix (row-major, (nodes * block)^2) into `values`.
    pub fn add_element(&self, values: &mut [f64], element: usize, local: &[f64]) {
        let n = self.nodes_per_element * self.block;
        let slots = &self.slots[element * n * n..(element + 1) * n * n];
        for (slot, v) in slots.iter().zip(local) {
            if *slot != u32::MAX {
                values[*slot as usize] += v;
            }
        }
    }

    /// Adds `value` at (i, i).
    pub fn add_diagonal(&self, values: &mut [f64], i: usize, value: f64) {
        let rows = self.column_rows(i);
        let k = rows.binary_search(&i).expect("diagonal in pattern");
        values[self.symbolic.col_ptr()[i] + k] += value;
    }

    /// Adds `value` at (row, col) of the upper triangle (row <= col).
    pub fn add_at(&self, values: &mut [f64], row: usize, col: usize, value: f64) {
        let (row, col) = (row.min(col), row.max(col));
        let k = self
            .column_rows(col)
            .binary_search(&row)
            .expect("entry in pattern");
        values[self.symbolic.col_ptr()[col] + k] += value;
    }

    /// Turns the rows and columns of `fixed` unknowns into identity rows, so a solve leaves them 0.
    pub fn constrain(&self, values: &mut [f64], fixed: &[bool]) {
        let ptr = self.symbolic.col_ptr();
        let rows = self.symbolic.row_idx();
        for c in 0..self.size {
            for k in ptr[c]..ptr[c + 1] {
                let r = rows[k];
                if fixed[r] || fixed[c] {
                    values[k] = if r == c { 1.0 } else { 0.0 };
                }
            }
        }
    }

    /// The diagonal entries.
    pub fn diagonal(&self, values: &[f64]) -> Vec<f64> {
        let ptr = self.symbolic.col_ptr();
        (0..self.size)
            .map(|c| {
                let rows = self.column_rows(c);
                rows.binary_search(&c).map_or(0.0, |k| values[ptr[c] + k])
            })
            .collect()
    }

    fn column_rows(&self, c: usize) -> &[usize] {
        let ptr = self.symbolic.col_ptr();
        &self.symbolic.row_idx()[ptr[c]..ptr[c + 1]]
    }

    /// y = A x for the symmetric matrix with these upper-triangle values.
    pub fn multiply(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        let ptr = self.symbolic.col_ptr();
        let rows = self.symbolic.row_idx();
        for c in 0..self.size {
            for k in ptr[c]..ptr[c + 1] {
                let r = rows[k];
                y[r] += values[k] * x[c];
                if r != c {
                    y[c] += values[k] * x[r];
                }
            }
        }
    }

    /// A Cholesky factorization with this pattern's symbolic analysis (ordering) done once.
    pub fn cholesky(&self) -> Result<SparseCholesky> {
        let symbolic = factorize_symbolic_cholesky(
            self.symbolic.as_ref(),
            Side::Upper,
            Default::default(),
            Default::default(),
        )
        .map_err(|e| Error::LinearAlgebra(format!("symbolic Cholesky: {e:?}")))?;
        Ok(SparseCholesky {
            symbolic,
            values: None,
        })
    }
}

/// Sparse LL^T of matrices sharing one pattern: symbolic once, numeric per matrix.
pub struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
    /// The factor's values, once factored.
    values: Option<Vec<f64>>,
}

/// Right-hand sides solved together on one thread. A fixed width, not one per thread, so that
/// a column's rounding does not depend on how many cores the machine has.
const SOLVE_CHUNK: usize = 4;

impl SparseCholesky {
    /// Factors the matrix with `pattern`'s structure and these values; fails if it is not
    /// positive definite.
    pub fn factor(&mut self, pattern: &ElementPattern, values: &[f64]) -> Result<()> {
        let matrix = SparseColMatRef::new(pattern.symbolic.as_ref(), values);
        // On the calling thread: faer's parallel factorization was slower on 2 cores (the
        // refinement's 7,709-vertex Laplacian 44 ms against 35 ms; the creature's FEM step
        // 396 ms against 372 ms, printed), and a node's refinement should leave the other core
        // to the stepping thread.
        let par = Par::Seq;
        let mut factor = vec![0.0; self.symbolic.len_val()];
        let scratch = self
            .symbolic
            .factorize_numeric_llt_scratch::<f64>(par, Default::default());
        self.symbolic
            .factorize_numeric_llt(
                &mut factor,
                matrix,
                Side::Upper,
                Default::default(),
                par,
                MemStack::new(&mut MemBuffer::new(scratch)),
                Default::default(),
            )
            .map_err(|e| Error::LinearAlgebra(format!("sparse Cholesky: {e:?}")))?;
        self.values = Some(factor);
        Ok(())
    }

    /// Solves in place for every column of `rhs` (column-major, `rhs.len() / n` columns).
    /// Several columns are solved in chunks side by side on rayon's threads, each chunk on one
    /// thread: faer's own parallel solve splits every small supernode across threads, and on
    /// two cores the hand-offs cost more than they gain.
    pub fn solve(&self, rhs: &mut [f64], n: usize) {
        let values = self.values.as_deref().expect("factor before solve");
        let factor = LltRef::new(&self.symbolic, values);
        let cols = rhs.len() / n;
        if cols == 1 {
            return solve_chunk(factor, rhs, n, faer::get_global_parallelism());
        }
        rhs.par_chunks_mut(n * SOLVE_CHUNK)
            .for_each(|chunk| solve_chunk(factor, chunk, n, Par::Seq));
    }
}

/// Solves `factor` in place for the columns of `rhs` (column-major, n rows).
fn solve_chunk(factor: LltRef<'_, usize, f64>, rhs: &mut [f64], n: usize, par: Par) {
    let cols = rhs.len() / n;
    let scratch = factor.solve_in_place_scratch::<f64>(cols, par);
    factor.solve_in_place_with_conj(
        faer::Conj::No,
        MatMut::from_column_major_slice_mut(rhs, n, cols),
        par,
        MemStack::new(&mut MemBuffer::new(scratch)),
    );
}

/// Multiply-adds below which `product` is nalgebra's: a one-handle body's 3 x 4 by 4 x 4.
const SMALL_PRODUCT: usize = 1024;

/// `a b` for nalgebra matrices, by faer's matrix product on the calling thread. nalgebra's own
/// product of a 3-row matrix by a wide one runs column by column: for a body's thousand contact
/// points it cost more than the rest of the step. Below `SMALL_PRODUCT` multiply-adds, where
/// faer's dispatch would cost more than the product, nalgebra's.
pub fn product(a: &nalgebra::DMatrix<f64>, b: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
    assert_eq!(a.ncols(), b.nrows(), "inner dimensions of a product");
    if a.nrows() * a.ncols() * b.ncols() < SMALL_PRODUCT {
        return a * b;
    }
    let mut out = nalgebra::DMatrix::zeros(a.nrows(), b.ncols());
    let (rows, cols) = out.shape();
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(out.as_mut_slice(), rows, cols),
        faer::Accum::Replace,
        faer::MatRef::from_column_major_slice(a.as_slice(), a.nrows(), a.ncols()),
        faer::MatRef::from_column_major_slice(b.as_slice(), b.nrows(), b.ncols()),
        1.0,
        Par::Seq,
    );
    out
}

/// `a^T b` for nalgebra matrices, by faer's matrix product on the calling thread. nalgebra's
/// `tr_mul` takes one dot product per entry: for the refinement's Gram matrices of a few
/// dozen columns over thousands of vertices it cost as much as the sparse solves.
pub fn transpose_product(
    a: &nalgebra::DMatrix<f64>,
    b: &nalgebra::DMatrix<f64>,
) -> nalgebra::DMatrix<f64> {
    assert_eq!(
        a.nrows(),
        b.nrows(),
        "inner dimensions of a transposed product"
    );
    if a.nrows() * a.ncols() * b.ncols() < SMALL_PRODUCT {
        return a.tr_mul(b);
    }
    let mut out = nalgebra::DMatrix::zeros(a.ncols(), b.ncols());
    let (rows, cols) = out.shape();
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(out.as_mut_slice(), rows, cols),
        faer::Accum::Replace,
        faer::MatRef::from_column_major_slice(a.as_slice(), a.nrows(), a.ncols()).transpose(),
        faer::MatRef::from_column_major_slice(b.as_slice(), b.nrows(), b.ncols()),
        1.0,
        Par::Seq,
    );
    out
}

/// out += a b^T with faer, on the calling thread: nalgebra's `gemm` over a transposed view
/// ran a matrix-vector product per column (a third of the cell's step, spreading its sticks'
/// forces, in a `perf` of `bench scene`, printed).
pub fn add_product_transposed(
    out: &mut nalgebra::DMatrix<f64>,
    a: &nalgebra::DMatrix<f64>,
    b: &nalgebra::DMatrix<f64>,
) {
    assert_eq!(a.ncols(), b.ncols(), "inner dimensions of a product");
    assert_eq!(out.shape(), (a.nrows(), b.nrows()), "shape of a product");
    let (rows, cols) = out.shape();
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(out.as_mut_slice(), rows, cols),
        faer::Accum::Add,
        faer::MatRef::from_column_major_slice(a.as_slice(), a.nrows(), a.ncols()),
        faer::MatRef::from_column_major_slice(b.as_slice(), b.nrows(), b.ncols()).transpose(),
        1.0,
        Par::Seq,
    );
}

/// a b^T where it is known to be symmetric (b = a diag(s), a Gram matrix): faer forms its
/// lower triangle, half the work of the whole product, and the upper is mirrored from it. A
/// landing body's springs' curvature is such a product over a few hundred points, four or
/// five times within a step; formed whole, it and the held matrix's turn beside it took
/// 0.12-0.48 ms of each refactor with 200-odd springs (printed).
pub fn symmetric_product(
    a: &nalgebra::DMatrix<f64>,
    b: &nalgebra::DMatrix<f64>,
) -> nalgebra::DMatrix<f64> {
    use faer::linalg::matmul::triangular::{matmul, BlockStructure};
    assert_eq!(a.shape(), b.shape(), "a b^T of one shape");
    let n = a.nrows();
    let mut out = nalgebra::DMatrix::zeros(n, n);
    matmul(
        MatMut::from_column_major_slice_mut(out.as_mut_slice(), n, n),
        BlockStructure::TriangularLower,
        faer::Accum::Replace,
        faer::MatRef::from_column_major_slice(a.as_slice(), n, a.ncols()),
        BlockStructure::Rectangular,
        faer::MatRef::from_column_major_slice(b.as_slice(), n, b.ncols()).transpose(),
        BlockStructure::Rectangular,
        1.0,
        Par::Seq,
    );
    out.fill_upper_triangle_with_lower_triangle();
    out
}

/// Dense LL^T of a symmetric positive definite matrix (column-major, n x n): faer's blocked
/// factorization, run on the calling thread. At the reduced sizes (a few hundred) thread
/// hand-offs cost more than they save; at 204 unknowns it took 0.070 ms where nalgebra's
/// unblocked one took 0.155 ms, and the quasi-Newton solver refactors whenever contact changes.
/// Only the lower triangle of the matrix is read, by the factorization and by what uses it.
pub struct DenseCholesky {
    /// L in the lower triangle, column-major; the upper triangle is whatever was given.
    factor: Vec<f64>,
    n: usize,
}

impl DenseCholesky {
    /// Factors the n x n column-major `matrix`, reading its lower triangle. An
    /// [`Error::LinearAlgebra`] when it is not positive definite; panics when `matrix` does not
    /// hold n * n values.
    pub fn new(matrix: &[f64], n: usize) -> Result<Self> {
        Self::in_place(matrix.to_vec(), n)
    }

    /// As [`DenseCholesky::new`], factoring `matrix` where it lies: a landing body refactors
    /// several times within a step, and a copy of its 333 KB matrix cost 13-47 us of each
    /// 114-209 us factorization (printed).
    pub fn in_place(mut matrix: Vec<f64>, n: usize) -> Result<Self> {
        use faer::linalg::cholesky::llt::factor;
        assert_eq!(matrix.len(), n * n, "a dense n x n matrix");
        let a = MatMut::from_column_major_slice_mut(&mut matrix, n, n);
        let scratch = factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default());
        let mut buffer = faer::dyn_stack::MemBuffer::new(scratch);
        let stack = faer::dyn_stack::MemStack::new(&mut buffer);
        let factored =
            factor::cholesky_in_place(a, Default::default(), Par::Seq, stack, Default::default());
        let factor = Self { factor: matrix, n };
        if factored.is_err() || !factor.definite() {
            return Err(Error::LinearAlgebra(
                "dense Cholesky: the matrix is not positive definite".into(),
            ));
        }
        Ok(factor)
    }

    /// Whether the factor's diagonal is positive and finite: a NaN pivot passes faer's sign
    /// test.
    fn definite(&self) -> bool {
        (0..self.n).all(|i| {
            let d = self.factor[i * (self.n + 1)];
            d.is_finite() && d > 0.0
        })
    }

    /// The factor L as faer sees it.
    fn lower(&self) -> faer::MatRef<'_, f64> {
        faer::MatRef::from_column_major_slice(&self.factor, self.n, self.n)
    }

    /// The factor of A + W diag(alphas) W^T from that of A, for the n x r column-major
    /// `vectors` W: O(r n^2), where factoring anew is O(n^3). Negative alphas take terms out.
    /// An [`Error::LinearAlgebra`] when the result is not positive definite; the factor is then
    /// spoiled and must be made anew. Panics when the sizes disagree.
    pub fn update(&mut self, vectors: &[f64], alphas: &[f64]) -> Result<()> {
        use faer::linalg::cholesky::llt::update::rank_r_update_clobber;
        let n = self.n;
        assert_eq!(
            vectors.len(),
            n * alphas.len(),
            "n x r vectors for r alphas"
        );
        if alphas.is_empty() {
            return Ok(());
        }
        let mut w = faer::Mat::from_fn(n, alphas.len(), |i, j| vectors[i + j * n]);
        let mut alpha = faer::Col::from_fn(alphas.len(), |j| alphas[j]);
        let updated = rank_r_update_clobber(
            MatMut::from_column_major_slice_mut(&mut self.factor, n, n),
            w.as_mut(),
            alpha.as_mut().as_diagonal_mut(),
        );
        if updated.is_err() || !self.definite() {
            return Err(Error::LinearAlgebra(
                "dense Cholesky update: the result is not positive definite".into(),
            ));
        }
        Ok(())
    }

    /// Solves in place for the columns of `rhs` (column-major, n rows).
    pub fn solve(&self, rhs: &mut [f64]) {
        let n = self.n;
        let cols = rhs.len() / n;
        let rhs = MatMut::from_column_major_slice_mut(rhs, n, cols);
        let mut buffer = faer::dyn_stack::MemBuffer::new(faer::dyn_stack::StackReq::EMPTY);
        faer::linalg::cholesky::llt::solve::solve_in_place(
            self.lower(),
            rhs,
            Par::Seq,
            faer::dyn_stack::MemStack::new(&mut buffer),
        );
    }
}

/// Two unit vectors orthogonal to the unit `normal` and to each other, (normal x helper,
/// normal x that) for a helper axis well away from `normal`: contact tangents, a view's axes,
/// the plane across a long object's axis.
pub(crate) fn tangents(normal: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let helper = if normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let t1 = normal.cross(&helper).normalize();
    let t2 = normal.cross(&t1);
    [t1, t2]
}

#[cfg(test)]
mod product_tests {
    use super::*;

    /// Terms added and taken out again leave the factor of the matrix they make, to round-off.
    #[test]
    fn an_updated_factor_solves_as_a_fresh_one() {
        let n = 24;
        let a = nalgebra::DMatrix::from_fn(n, n, |r, c| ((r * 7 + c * 3) % 11) as f64 - 5.0);
        let base = &a * a.transpose() + nalgebra::DMatrix::identity(n, n) * 10.0;
        let w = nalgebra::DMatrix::from_fn(n, 3, |r, c| ((r * 5 + c * 2) % 7) as f64 - 3.0);
        let mut factor = DenseCholesky::new(base.as_slice(), n).expect("definite");
        factor
            .update(w.as_slice(), &[1e4, 2.0, 30.0])
            .expect("still definite");
        factor
            .update(w.columns(1, 1).clone_owned().as_slice(), &[-2.0])
            .expect("definite");
        let mut matrix = base.clone();
        for (j, alpha) in [(0, 1e4), (2, 30.0)] {
            matrix += w.column(j) * w.column(j).transpose() * alpha;
        }
        let fresh = DenseCholesky::new(matrix.as_slice(), n).expect("definite");
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut x, mut y) = (rhs.clone(), rhs);
        factor.solve(&mut x);
        fresh.solve(&mut y);
        let difference: f64 = x.iter().zip(&y).map(|(a, b)| (a - b).powi(2)).sum();
        let size: f64 = y.iter().map(|b| b * b).sum();
        assert!(difference.sqrt() <= 1e-9 * size.sqrt());
        // Taking out more than is there is refused.
        assert!(factor
            .update(w.columns(1, 1).clone_owned().as_slice(), &[-1e9])
            .is_err());
    }

    /// A Gram product formed by its lower triangle is the whole product.
    #[test]
    fn a_symmetric_product_is_the_whole_product() {
        let a = nalgebra::DMatrix::from_fn(68, 230, |r, c| ((r * 7 + c * 3) % 11) as f64 - 5.0);
        let b = nalgebra::DMatrix::from_fn(68, 230, |r, c| a[(r, c)] * (1.0 + (c % 5) as f64));
        let expected = &a * b.transpose();
        assert!((symmetric_product(&a, &b) - &expected).amax() <= 1e-12 * expected.amax());
    }

    /// A factor made from the lower triangle alone (NaN above it), updated and solved with,
    /// gives what one made from the whole matrix gives; at 204 unknowns, the solver's size.
    #[test]
    fn only_the_lower_triangle_is_read() {
        let n = 204;
        let a = nalgebra::DMatrix::from_fn(n, n, |r, c| ((r * 7 + c * 3) % 11) as f64 - 5.0);
        let matrix = &a * a.transpose() + nalgebra::DMatrix::identity(n, n) * 10.0;
        let mut lower = matrix.clone();
        for c in 1..n {
            for r in 0..c {
                lower[(r, c)] = f64::NAN;
            }
        }
        let w = nalgebra::DMatrix::from_fn(n, 2, |r, c| ((r * 5 + c * 2) % 7) as f64 - 3.0);
        let solved = |mut factor: DenseCholesky| {
            factor.update(w.as_slice(), &[3.0, 40.0]).expect("definite");
            let mut x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            factor.solve(&mut x);
            nalgebra::DVector::from_vec(x)
        };
        let whole = solved(DenseCholesky::new(matrix.as_slice(), n).expect("definite"));
        let from_lower = solved(DenseCholesky::in_place(lower.data.into(), n).expect("definite"));
        assert!(from_lower.iter().all(|v| v.is_finite()));
        assert!((&from_lower - &whole).norm() <= 1e-12 * whole.norm());
        let updated = matrix
            + &w * nalgebra::DMatrix::from_diagonal(&nalgebra::dvector![3.0, 40.0]) * w.transpose();
        let rhs = nalgebra::DVector::from_fn(n, |i, _| (i as f64 * 0.37).sin());
        assert!((updated * &whole - &rhs).norm() <= 1e-9 * rhs.norm());
    }

    #[test]
    fn add_product_transposed_adds_a_times_b_transposed() {
        let a = nalgebra::DMatrix::from_fn(3, 40, |r, c| ((r * 7 + c * 3) % 11) as f64 - 5.0);
        let b = nalgebra::DMatrix::from_fn(68, 40, |r, c| ((r * 5 + c) % 13) as f64 * 0.25);
        let start = nalgebra::DMatrix::from_fn(3, 68, |r, c| (r + c) as f64);
        let mut out = start.clone();
        add_product_transposed(&mut out, &a, &b);
        let expected = start + &a * b.transpose();
        assert!((out - &expected).amax() <= 1e-12 * expected.amax());
    }

    #[test]
    fn transpose_product_is_a_transposed_times_b() {
        let a = nalgebra::DMatrix::from_fn(300, 7, |r, c| ((r * 7 + c * 3) % 11) as f64 - 5.0);
        let b = nalgebra::DMatrix::from_fn(300, 9, |r, c| ((r * 5 + c) % 13) as f64 * 0.25);
        let expected = a.transpose() * &b;
        assert!((transpose_product(&a, &b) - &expected).amax() <= 1e-12 * expected.amax());
    }

    /// Many right-hand sides solved in chunks on rayon's threads give each column what it
    /// gets solved alone, and solve the system: a chain of springs, pinned by a diagonal.
    #[test]
    fn a_sparse_solve_of_many_columns_solves_each() {
        let n = 500;
        let edges: Vec<[u32; 2]> = (0..n as u32 - 1).map(|i| [i, i + 1]).collect();
        let pattern = ElementPattern::new(n, 1, &edges);
        let mut values = vec![0.0; pattern.symbolic.row_idx().len()];
        for &[i, j] in &edges {
            let (i, j) = (i as usize, j as usize);
            pattern.add_diagonal(&mut values, i, 1.0);
            pattern.add_diagonal(&mut values, j, 1.0);
            pattern.add_at(&mut values, i, j, -1.0);
        }
        (0..n).for_each(|i| pattern.add_diagonal(&mut values, i, 0.01));
        let mut cholesky = pattern.cholesky().expect("symbolic");
        cholesky.factor(&pattern, &values).expect("definite");
        let columns = 11;
        let rhs: Vec<f64> = (0..n * columns).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut together = rhs.clone();
        cholesky.solve(&mut together, n);
        for (c, expected) in together.chunks(n).enumerate() {
            let mut alone = rhs[c * n..(c + 1) * n].to_vec();
            cholesky.solve(&mut alone, n);
            let gap = alone.iter().zip(expected).map(|(a, b)| (a - b).abs());
            assert!(gap.fold(0.0, f64::max) <= 1e-12, "column {c}");
            let mut applied = vec![0.0; n];
            pattern.multiply(&values, expected, &mut applied);
            let residual = applied
                .iter()
                .zip(&rhs[c * n..])
                .map(|(a, b)| (a - b).abs());
            assert!(residual.fold(0.0, f64::max) <= 1e-9, "column {c}");
        }
    }
}
