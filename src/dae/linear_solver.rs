//! The linear-solver seam: what the BDF needs from a linear solver for its iteration
//! matrices (factorise a matrix on a fixed sparse pattern, solve with the factors), the two
//! implementations, and the option that picks one.
//!
//! * [`SparseLu`] — faer's sparse LU (the default): symbolic analysis once per pattern,
//!   numeric refactorisation in place.
//! * [`DenseLu`] — nalgebra's dense LU with partial pivoting, for tiny systems where the
//!   sparse machinery costs more than it saves.
//! * [`BlockSchurLu`] — eliminates the blocks of unknowns the system declares
//!   ([`DaeSystem::eliminable_blocks`](super::DaeSystem::eliminable_blocks)) before faer's
//!   sparse LU on what remains.
//!
//! Another solver (an iterative one, another sparse LU) plugs in by implementing
//! [`LinearSolver`] and adding a [`LinearSolverKind`] variant.

use crate::sparse::{BlockSchurLu, CscPattern, FactorRoute, LinearSolveError, SparseLu};
use nalgebra::{DMatrix, DVector, Dyn, LU};

/// A direct linear solver for matrices with a fixed sparse pattern.
///
/// The solver is built for one pattern (its constructor may analyse it); every
/// [`factor`](Self::factor) passes values on that same pattern.
pub trait LinearSolver: std::fmt::Debug + Send {
    /// Factorises the matrix with `values` on `pattern` (column-major, in the pattern's
    /// order). On error the previous factors are no longer usable.
    fn factor(&mut self, pattern: &CscPattern, values: &[f64]) -> Result<(), LinearSolveError>;
    /// Solves A·x = b in place (`b` becomes `x`) with the latest factors.
    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError>;
    /// How the latest factorisation was reached: a solver with fallbacks says which one it
    /// took (counted in [`Statistics`](super::Statistics)); the default is
    /// [`FactorRoute::Direct`].
    fn last_route(&self) -> FactorRoute {
        FactorRoute::Direct
    }
}

impl LinearSolver for SparseLu {
    fn factor(&mut self, _pattern: &CscPattern, values: &[f64]) -> Result<(), LinearSolveError> {
        SparseLu::factor(self, values)
    }
    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        SparseLu::solve_in_place(self, b)
    }
}

impl LinearSolver for BlockSchurLu {
    fn factor(&mut self, _pattern: &CscPattern, values: &[f64]) -> Result<(), LinearSolveError> {
        BlockSchurLu::factor(self, values)
    }
    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        BlockSchurLu::solve_in_place(self, b)
    }
    fn last_route(&self) -> FactorRoute {
        self.route()
    }
}

/// Which linear solver factorises the BDF's iteration matrices.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LinearSolverKind {
    /// faer's sparse LU ([`SparseLu`]).
    #[default]
    SparseLu,
    /// nalgebra's dense LU ([`DenseLu`]); O(n³) per factorisation, for systems of a few
    /// dozen unknowns at most.
    DenseLu,
    /// Eliminate the system's [`eliminable_blocks`](super::DaeSystem::eliminable_blocks)
    /// densely, then faer's sparse LU on the Schur complement ([`BlockSchurLu`]): a smaller
    /// sparse factorisation when many unknowns sit in small blocks coupled to each other only
    /// weakly (entries between two blocks are left out of the factors). Without blocks it is
    /// [`SparseLu`](Self::SparseLu).
    BlockSchurLu,
}

impl LinearSolverKind {
    /// Builds the solver for matrices on `pattern` (square); `blocks` are the groups of
    /// unknowns [`BlockSchurLu`](Self::BlockSchurLu) eliminates (the other kinds ignore them).
    pub fn build(
        self,
        pattern: &CscPattern,
        blocks: &[Vec<usize>],
    ) -> Result<Box<dyn LinearSolver>, LinearSolveError> {
        Ok(match self {
            LinearSolverKind::SparseLu => Box::new(SparseLu::new(pattern)?),
            LinearSolverKind::DenseLu => Box::new(DenseLu::new(pattern)?),
            LinearSolverKind::BlockSchurLu => Box::new(BlockSchurLu::new(pattern, blocks)?),
        })
    }
}

