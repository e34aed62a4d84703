//! Solver options (every tunable in one place) and run statistics.

use super::linear_solver::LinearSolverKind;

/// Absolute tolerance: one value for all components, or one per component.
#[derive(Debug, Clone, PartialEq)]
pub enum AbsTol {
    /// The same absolute tolerance for every component.
    Scalar(f64),
    /// One absolute tolerance per component.
    Vector(Vec<f64>),
}

impl AbsTol {
    /// One absolute tolerance per component of a system of `n` unknowns, each checked to be
    /// positive and finite (`name(i)` names component i in the error).
    pub(crate) fn expand(
        &self,
        n: usize,
        name: impl Fn(usize) -> String,
    ) -> Result<Vec<f64>, super::DaeError> {
        let atol = match self {
            AbsTol::Scalar(a) => vec![*a; n],
            AbsTol::Vector(v) if v.len() != n => {
                return Err(super::DaeError::InvalidInput(format!(
                    "atol has length {}, expected {n}",
                    v.len()
                )))
            }
            AbsTol::Vector(v) => v.clone(),
        };
        match atol.iter().position(|a| !(*a > 0.0 && a.is_finite())) {
            Some(i) => Err(super::DaeError::InvalidInput(format!(
                "atol must be positive, got {} for {}",
                atol[i],
                name(i)
            ))),
            None => Ok(atol),
        }
    }
}

/// Every tunable of the BDF solver. Defaults follow SUNDIALS IDA where it has one.
#[derive(Debug, Clone, PartialEq)]
pub struct BdfOptions {
    /// Relative tolerance (> 0).
    pub rtol: f64,
    /// Absolute tolerance (> 0).
    pub atol: AbsTol,
    /// Largest BDF order, 1–5.
    pub max_order: usize,
    /// Initial step size; `None` chooses one from y'(t0) and the tolerances.
    pub h_init: Option<f64>,
    /// Largest step size magnitude (`f64::INFINITY` for none).
    pub h_max: f64,
    /// Step-size floor: a step smaller than this ends the run with an error. The floor is
    /// never below 16·ε·|t| (a step that would not change t); `None` uses just that.
    pub h_min: Option<f64>,
    /// Maximum number of internal steps in one call of the driver before it returns an error.
    pub max_steps: usize,
    /// Exclude algebraic components from the local error test (IDA's "suppress algebraic").
    pub suppress_algebraic: bool,
    /// Maximum Newton iterations per nonlinear solve (IDA: 4).
    pub max_newton_iters: usize,
    /// Newton convergence coefficient on the weighted norm of the correction (IDA: 0.33).
    pub newton_tol: f64,
    /// Convergence rate above which the Newton iteration is declared diverging (IDA: 0.9).
    pub newton_max_rate: f64,
    /// A converged Newton iteration whose rate exceeded this marks the Jacobian stale, so the
    /// next step re-evaluates it instead of iterating slowly (or diverging when stiff
    /// directions turn).
    pub jacobian_refresh_rate: f64,
    /// Times the iteration matrix may be rebuilt at the current iterate within one nonlinear
    /// solve when the iteration converges slower than `jacobian_refresh_rate` and, at that
    /// rate, would not pass the convergence test in the iterations left (0: IDA's
    /// modified Newton, the matrix only changes between attempts). Stiff contact forces that
    /// switch on within a step make modified Newton crawl at rate 0.7–0.9; a rebuilt matrix
    /// converges in a few iterations, cheaper than failing the step.
    pub max_jacobian_refreshes_in_solve: usize,
    /// Error-test failures allowed within one step (IDA: 10).
    pub max_error_test_fails: usize,
    /// Nonlinear convergence failures allowed within one step (IDA: 10).
    pub max_newton_fails: usize,
    /// Re-evaluate the Jacobian at least every this many steps.
    pub max_steps_between_jacobians: usize,
    /// Step ceiling after a nonlinear convergence failure: once the Newton iteration failed
    /// at a step size h that had just grown past the last accepted step, later steps stay
    /// below this fraction of h, a ceiling that rises by `step_ceiling_relaxation` per
    /// accepted step (`f64::INFINITY`: no ceiling, IDA). Where the step size is limited by
    /// Newton convergence rather than by the error test (stiff contact switching on and
    /// off), IDA's rule (cut to h/4, then double) grows straight back into the failure, and
    /// every failure costs its iterations and factorisations. A failure at an unchanged or
    /// smaller step (a contact switching within it) sets no ceiling: there the step size
    /// was not what failed, and a ceiling would only slow the regrowth after it.
    pub step_ceiling_after_newton_failure: f64,
    /// Factor (≥ 1) by which the step ceiling rises per accepted step.
    pub step_ceiling_relaxation: f64,
    /// Stop time: the solver never steps past it.
    pub stop_time: Option<f64>,
    /// Filter the local error estimates through the iteration matrix so transients in stiff
    /// directions (already damped by BDF) do not force tiny steps; see `dae::bdf::estimate`.
    /// Costs about one residual evaluation and one LU solve per estimate.
    pub filter_error_estimate: bool,
    /// With an iteration matrix from an earlier step, always take a second Newton iteration
    /// so the convergence rate of this step is measured (and a slow rate refreshes the
    /// matrix) instead of trusting the previous step's rate.
    pub measure_rate_with_stale_jacobian: bool,
    /// Differences kept by the Anderson acceleration of the Newton iteration (0: none, IDA's
    /// plain modified Newton; at most 8, more is an input error; a solve gathers at most
    /// `max_newton_iters` − 1 of them). With a matrix that has drifted from the true Jacobian
    /// in a few stiff directions (contact stiffness changing between steps), the accelerated
    /// iteration is GMRES preconditioned by that matrix (Walker & Ni, on a linear problem), at
    /// one residual and one solve per iteration as before (`dae::bdf::anderson`). Measured on
    /// the MR2120 clearance model and not a default there (`validation/performance-log.md`, "Anderson acceleration").
    pub anderson_depth: usize,
    /// Linear solver of the iteration matrices (default: faer's sparse LU).
    pub linear_solver: LinearSolverKind,
}

