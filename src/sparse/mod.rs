//! Sparse-matrix plumbing: every sparse structure and factorisation in lash goes through here.
//!
//! * [`CscPattern`] — a validated compressed-sparse-column pattern, declared once per problem.
//! * [`SlotIndex`] — (row, column) → value position, for assembling values entry by entry.
//! * [`CscMatrix`] — values on a shared pattern (the pattern is reference-counted, so a
//!   Jacobian and its copies never duplicate the index arrays).
//! * [`SparseLu`] — faer's sparse LU with the symbolic analysis done once per pattern and the
//!   numeric factorisation redone in place.
//! * [`RefactorLu`] — a sparse LU that reuses the pivot sequence of its last pivoting
//!   factorisation (faer's) while the pivots stay acceptable: the numbers only, no search.
//! * [`BlockSchurLu`] — small diagonal blocks eliminated densely first, the sparse LU on the
//!   Schur complement of what remains.
//! * [`DenseLu`] — dense LU with partial pivoting for the multibody analyses' small
//!   systems, solving with A and Aᵀ from one factorisation.
//! * [`column_colouring`] — a greedy colouring of the columns so a finite-difference Jacobian
//!   needs one residual evaluation per colour rather than per column.

mod colouring;
mod dense;
mod lu;
mod pattern;
mod refactor;
mod schur;

pub use colouring::column_colouring;
pub use dense::DenseLu;
pub use lu::{LinearSolveError, SparseLu, SUPERNODAL_THRESHOLD};
pub use pattern::{CscMatrix, CscPattern, PatternError, SlotIndex};
pub use refactor::{RefactorLu, REUSE_PIVOT_THRESHOLD};
pub use schur::{BlockSchurLu, FactorRoute, MAX_GROUP};

/// Helpers of the sparse tests: small dense matrices as patterns and values.
#[cfg(test)]
pub(crate) mod test_util {
    use super::CscPattern;

    /// A dense square matrix as a pattern (its nonzeros, and the entries `keep` names even
    /// when zero) and values.
    pub(crate) fn csc(dense: &[Vec<f64>], keep: impl Fn(usize, usize) -> bool) -> (CscPattern, Vec<f64>) {
        let n = dense.len();
        let mut e = Vec::new();
        for (r, row) in dense.iter().enumerate() {
            for (c, &v) in row.iter().enumerate() {
                if v != 0.0 || keep(r, c) {
                    e.push((r, c));
                }
            }
        }
        let p = CscPattern::from_entries(n, n, e).unwrap();
        let mut vals = vec![0.0; p.nnz()];
        for c in 0..n {
            for k in p.col_range(c) {
                vals[k] = dense[p.row_idx()[k]][c];
            }
        }
        (p, vals)
    }

    /// max_r |(A·x − b)_r|.
    pub(crate) fn residual(dense: &[Vec<f64>], x: &[f64], b: &[f64]) -> f64 {
        dense
            .iter()
            .zip(b)
            .map(|(row, b)| (row.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - b).abs())
            .fold(0.0, f64::max)
    }
}
