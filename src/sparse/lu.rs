//! Sparse LU through faer: symbolic analysis once per pattern, numeric factorisation reused.

use super::CscPattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, NumericLu, SymbolicLu};
use faer::sparse::linalg::LuError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};
use thiserror::Error;

/// A sparse linear solve that failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LinearSolveError {
    /// The matrix is not square.
    #[error("matrix is not square ({nrows} × {ncols})")]
    NotSquare {
        /// Rows.
        nrows: usize,
        /// Columns.
        ncols: usize,
    },
    /// The matrix is structurally or numerically singular.
    #[error("matrix is singular{}", match .column { Some(c) => format!(" (no usable pivot in column {c})"), None => String::new() })]
    Singular {
        /// A column (unknown index) where elimination broke down, when known.
        column: Option<usize>,
    },
    /// A matrix value is NaN or infinite.
    #[error("matrix entry ({row}, {col}) is not finite ({value})")]
    NonFiniteEntry {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The value.
        value: f64,
    },
    /// The right-hand side length does not match the matrix.
    #[error("right-hand side has length {got}, expected {expected}")]
    DimensionMismatch {
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// The groups of unknowns given for block elimination are not usable
    /// ([`BlockSchurLu`](super::BlockSchurLu)).
    #[error("invalid elimination blocks: {0}")]
    InvalidBlocks(String),
    /// The matrix has more unknowns or entries than the factorisation's u32 addresses hold.
    #[error("matrix too large to factorise: {unknowns} unknowns, {entries} entries (at most 2³² − 1 each)")]
    TooLarge {
        /// Unknowns.
        unknowns: usize,
        /// Stored entries.
        entries: usize,
    },
    /// faer reported an allocation or internal failure.
    #[error("sparse LU failed inside faer: {0}")]
    Backend(String),
}

/// Sparse LU factorisation of a square matrix with a fixed pattern.
///
/// [`SparseLu::new`] runs the fill-reducing ordering and symbolic analysis once;
/// [`SparseLu::factor`] refactorises numerically, reusing the symbolic structure and the
/// numeric storage; [`SparseLu::solve_in_place`] solves with the latest factors.
pub struct SparseLu {
    pattern: CscPattern,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    factor_buf: MemBuffer,
    solve_buf: MemBuffer,
    factored: bool,
    /// Reciprocal of the largest absolute matrix entry of the last factorisation (scale for
    /// the singularity check on the solution).
    n_factorisations: usize,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu")
            .field("n", &self.pattern.ncols())
            .field("nnz", &self.pattern.nnz())
            .field("factored", &self.factored)
            .finish()
    }
}

/// faer's threshold on (flops / nonzeros) of the factorisation above which the supernodal
/// variant is used, relative to its default of 1. Measured in one `lash bench mr2120` style run
/// (0.5 s of the L1 trajectory, rtol 1e-4): the 63-DOF MR2120 (260 unknowns) takes 0.7 s with
/// faer's default (it picks simplicial) and 0.4 s supernodal (a 2 s run: 7.3 s against 3.5 s);
/// the 1 000-link clearance chain (28 000 unknowns) is 10 % slower supernodal (7.9 s against
/// 7.2 s). 0.25 switches the MR2120 to supernodal; larger, path-like chains follow it too.
/// Rechecked on the MR2120's reduced matrix after block elimination
/// ([`BlockSchurLu`](super::BlockSchurLu): 114 unknowns, 2 106 nonzeros; whole L1 run at rtol
/// 1e-4): 0.18 ms per step supernodal (0.25 or 0) against 0.25 ms simplicial.
pub const SUPERNODAL_THRESHOLD: f64 = 0.25;

