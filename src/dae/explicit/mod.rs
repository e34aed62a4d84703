//! Explicit baselines for ODEs, used to measure what the implicit BDF buys on stiff problems.
//!
//! * [`Dopri5`] — adaptive Dormand–Prince 5(4) with FSAL and a PI step controller.
//! * [`SymplecticEuler`] — fixed-step semi-implicit Euler for q'' = a(t, q, q'), the
//!   integrator of game-style contact engines.

mod dopri5;
mod symplectic_euler;

pub use dopri5::{Dopri5, Dopri5Options};
pub use symplectic_euler::{SecondOrderSystem, SymplecticEuler};

use super::problem::EvalError;

/// An ODE y' = f(t, y, p).
pub trait OdeSystem {
    /// Number of unknowns.
    fn dim(&self) -> usize;
    /// Evaluates `dy = f(t, y, p)`.
    fn rhs(&mut self, t: f64, y: &[f64], p: &[f64], dy: &mut [f64]) -> Result<(), EvalError>;
}

/// Work counters of an explicit run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExplicitStats {
    /// Accepted steps.
    pub steps: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side (or acceleration) evaluations.
    pub rhs_evals: usize,
}

/// Why an explicit run stopped with an error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExplicitError {
    /// Bad input.
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The right-hand side failed.
    #[error("right-hand side failed at t = {t:e}: {message}")]
    Evaluation {
        /// Time.
        t: f64,
        /// Message.
        message: String,
    },
    /// Too many steps.
    #[error("reached the maximum of {max_steps} steps at t = {t:e} (h = {h:e})")]
    TooManySteps {
        /// Time reached.
        t: f64,
        /// Step size.
        h: f64,
        /// Limit.
        max_steps: usize,
    },
    /// The step size underflowed.
    #[error("step size {h:e} too small at t = {t:e}")]
    StepTooSmall {
        /// Time.
        t: f64,
        /// Step size.
        h: f64,
    },
    /// The solution became NaN or infinite.
    #[error("solution is not finite at t = {t:e} (component {index})")]
    NonFinite {
        /// Time.
        t: f64,
        /// First non-finite component.
        index: usize,
    },
}
