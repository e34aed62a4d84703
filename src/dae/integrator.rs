//! One interface over every time integrator: advance to a time, read the time and state
//! reached, count the work.
//!
//! Implemented by lash's [`BdfSolver`], the explicit baselines [`Dopri5`] and
//! [`SymplecticEuler`], and (feature `peers`) the stepping wrapper around diffsol's BDF in
//! [`crate::peers`]. Drivers that sample a run (benchmarks, cross-checks) take
//! `&mut dyn Integrator` and need no per-solver loop.
//!
//! ```
//! use lash::dae::explicit::{Dopri5, Dopri5Options, OdeSystem};
//! use lash::dae::{EvalError, Integrator};
//!
//! /// y' = -y.
//! struct Decay;
//! impl OdeSystem for Decay {
//!     fn dim(&self) -> usize { 1 }
//!     fn rhs(&mut self, _t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
//!         dy[0] = -y[0];
//!         Ok(())
//!     }
//! }
//! let mut dp = Dopri5::new(Decay, 0.0, &[1.0], &[], Dopri5Options::default())?;
//! let integ: &mut dyn Integrator = &mut dp;
//! for t in [0.5, 1.0] {
//!     integ.advance_to(t)?;
//! }
//! assert_eq!(integ.t(), 1.0);
//! assert!((integ.y()[0] - (-1.0f64).exp()).abs() < 1e-5);
//! assert!(integ.work().steps > 0);
//! # Ok::<(), lash::dae::IntegratorError>(())
//! ```

use super::bdf::{BdfSolver, Outcome};
use super::error::DaeError;
use super::explicit::{Dopri5, ExplicitError, ExplicitStats, OdeSystem, SecondOrderSystem, SymplecticEuler};
use super::options::Statistics;
use super::problem::DaeSystem;

/// Work counters every integrator reports: the common subset of the BDF's richer
/// [`Statistics`] (which stays available from [`BdfSolver::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkStats {
    /// Accepted steps.
    pub steps: usize,
    /// Rejected step attempts (error test and, for implicit methods, nonlinear-solver
    /// failures).
    pub rejected: usize,
    /// Residual or right-hand-side evaluations, including those spent in finite-difference
    /// Jacobians.
    pub rhs_evals: usize,
    /// Jacobian (iteration-matrix) evaluations; 0 for explicit methods.
    pub jacobian_evals: usize,
    /// Successful LU factorisations; 0 for explicit methods.
    pub factorisations: usize,
    /// Newton (nonlinear-solver) iterations; 0 for explicit methods.
    pub newton_iters: usize,
}

impl From<&Statistics> for WorkStats {
    fn from(s: &Statistics) -> Self {
        Self {
            steps: s.steps,
            rejected: s.error_test_failures + s.newton_failures,
            rhs_evals: s.residual_evals,
            jacobian_evals: s.jacobian_evals,
            factorisations: s.lu_factorisations,
            newton_iters: s.newton_iters,
        }
    }
}

impl From<&ExplicitStats> for WorkStats {
    fn from(s: &ExplicitStats) -> Self {
        Self {
            steps: s.steps,
            rejected: s.rejected,
            rhs_evals: s.rhs_evals,
            ..Self::default()
        }
    }
}

/// Why [`Integrator::advance_to`] failed: the integrator's own error, unchanged.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntegratorError {
    /// lash's BDF failed.
    #[error(transparent)]
    Dae(#[from] DaeError),
    /// An explicit integrator failed.
    #[error(transparent)]
    Explicit(#[from] ExplicitError),
    /// An integrator outside the dae layer (a peer solver, or a driver wrapping one of
    /// lash's) failed; the message says why.
    #[error("{0}")]
    Other(String),
}

/// A time integrator advanced from output time to output time.
pub trait Integrator {
    /// Integrates forward to `t` and makes the solution there current. An integrator may
    /// return earlier without error when it was told to stop there (the BDF's stop time or
    /// events): [`t`](Self::t) says where it is.
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError>;
    /// Time of the current solution, s.
    fn t(&self) -> f64;
    /// Current solution, in the integrator's own layout (the BDF's y; Dormand–Prince's y;
    /// symplectic Euler's positions followed by its velocities).
    fn y(&self) -> &[f64];
    /// Work counters so far (cumulative).
    fn work(&self) -> WorkStats;
}

impl<P: DaeSystem> Integrator for BdfSolver<P> {
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError> {
        let _: Outcome = self.solve_to(t)?;
        Ok(())
    }
    fn t(&self) -> f64 {
        BdfSolver::t(self)
    }
    fn y(&self) -> &[f64] {
        BdfSolver::y(self)
    }
    fn work(&self) -> WorkStats {
        self.stats().into()
    }
}

impl<S: OdeSystem> Integrator for Dopri5<S> {
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError> {
        Ok(self.solve_to(t)?)
    }
    fn t(&self) -> f64 {
        Dopri5::t(self)
    }
    fn y(&self) -> &[f64] {
        Dopri5::y(self)
    }
    fn work(&self) -> WorkStats {
        self.stats().into()
    }
}

impl<S: SecondOrderSystem> Integrator for SymplecticEuler<S> {
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError> {
        Ok(self.solve_to(t)?)
    }
    fn t(&self) -> f64 {
        SymplecticEuler::t(self)
    }
    fn y(&self) -> &[f64] {
        self.state()
    }
    fn work(&self) -> WorkStats {
        self.stats().into()
    }
}