/// Checks matrix `values` on `pattern` before a factorisation: one value per entry, all
/// finite (the first NaN or infinite one is reported with its row and column).
pub(crate) fn check_values(pattern: &CscPattern, values: &[f64]) -> Result<(), LinearSolveError> {
    if values.len() != pattern.nnz() {
        return Err(LinearSolveError::DimensionMismatch {
            expected: pattern.nnz(),
            got: values.len(),
        });
    }
    match first_non_finite(values) {
        Some(k) => Err(LinearSolveError::NonFiniteEntry {
            row: pattern.row_idx()[k],
            col: pattern.col_ptr().partition_point(|&p| p <= k) - 1,
            value: values[k],
        }),
        None => Ok(()),
    }
}

/// 1 if `v` is NaN or infinite (its exponent bits all set), else 0: branch-free, so a pass
/// that ORs it over many values vectorises.
#[inline]
pub(crate) fn non_finite_bit(v: f64) -> u64 {
    (((v.to_bits() >> 52) & 0x7ff) + 1) >> 11
}

/// Position of the first NaN or infinite value. One branch-free pass over the exponent bits
/// (an integer OR that vectorises) finds whether there is one; only then is it located.
fn first_non_finite(values: &[f64]) -> Option<usize> {
    let any = values.iter().fold(0u64, |acc, &v| acc | non_finite_bit(v));
    if any == 0 {
        return None;
    }
    values.iter().position(|v| !v.is_finite())
}

fn backend<E: std::fmt::Debug>(e: E) -> LinearSolveError {
    LinearSolveError::Backend(format!("{e:?}"))
}

impl SparseLu {
    /// Symbolic analysis of `pattern` (square), choosing the supernodal or simplicial
    /// factorisation with [`SUPERNODAL_THRESHOLD`].
    pub fn new(pattern: &CscPattern) -> Result<Self, LinearSolveError> {
        Self::with_supernodal_threshold(pattern, SUPERNODAL_THRESHOLD)
    }