impl Default for BdfOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: AbsTol::Scalar(1e-6),
            max_order: 5,
            h_init: None,
            h_max: f64::INFINITY,
            h_min: None,
            max_steps: 500_000,
            suppress_algebraic: false,
            max_newton_iters: 4,
            newton_tol: 0.33,
            newton_max_rate: 0.9,
            jacobian_refresh_rate: 0.25,
            max_jacobian_refreshes_in_solve: 0,
            max_error_test_fails: 10,
            max_newton_fails: 10,
            max_steps_between_jacobians: 50,
            step_ceiling_after_newton_failure: f64::INFINITY,
            step_ceiling_relaxation: 1.2,
            stop_time: None,
            filter_error_estimate: false,
            measure_rate_with_stale_jacobian: true,
            anderson_depth: 0,
            linear_solver: LinearSolverKind::SparseLu,
        }
    }
}

impl BdfOptions {
    /// Default options with `rtol` and a scalar `atol`.
    pub fn with_tolerances(rtol: f64, atol: f64) -> Self {
        Self {
            rtol,
            atol: AbsTol::Scalar(atol),
            ..Self::default()
        }
    }
}

/// Work counters of a run (cumulative).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Statistics {
    /// Accepted steps.
    pub steps: usize,
    /// Steps rejected by the local error test.
    pub error_test_failures: usize,
    /// Steps rejected because the Newton iteration failed to converge.
    pub newton_failures: usize,
    /// Residual evaluations, including those spent in finite-difference Jacobians.
    pub residual_evals: usize,
    /// Jacobian evaluations (analytic or finite-difference).
    pub jacobian_evals: usize,
    /// Numeric LU factorisations.
    pub lu_factorisations: usize,
    /// Of those, factorisations whose block elimination had to be redone with every block
    /// equilibrated ([`FactorRoute::Equilibrated`](crate::sparse::FactorRoute)).
    pub lu_equilibrated: usize,
    /// Of those, factorisations that fell back to the plain sparse LU of the whole matrix
    /// ([`FactorRoute::PlainLu`](crate::sparse::FactorRoute)).
    pub lu_plain_fallbacks: usize,
    /// Newton iterations.
    pub newton_iters: usize,
    /// Event-function evaluations.
    pub event_evals: usize,
    /// Order of the last step.
    pub last_order: usize,
    /// Size of the last step.
    pub last_step: f64,
    /// Wall time spent in each phase, s.
    pub time: PhaseTimes,
}

/// Cumulative wall time of the solver's phases, s: where a run's time goes, without a
/// profiler. The remainder of a run's wall time is the step logic (predictor, error test,
/// history updates) and output interpolation.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimes {
    /// Residual evaluations of the Newton iteration and the error-estimate filter.
    pub residual_s: f64,
    /// Jacobian evaluations (analytic, or finite differences including their residuals).
    pub jacobian_s: f64,
    /// Numeric LU factorisations.
    pub factorisation_s: f64,
    /// Triangular solves with the factors.
    pub solve_s: f64,
}

/// Runs `f` and adds its wall time to `acc` (s).
pub(crate) fn timed<T>(acc: &mut f64, f: impl FnOnce() -> T) -> T {
    let start = std::time::Instant::now();
    let r = f();
    *acc += start.elapsed().as_secs_f64();
    r
}
