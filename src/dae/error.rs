//! Errors of the DAE solvers.

use crate::sparse::{LinearSolveError, PatternError};
use thiserror::Error;

/// A component that contributed most to a failure: its index, name, and weighted size.
#[derive(Debug, Clone, PartialEq)]
pub struct Culprit {
    /// Index in y.
    pub index: usize,
    /// Name from [`DaeSystem::component_name`](super::DaeSystem::component_name).
    pub name: String,
    /// Weighted magnitude (error, correction or residual, divided by its tolerance).
    pub weighted: f64,
}

/// The `k` components of `sys` with the largest |x_i|·w_i, named (zero ones left out; NaN
/// ones kept).
pub(crate) fn largest<P: super::DaeSystem>(sys: &P, x: &[f64], w: &[f64], k: usize) -> Vec<Culprit> {
    let mut idx: Vec<(usize, f64)> = x
        .iter()
        .zip(w)
        .map(|(a, b)| (a * b).abs())
        .enumerate()
        .filter(|(_, v)| *v > 0.0 || v.is_nan())
        .collect();
    idx.sort_by(|a, b| b.1.partial_cmp(&a.1).unwrap_or(std::cmp::Ordering::Less));
    idx.into_iter()
        .take(k)
        .map(|(i, v)| Culprit {
            index: i,
            name: sys.component_name(i),
            weighted: v,
        })
        .collect()
}

fn fmt_culprits(c: &[Culprit]) -> String {
    if c.is_empty() {
        return String::new();
    }
    let list: Vec<String> = c
        .iter()
        .map(|c| format!("{} ({:.3e})", c.name, c.weighted))
        .collect();
    format!("; largest contributions: {}", list.join(", "))
}

/// Why a DAE solve stopped with an error.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DaeError {
    /// Bad input at set-up (dimensions, tolerances, options).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The Jacobian pattern was rejected.
    #[error("invalid Jacobian pattern: {0}")]
    Pattern(#[from] PatternError),
    /// The local error test failed too often within one step.
    #[error("error test failed {fails} times in one step at t = {t:e}, h = {h:e}{}", fmt_culprits(.culprits))]
    ErrorTestFailures {
        /// Time of the last accepted step.
        t: f64,
        /// Step size of the last attempt.
        h: f64,
        /// Failures within the step.
        fails: usize,
        /// Components with the largest weighted local error.
        culprits: Vec<Culprit>,
    },
    /// The Newton iteration failed too often within one step.
    #[error("Newton iteration failed {fails} times in one step at t = {t:e}, h = {h:e}{}", fmt_culprits(.culprits))]
    NewtonFailures {
        /// Time of the last accepted step.
        t: f64,
        /// Step size of the last attempt.
        h: f64,
        /// Failures within the step.
        fails: usize,
        /// Components with the largest weighted Newton correction.
        culprits: Vec<Culprit>,
    },
    /// The step size fell below the floor.
    #[error("step size {h:e} fell below the floor {h_min:e} at t = {t:e}{}", fmt_culprits(.culprits))]
    StepTooSmall {
        /// Time of the last accepted step.
        t: f64,
        /// Attempted step.
        h: f64,
        /// The floor.
        h_min: f64,
        /// Components that forced the reductions, if known.
        culprits: Vec<Culprit>,
    },
    /// Too many steps in one call.
    #[error("reached the maximum of {max_steps} steps at t = {t:e} (h = {h:e}) before t_out = {t_out:e}")]
    TooManySteps {
        /// Time reached.
        t: f64,
        /// Current step size.
        h: f64,
        /// The limit.
        max_steps: usize,
        /// Requested output time.
        t_out: f64,
    },
    /// The iteration matrix could not be factorised or solved with.
    #[error("linear solve failed at t = {t:e}, h = {h:e}: {source}{}", fmt_culprits(.culprits))]
    LinearSolve {
        /// Time.
        t: f64,
        /// Step size.
        h: f64,
        /// The sparse LU's error.
        source: LinearSolveError,
        /// Rows or columns implicated (e.g. empty or non-finite), if known.
        culprits: Vec<Culprit>,
    },
    /// A user callback failed unrecoverably, or recoverably too often.
    #[error("residual or Jacobian evaluation failed at t = {t:e}: {message}")]
    Evaluation {
        /// Time.
        t: f64,
        /// The callback's message.
        message: String,
    },
    /// The residual returned NaN or infinity.
    #[error("residual is not finite at t = {t:e}{}", fmt_culprits(.culprits))]
    NonFiniteResidual {
        /// Time.
        t: f64,
        /// The non-finite components.
        culprits: Vec<Culprit>,
    },
    /// Consistent initial values could not be computed.
    #[error("consistent initial values not found at t = {t:e}: {reason}{}", fmt_culprits(.culprits))]
    InitialConditions {
        /// Initial time.
        t: f64,
        /// What went wrong.
        reason: String,
        /// Equations with the largest remaining residual.
        culprits: Vec<Culprit>,
    },
    /// The initial values do not satisfy F(t0, y0, y'0) = 0 within tolerance.
    #[error("initial values are inconsistent at t = {t:e}: the first Newton correction has weighted norm {norm:e} (> 1: off by more than the tolerances){}", fmt_culprits(.culprits))]
    InconsistentInitialValues {
        /// Initial time.
        t: f64,
        /// Weighted norm of F(t0, y0, y'0).
        norm: f64,
        /// Equations with the largest residual.
        culprits: Vec<Culprit>,
    },
    /// Pseudo-transient continuation ([`steady_state`](super::steady_state)) did not reach a
    /// steady state within its iteration budget.
    #[error("steady state not found at t = {t:e} after {iterations} pseudo-steps (τ = {tau:e}, last update {update_norm:.3e} of its tolerance, residual norm {residual_norm:.3e}){}", fmt_culprits(.culprits))]
    SteadyState {
        /// The fixed time.
        t: f64,
        /// Pseudo-time step reached.
        tau: f64,
        /// Pseudo-steps taken.
        iterations: usize,
        /// Weighted RMS of the last accepted update (≤ 1 would be converged).
        update_norm: f64,
        /// 2-norm of F(t, y, 0) at the last accepted iterate.
        residual_norm: f64,
        /// Components with the largest weighted last update (or residual, if no step was
        /// accepted).
        culprits: Vec<Culprit>,
    },
    /// A requested output time lies outside what the solver can deliver.
    #[error("requested time {t:e} is outside [{lo:e}, {hi:e}]")]
    OutOfRange {
        /// Requested time.
        t: f64,
        /// Start of the valid interval.
        lo: f64,
        /// End of the valid interval.
        hi: f64,
    },
}