/// Dense LU with partial pivoting (nalgebra) of a matrix given on a sparse pattern.
#[derive(Debug)]
pub struct DenseLu {
    n: usize,
    lu: Option<LU<f64, Dyn, Dyn>>,
    rhs: DVector<f64>,
}

impl DenseLu {
    /// A dense LU for square matrices on `pattern`.
    pub fn new(pattern: &CscPattern) -> Result<Self, LinearSolveError> {
        if pattern.nrows() != pattern.ncols() {
            return Err(LinearSolveError::NotSquare {
                nrows: pattern.nrows(),
                ncols: pattern.ncols(),
            });
        }
        let n = pattern.ncols();
        Ok(Self {
            n,
            lu: None,
            rhs: DVector::zeros(n),
        })
    }
}

impl LinearSolver for DenseLu {
    fn factor(&mut self, pattern: &CscPattern, values: &[f64]) -> Result<(), LinearSolveError> {
        self.lu = None;
        if pattern.ncols() != self.n || values.len() != pattern.nnz() {
            return Err(LinearSolveError::DimensionMismatch {
                expected: pattern.nnz(),
                got: values.len(),
            });
        }
        let mut a = DMatrix::<f64>::zeros(self.n, self.n);
        for c in 0..self.n {
            for k in pattern.col_range(c) {
                let r = pattern.row_idx()[k];
                if !values[k].is_finite() {
                    return Err(LinearSolveError::NonFiniteEntry {
                        row: r,
                        col: c,
                        value: values[k],
                    });
                }
                a[(r, c)] = values[k];
            }
        }
        let lu = a.lu();
        if !lu.is_invertible() {
            let u = lu.u();
            let column = (0..self.n).find(|&i| u[(i, i)] == 0.0);
            return Err(LinearSolveError::Singular { column });
        }
        self.lu = Some(lu);
        Ok(())
    }

    fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        let Some(lu) = &self.lu else {
            return Err(LinearSolveError::Singular { column: None });
        };
        if b.len() != self.n {
            return Err(LinearSolveError::DimensionMismatch {
                expected: self.n,
                got: b.len(),
            });
        }
        self.rhs.as_mut_slice().copy_from_slice(b);
        if !lu.solve_mut(&mut self.rhs) || self.rhs.iter().any(|v| !v.is_finite()) {
            return Err(LinearSolveError::Singular { column: None });
        }
        b.copy_from_slice(self.rhs.as_slice());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_and_sparse_lu_solve_the_same_system() {
        // [[4, 0, 1], [1, 3, 0], [0, 2, 5]] in CSC.
        let pattern = CscPattern::new(3, 3, vec![0, 2, 4, 6], vec![0, 1, 1, 2, 0, 2]).unwrap();
        let values = [4.0, 1.0, 3.0, 2.0, 1.0, 5.0];
        let mut x = [vec![1.0, 2.0, 3.0], vec![1.0, 2.0, 3.0]];
        for (kind, x) in [LinearSolverKind::SparseLu, LinearSolverKind::DenseLu]
            .into_iter()
            .zip(x.iter_mut())
        {
            let mut s = kind.build(&pattern, &[]).unwrap();
            s.factor(&pattern, &values).unwrap();
            s.solve_in_place(x).unwrap();
        }
        for i in 0..3 {
            assert!((x[0][i] - x[1][i]).abs() < 1e-14, "{x:?}");
        }
        // A x = b check on the dense result.
        let b = [
            4.0 * x[1][0] + x[1][2],
            x[1][0] + 3.0 * x[1][1],
            2.0 * x[1][1] + 5.0 * x[1][2],
        ];
        assert!((b[0] - 1.0).abs() < 1e-14 && (b[1] - 2.0).abs() < 1e-14 && (b[2] - 3.0).abs() < 1e-14);
    }

    #[test]
    fn dense_lu_reports_a_singular_matrix() {
        let pattern = CscPattern::dense(2, 2);
        let mut s = DenseLu::new(&pattern).unwrap();
        let err = s.factor(&pattern, &[1.0, 2.0, 2.0, 4.0]).unwrap_err();
        assert!(matches!(err, LinearSolveError::Singular { .. }), "{err}");
        assert!(s.solve_in_place(&mut [1.0, 1.0]).is_err());
    }
}
