//! The problem form: F(t, y, y', p) = 0.

use crate::sparse::CscPattern;
use thiserror::Error;

/// Whether a component of y is differential (its derivative appears in F) or algebraic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarKind {
    /// y'_i appears in the residual.
    Differential,
    /// y'_i does not appear in the residual (a multiplier, a constraint force, …).
    Algebraic,
}

/// How the iteration matrix dF/dy + α·dF/dy' is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianSource {
    /// [`DaeSystem::jacobian`] fills the values on the declared pattern.
    Analytic,
    /// lash computes it by finite differences, one residual per colour of the pattern.
    FiniteDifference,
}

/// A user callback could not evaluate at the given point.
///
/// `Recoverable` makes the solver retry with a smaller step (for example a square root of a
/// negative number just outside the physical domain); `Fatal` stops the run.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EvalError {
    /// The step can be retried with a smaller step size.
    #[error("recoverable evaluation failure: {0}")]
    Recoverable(String),
    /// The run cannot continue.
    #[error("evaluation failed: {0}")]
    Fatal(String),
}

/// A differential-algebraic system in residual form F(t, y, y', p) = 0, with `p` explicit
/// parameters (kept separate from the state so forward sensitivities dy/dp can be added).
///
/// Units are the user's; lash makes no assumption beyond consistency.
///
/// Required: [`dim`](Self::dim), [`residual`](Self::residual),
/// [`jacobian_pattern`](Self::jacobian_pattern). Everything else has a default.
pub trait DaeSystem {
    /// Number of equations and unknowns.
    fn dim(&self) -> usize;

    /// Evaluates the residual `r = F(t, y, yp, p)`.
    fn residual(&mut self, t: f64, y: &[f64], yp: &[f64], p: &[f64], r: &mut [f64]) -> Result<(), EvalError>;

    /// Sparsity pattern of dF/dy + α·dF/dy' (the union of both patterns), declared once.
    fn jacobian_pattern(&self) -> CscPattern;

    /// Where the iteration matrix comes from. Default: finite differences.
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::FiniteDifference
    }

    /// Fills `values` (in the order of [`jacobian_pattern`](Self::jacobian_pattern)) with
    /// dF/dy + α·dF/dy' at (t, y, yp). Called only when
    /// [`jacobian_source`](Self::jacobian_source) is [`JacobianSource::Analytic`].
    fn jacobian(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let _ = (t, y, yp, p, alpha, values);
        Err(EvalError::Fatal(
            "jacobian_source() is Analytic but jacobian() is not implemented".into(),
        ))
    }

    /// Kind of each component. Default: all differential.
    fn var_kinds(&self) -> Vec<VarKind> {
        vec![VarKind::Differential; self.dim()]
    }

    /// Error-test index of each component (1, 2 or 3), as in Hairer & Wanner's RADAU5: the
    /// local error of a component of index j is measured multiplied by min(|h|, 1)^(j−1).
    /// Use 2 for the velocities of a mechanical system with very stiff forces (they behave
    /// like index-2 variables along the stiff directions) and for index-2 multipliers kept
    /// in the error test. Default: all 1.
    fn error_index(&self) -> Vec<u8> {
        vec![1; self.dim()]
    }

    /// Groups of unknowns that [`LinearSolverKind::BlockSchurLu`](super::LinearSolverKind::BlockSchurLu)
    /// eliminates before its sparse LU: each group indexes both unknowns and equations (the
    /// block of those rows and columns must be invertible in the iteration matrix), and
    /// iteration-matrix entries between two different groups are left out of the
    /// factorisation, so declare groups whose mutual coupling is absent or vanishes at the
    /// solution. Default: none.
    fn eliminable_blocks(&self) -> Vec<Vec<usize>> {
        Vec::new()
    }

    /// Projects an accepted solution `y` at time `t` onto invariants the formulation does not
    /// enforce by itself (e.g. position and velocity constraints of an index-1 multibody
    /// formulation, which otherwise drift). Returns `true` if `y` was changed. Default: no
    /// projection.
    fn project(&mut self, t: f64, y: &mut [f64], p: &[f64]) -> bool {
        let _ = (t, y, p);
        false
    }

    /// A readable name of component `i` (used in error reports). Default `y[i]`.
    fn component_name(&self, i: usize) -> String {
        format!("y[{i}]")
    }

    /// Number of event functions g(t, y, y') whose zeros the solver locates.
    fn num_events(&self) -> usize {
        0
    }

    /// Evaluates the event functions into `g` (length [`num_events`](Self::num_events)).
    fn events(&mut self, t: f64, y: &[f64], yp: &[f64], p: &[f64], g: &mut [f64]) {
        let _ = (t, y, yp, p, g);
    }
}