    /// As [`new`](Self::new) with faer's flop-ratio threshold for choosing the supernodal
    /// factorisation (0: always supernodal, ∞: always simplicial).
    pub fn with_supernodal_threshold(
        pattern: &CscPattern,
        supernodal_threshold: f64,
    ) -> Result<Self, LinearSolveError> {
        if pattern.nrows() != pattern.ncols() {
            return Err(LinearSolveError::NotSquare {
                nrows: pattern.nrows(),
                ncols: pattern.ncols(),
            });
        }
        let n = pattern.ncols();
        let sym = SymbolicSparseColMatRef::new_checked(n, n, pattern.col_ptr(), None, pattern.row_idx());
        let params = faer::sparse::linalg::lu::LuSymbolicParams {
            supernodal_flop_ratio_threshold: faer::sparse::linalg::SupernodalThreshold(supernodal_threshold),
            ..Default::default()
        };
        let symbolic = factorize_symbolic_lu(sym, params).map_err(backend)?;
        let factor_req = symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default());
        let solve_req = symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        Ok(Self {
            pattern: pattern.clone(),
            symbolic,
            numeric: NumericLu::new(),
            factor_buf: MemBuffer::try_new(factor_req).map_err(backend)?,
            solve_buf: MemBuffer::try_new(solve_req).map_err(backend)?,
            factored: false,
            n_factorisations: 0,
        })
    }

    /// Dimension of the system.
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Number of numeric factorisations done so far.
    pub fn factorisations(&self) -> usize {
        self.n_factorisations
    }

    /// Numeric factorisation of the matrix with `values` on the pattern given to [`new`](Self::new).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        self.factored = false;
        check_values(&self.pattern, values)?;
        let n = self.dim();
        // Safety of indices was checked when the CscPattern was built.
        let sym =
            SymbolicSparseColMatRef::new_checked(n, n, self.pattern.col_ptr(), None, self.pattern.row_idx());
        let mat = SparseColMatRef::new(sym, values);
        let res = self.symbolic.factorize_numeric_lu(
            &mut self.numeric,
            mat,
            Par::Seq,
            MemStack::new(&mut self.factor_buf),
            Default::default(),
        );
        match res {
            Ok(_) => {}
            Err(LuError::SymbolicSingular { index }) => {
                return Err(LinearSolveError::Singular { column: Some(index) })
            }
            Err(e) => return Err(backend(e)),
        }
        self.factored = true;
        self.n_factorisations += 1;
        Ok(())
    }

    /// Solves A·x = b in place (`b` becomes `x`) with the current factors.
    ///
    /// A solution with a non-finite entry reports [`LinearSolveError::Singular`]: faer's
    /// partial pivoting then met a zero pivot.
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        if !self.factored {
            return Err(LinearSolveError::Singular { column: None });
        }
        if b.len() != self.dim() {
            return Err(LinearSolveError::DimensionMismatch {
                expected: self.dim(),
                got: b.len(),
            });
        }
        let n = b.len();
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        LuRef::new_unchecked(&self.symbolic, &self.numeric).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut self.solve_buf),
        );
        if b.iter().any(|v| !v.is_finite()) {
            return Err(LinearSolveError::Singular { column: None });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tridiag(n: usize) -> (CscPattern, Vec<f64>) {
        let mut entries = Vec::new();
        for i in 0..n {
            entries.push((i, i));
            if i > 0 {
                entries.push((i - 1, i));
                entries.push((i, i - 1));
            }
        }
        let p = CscPattern::from_entries(n, n, entries).unwrap();
        let mut v = vec![0.0; p.nnz()];
        for c in 0..n {
            for k in p.col_range(c) {
                v[k] = if p.row_idx()[k] == c { 4.0 } else { -1.0 };
            }
        }
        (p, v)
    }

    #[test]
    fn non_finite_values_are_found_and_finite_ones_pass() {
        assert_eq!(
            first_non_finite(&[1.0, -0.0, f64::MAX, f64::MIN_POSITIVE, 5e-324]),
            None
        );
        assert_eq!(first_non_finite(&[1.0, f64::NAN, 2.0]), Some(1));
        assert_eq!(first_non_finite(&[1.0, 2.0, f64::NEG_INFINITY]), Some(2));
        assert_eq!(first_non_finite(&[]), None);
    }

    #[test]
    fn solves_and_refactors() {
        let (p, mut v) = tridiag(50);
        let mut lu = SparseLu::new(&p).unwrap();
        for round in 0..3 {
            for x in v.iter_mut() {
                *x *= 1.0 + round as f64;
            }
            lu.factor(&v).unwrap();
            let x_true: Vec<f64> = (0..50).map(|i| (i as f64).sin()).collect();
            let mut b = vec![0.0; 50];
            for c in 0..50 {
                for k in p.col_range(c) {
                    b[p.row_idx()[k]] += v[k] * x_true[c];
                }
            }
            lu.solve_in_place(&mut b).unwrap();
            for i in 0..50 {
                assert!((b[i] - x_true[i]).abs() < 1e-12);
            }
        }
        assert_eq!(lu.factorisations(), 3);
    }

    #[test]
    fn singular_is_an_error_not_a_panic() {
        let p = CscPattern::dense(2, 2);
        let mut lu = SparseLu::new(&p).unwrap();
        let r = lu.factor(&[1.0, 2.0, 2.0, 4.0]).and_then(|_| {
            let mut b = vec![1.0, 1.0];
            lu.solve_in_place(&mut b)
        });
        assert!(matches!(r, Err(LinearSolveError::Singular { .. })), "{r:?}");
        assert!(matches!(
            lu.factor(&[f64::NAN, 0.0, 0.0, 1.0]),
            Err(LinearSolveError::NonFiniteEntry { row: 0, col: 0, .. })
        ));
        let zero_col = CscPattern::from_entries(2, 2, [(0, 0), (1, 0)]).unwrap();
        let mut lu = SparseLu::new(&zero_col).unwrap();
        let r = lu
            .factor(&[1.0, 1.0])
            .and_then(|_| lu.solve_in_place(&mut [1.0, 1.0]));
        assert!(r.is_err());
    }
}
