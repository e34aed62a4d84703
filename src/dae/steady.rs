//! Steady states of a DAE by pseudo-transient continuation: y with F(t, y, 0, p) = 0 at a
//! fixed t — the equilibrium a damped system settles to, found without following its motion.
//!
//! Each pseudo-step is one Newton iteration of a backward-Euler step of pseudo-time length τ
//! (Kelley & Keyes 1998, "Convergence analysis of pseudo-transient continuation"):
//!
//! ```text
//! (dF/dy + (1/τ)·dF/dy')·Δ = −F(t, y_k, 0),    y_{k+1} = y_k + Δ
//! ```
//!
//! For small τ the term (1/τ)·dF/dy' (a mechanism's mass matrix) dominates and the step follows
//! the motion; as τ grows the step becomes Newton's method on F(t, y, 0) = 0 and converges
//! quadratically. τ grows by switched evolution relaxation, τ_{k+1} = τ_k·‖F_k‖/‖F_{k+1}‖
//! (bounded by [`SteadyOptions::max_growth`], and at least [`SteadyOptions::min_growth`]
//! while the residual does not grow); a step whose residual exceeds
//! [`SteadyOptions::reject_factor`] times the smallest residual so far, or whose evaluation
//! or factorisation fails, is retried with a quarter of τ. Directions without any stiffness (a body floating inside a
//! clearance) keep a regularising 1/τ term, so the matrix stays factorisable.
//!
//! Converged: the weighted RMS of the update is below [`SteadyOptions::tol`] (weights
//! 1/(rtol·|y| + atol), as in the BDF; algebraic components left out when
//! `suppress_algebraic`) and τ has reached [`SteadyOptions::settle_time`] — the system,
//! integrated (with heavy numerical damping) over at least that long, moves less than its
//! tolerance. The matrix machinery (analytic or coloured finite-difference Jacobian, the
//! [`LinearSolver`](super::LinearSolver) seam) is the BDF's.

use super::bdf::linsys::IterationMatrix;
use super::error::{largest, Culprit, DaeError};
use super::linear_solver::LinearSolverKind;
use super::options::{timed, AbsTol, PhaseTimes};
use super::problem::{DaeSystem, EvalError, VarKind};

/// τ below this fraction of τ_0 (after rejections) ends the iteration with an error: no
/// step, however short, reduces the residual.
const MIN_TAU_FRACTION: f64 = 1e-8;

/// Every tunable of [`steady_state`]. Times are in the system's time unit (s for lash's
/// mechanisms).
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyOptions {
    /// Relative tolerance of the update (> 0). Default 1e-8.
    pub rtol: f64,
    /// Absolute tolerance of the update (> 0). Default 1e-10.
    pub atol: AbsTol,
    /// Weighted RMS of the update below which the iteration has converged. Default 1.
    pub tol: f64,
    /// Leave algebraic components (multipliers) out of the convergence test. Default `true`.
    pub suppress_algebraic: bool,
    /// First pseudo-time step τ_0. Default 1e-3.
    pub tau0: f64,
    /// Pseudo-time step at which a small update counts as converged: the longest time
    /// constant of the system's slow motion. Default 1e3.
    pub settle_time: f64,
    /// Largest pseudo-time step. Default 1e8.
    pub tau_max: f64,
    /// Largest growth of τ in one step. Default 100.
    pub max_growth: f64,
    /// Growth of τ after an accepted step whose residual did not grow more than twofold,
    /// whatever switched evolution relaxation says: while a system moves towards its
    /// equilibrium its residual need not fall. Default 2.
    pub min_growth: f64,
    /// A step whose residual norm exceeds this factor times the smallest residual norm of
    /// the iteration so far is rejected. Default 100.
    pub reject_factor: f64,
    /// Pseudo-steps (accepted and rejected) before giving up. Default 300.
    pub max_iterations: usize,
    /// The linear solver.
    pub linear_solver: LinearSolverKind,
}

impl Default for SteadyOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: AbsTol::Scalar(1e-10),
            tol: 1.0,
            suppress_algebraic: true,
            tau0: 1e-3,
            settle_time: 1e3,
            tau_max: 1e8,
            max_growth: 100.0,
            min_growth: 2.0,
            reject_factor: 100.0,
            max_iterations: 300,
            linear_solver: LinearSolverKind::SparseLu,
        }
    }
}

/// Work and outcome of a [`steady_state`] solve.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct SteadyStats {
    /// Accepted pseudo-steps.
    pub steps: usize,
    /// Rejected pseudo-steps.
    pub rejected: usize,
    /// Residual evaluations (including finite-difference Jacobians).
    pub residual_evals: usize,
    /// Numeric LU factorisations.
    pub lu_factorisations: usize,
    /// Last pseudo-time step τ.
    pub tau: f64,
    /// Weighted RMS of the last update.
    pub update_norm: f64,
    /// 2-norm of F(t, y, 0) at the solution.
    pub residual_norm: f64,
    /// Wall time per phase, s.
    pub time: PhaseTimes,
}

/// Finds y with F(t, y, 0, p) = 0 starting from `y` (overwritten with the steady state) by
/// pseudo-transient continuation (see the module docs in `src/dae/steady.rs`):
/// [`SteadySolver::new`] and one [`SteadySolver::solve`].
///
/// Errors: [`DaeError::InvalidInput`] for bad options or dimensions, [`DaeError::SteadyState`]
/// when the iteration does not converge within the iteration budget (naming the components
/// with the largest weighted update), [`DaeError::Evaluation`] for a fatal callback failure.
pub fn steady_state<P: DaeSystem>(
    sys: &mut P,
    t: f64,
    y: &mut [f64],
    p: &[f64],
    opts: &SteadyOptions,
) -> Result<SteadyStats, DaeError> {
    SteadySolver::new(sys, opts)?.solve(sys, t, y, p)
}

/// A steady-state solver set up once for a system and used for many solves (other times,
/// parameters, starts, or loads the system takes between solves): the Jacobian pattern's
/// symbolic analysis and the work vectors are kept, as IDA keeps its memory between
/// `IDAReInit` calls. The system must keep its dimension and Jacobian pattern.
#[derive(Debug)]
pub struct SteadySolver {
    opts: SteadyOptions,
    atol: Vec<f64>,
    kinds: Vec<VarKind>,
    mat: IterationMatrix,
}

impl SteadySolver {
    /// Sets up the solver for `sys`: validates `opts`, expands the tolerances and analyses
    /// the Jacobian pattern. Errors: [`DaeError::InvalidInput`].
    pub fn new<P: DaeSystem>(sys: &P, opts: &SteadyOptions) -> Result<Self, DaeError> {
        let n = sys.dim();
        validate(opts, n, n)?;
        let atol = opts.atol.expand(n, |i| sys.component_name(i))?;
        let mat = IterationMatrix::new(
            sys.jacobian_pattern(),
            sys.jacobian_source(),
            opts.linear_solver,
            &sys.eliminable_blocks(),
        )
        .map_err(|e| DaeError::InvalidInput(format!("Jacobian pattern: {e}")))?;
        Ok(Self {
            opts: opts.clone(),
            atol,
            kinds: sys.var_kinds(),
            mat,
        })
    }

    /// Finds y with F(t, y, 0, p) = 0 starting from `y` (overwritten with the steady state).
    /// Errors as [`steady_state`]; a `sys` or `y` of another dimension than the one the
    /// solver was set up for is [`DaeError::InvalidInput`].
    pub fn solve<P: DaeSystem>(
        &mut self,
        sys: &mut P,
        t: f64,
        y: &mut [f64],
        p: &[f64],
    ) -> Result<SteadyStats, DaeError> {
        let n = self.atol.len();
        if sys.dim() != n {
            return Err(DaeError::InvalidInput(format!(
                "steady state: the solver was set up for {n} unknowns, the system has {}",
                sys.dim()
            )));
        }
        validate(&self.opts, n, y.len())?;
        solve(sys, t, y, p, &self.opts, &self.atol, &self.kinds, &mut self.mat)
    }
}

#[allow(clippy::too_many_arguments)]
fn solve<P: DaeSystem>(
    sys: &mut P,
    t: f64,
    y: &mut [f64],
    p: &[f64],
    opts: &SteadyOptions,
    atol: &[f64],
    kinds: &[VarKind],
    mat: &mut IterationMatrix,
) -> Result<SteadyStats, DaeError> {
    let n = atol.len();
    let zero = vec![0.0; n];
    let mut r = vec![0.0; n];
    let mut r_new = vec![0.0; n];
    let mut y_new = vec![0.0; n];
    let mut dy = vec![0.0; n];
    let mut ewt = vec![0.0; n];
    let mut stats = SteadyStats::default();
    let fatal = |m: String| DaeError::Evaluation { t, message: m };
    eval(sys, t, y, &zero, p, &mut r, &mut stats).map_err(|e| match e {
        EvalError::Recoverable(m) | EvalError::Fatal(m) => fatal(m),
    })?;
    let mut rnorm = norm2(&r);
    if !rnorm.is_finite() {
        return Err(DaeError::NonFiniteResidual {
            t,
            culprits: non_finite(sys, &r),
        });
    }
    let mut tau = opts.tau0;
    // Smallest residual norm so far: a step may raise the residual (a body moving into
    // contact) but never far above the best iterate, so a chain of growing steps cannot
    // carry the iteration away.
    let mut best = rnorm;
    // The last accepted update and its weighted norm (for the error report).
    let (mut last_norm, mut last_dy, mut accepted) = (f64::INFINITY, vec![0.0; n], false);
    let mut iterations = 0;
    while iterations < opts.max_iterations {
        iterations += 1;
        for ((w, yi), a) in ewt.iter_mut().zip(y.iter()).zip(atol) {
            *w = 1.0 / (opts.rtol * yi.abs() + a);
        }
        // The iteration matrix dF/dy + (1/τ)·dF/dy' at (y_k, 0), factorised.
        stats.residual_evals += mat.fd_cost();
        let setup = timed(&mut stats.time.jacobian_s, || {
            mat.evaluate(sys, t, y, &zero, p, 1.0 / tau, &r, &ewt, tau)
        });
        let ok = match setup {
            Err(EvalError::Fatal(m)) => return Err(fatal(m)),
            Err(EvalError::Recoverable(_)) => false,
            Ok(()) => timed(&mut stats.time.factorisation_s, || mat.factor()).is_ok(),
        };
        if ok {
            stats.lu_factorisations += 1;
        }
        let solved = ok && {
            for (d, ri) in dy.iter_mut().zip(&r) {
                *d = -ri;
            }
            timed(&mut stats.time.solve_s, || mat.solve(&mut dy)).is_ok() && dy.iter().all(|v| v.is_finite())
        };
        if !solved {
            stats.rejected += 1;
            tau *= 0.25;
            if tau < opts.tau0 * MIN_TAU_FRACTION {
                break;
            }
            continue;
        }
        for i in 0..n {
            y_new[i] = y[i] + dy[i];
        }
        let evaluated = eval(sys, t, &y_new, &zero, p, &mut r_new, &mut stats);
        let new_norm = match evaluated {
            Err(EvalError::Fatal(m)) => return Err(fatal(m)),
            Err(EvalError::Recoverable(_)) => f64::NAN,
            Ok(()) => norm2(&r_new),
        };
        if !new_norm.is_finite() || new_norm > opts.reject_factor * best.max(f64::MIN_POSITIVE) {
            stats.rejected += 1;
            tau *= 0.25;
            if tau < opts.tau0 * MIN_TAU_FRACTION {
                break;
            }
            continue;
        }
        let unorm = update_norm(&dy, &ewt, kinds, opts.suppress_algebraic);
        last_norm = unorm;
        last_dy.copy_from_slice(&dy);
        accepted = true;
        y.copy_from_slice(&y_new);
        std::mem::swap(&mut r, &mut r_new);
        let ratio = if new_norm > 0.0 {
            rnorm / new_norm
        } else {
            opts.max_growth
        };
        rnorm = new_norm;
        best = best.min(rnorm);
        stats.steps += 1;
        stats.update_norm = unorm;
        stats.tau = tau;
        if unorm <= opts.tol && tau >= opts.settle_time {
            stats.residual_norm = rnorm;
            return Ok(stats);
        }
        // SER; a residual that holds while the system moves (a body falling onto its
        // support) still lets τ grow by `min_growth`.
        let growth = if ratio >= 0.5 {
            ratio.max(opts.min_growth)
        } else {
            ratio.max(1e-3)
        };
        tau = (tau * growth.min(opts.max_growth)).min(opts.tau_max);
        if unorm <= opts.tol {
            // Still at rest: let τ reach the settling time quickly.
            tau = tau.max((tau * opts.max_growth).min(opts.settle_time));
        }
    }
    // Culprits: the largest weighted last update, or the largest residuals if no step was
    // accepted.
    let culprits = if accepted {
        largest(sys, &last_dy, &ewt, 5)
    } else {
        largest(sys, &r, &vec![1.0; n], 5)
    };
    Err(DaeError::SteadyState {
        t,
        tau,
        iterations,
        update_norm: last_norm,
        residual_norm: rnorm,
        culprits,
    })
}

fn validate(opts: &SteadyOptions, n: usize, ylen: usize) -> Result<(), DaeError> {
    let bad = |what: &str, v: f64| {
        DaeError::InvalidInput(format!("steady state: {what} must be > 0 and finite, got {v}"))
    };
    for (what, v) in [
        ("rtol", opts.rtol),
        ("tol", opts.tol),
        ("tau0", opts.tau0),
        ("settle_time", opts.settle_time),
        ("tau_max", opts.tau_max),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(bad(what, v));
        }
    }
    if !(opts.max_growth > 1.0 && opts.max_growth.is_finite()) {
        return Err(DaeError::InvalidInput(format!(
            "steady state: max_growth must be > 1, got {}",
            opts.max_growth
        )));
    }
    if !(opts.min_growth >= 1.0 && opts.min_growth <= opts.max_growth) {
        return Err(DaeError::InvalidInput(format!(
            "steady state: min_growth must be in [1, max_growth], got {}",
            opts.min_growth
        )));
    }
    if opts.reject_factor.is_nan() || opts.reject_factor < 1.0 {
        return Err(DaeError::InvalidInput(format!(
            "steady state: reject_factor must be ≥ 1, got {}",
            opts.reject_factor
        )));
    }
    if ylen != n {
        return Err(DaeError::InvalidInput(format!(
            "steady state: y has {ylen} components, the system {n}"
        )));
    }
    Ok(())
}

fn eval<P: DaeSystem>(
    sys: &mut P,
    t: f64,
    y: &[f64],
    yp: &[f64],
    p: &[f64],
    r: &mut [f64],
    stats: &mut SteadyStats,
) -> Result<(), EvalError> {
    stats.residual_evals += 1;
    timed(&mut stats.time.residual_s, || sys.residual(t, y, yp, p, r))
}

fn update_norm(dy: &[f64], ewt: &[f64], kinds: &[VarKind], suppress_algebraic: bool) -> f64 {
    let mut s = 0.0;
    let mut k = 0usize;
    for i in 0..dy.len() {
        if suppress_algebraic && kinds.get(i) == Some(&VarKind::Algebraic) {
            continue;
        }
        s += (dy[i] * ewt[i]).powi(2);
        k += 1;
    }
    if k == 0 {
        0.0
    } else {
        (s / k as f64).sqrt()
    }
}

fn norm2(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn non_finite<P: DaeSystem>(sys: &P, r: &[f64]) -> Vec<Culprit> {
    r.iter()
        .enumerate()
        .filter(|(_, v)| !v.is_finite())
        .take(5)
        .map(|(i, v)| Culprit {
            index: i,
            name: sys.component_name(i),
            weighted: *v,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dae::JacobianSource;
    use crate::sparse::CscPattern;

    /// A damped oscillator with a cubic spring and a load, as a first-order DAE with an
    /// algebraic spring force: x' = v, m·v' = −c·v − f + load, 0 = f − k·x − k3·x³.
    struct Spring {
        m: f64,
        c: f64,
        k: f64,
        k3: f64,
        load: f64,
    }

    impl DaeSystem for Spring {
        fn dim(&self) -> usize {
            3
        }
        fn residual(
            &mut self,
            _t: f64,
            y: &[f64],
            yp: &[f64],
            _p: &[f64],
            r: &mut [f64],
        ) -> Result<(), EvalError> {
            r[0] = yp[0] - y[1];
            r[1] = self.m * yp[1] + self.c * y[1] + y[2] - self.load;
            r[2] = y[2] - self.k * y[0] - self.k3 * y[0].powi(3);
            Ok(())
        }
        fn jacobian_pattern(&self) -> CscPattern {
            CscPattern::dense(3, 3)
        }
        fn jacobian_source(&self) -> JacobianSource {
            JacobianSource::FiniteDifference
        }
        fn var_kinds(&self) -> Vec<VarKind> {
            vec![VarKind::Differential, VarKind::Differential, VarKind::Algebraic]
        }
    }

    #[test]
    fn finds_the_equilibrium_of_a_stiffening_spring() {
        let mut s = Spring {
            m: 2.0,
            c: 0.0,
            k: 100.0,
            k3: 1e6,
            load: 50.0,
        };
        let mut y = vec![0.0; 3];
        let st = steady_state(&mut s, 0.0, &mut y, &[], &SteadyOptions::default()).unwrap();
        // k·x + k3·x³ = 50 solved independently by bisection.
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..200 {
            let mid: f64 = 0.5 * (lo + hi);
            if 100.0 * mid + 1e6 * mid.powi(3) > 50.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        assert!((y[0] - lo).abs() < 1e-9 * lo.max(1e-3), "x = {} vs {lo}", y[0]);
        assert!(y[1].abs() < 1e-9, "v = {}", y[1]);
        assert!((y[2] - 50.0).abs() < 1e-6, "f = {}", y[2]);
        assert!(st.steps < 60, "{st:?}");
        assert!(st.tau >= SteadyOptions::default().settle_time);
    }

    #[test]
    fn a_system_without_equilibrium_is_an_error_naming_the_moving_component() {
        // No spring: a constant load accelerates the mass for ever.
        let mut s = Spring {
            m: 1.0,
            c: 0.0,
            k: 0.0,
            k3: 0.0,
            load: 1.0,
        };
        let mut y = vec![0.0; 3];
        let o = SteadyOptions {
            max_iterations: 40,
            ..Default::default()
        };
        let e = steady_state(&mut s, 0.0, &mut y, &[], &o).unwrap_err();
        match &e {
            DaeError::SteadyState { culprits, .. } => assert!(!culprits.is_empty(), "{e}"),
            other => panic!("{other}"),
        }
        let msg = e.to_string();
        assert!(msg.contains("steady state not found"), "{msg}");
    }

    #[test]
    fn bad_options_are_errors() {
        let mut s = Spring {
            m: 1.0,
            c: 1.0,
            k: 1.0,
            k3: 0.0,
            load: 1.0,
        };
        let mut y = vec![0.0; 3];
        let o = SteadyOptions {
            tau0: 0.0,
            ..Default::default()
        };
        assert!(matches!(
            steady_state(&mut s, 0.0, &mut y, &[], &o),
            Err(DaeError::InvalidInput(_))
        ));
        let mut short = vec![0.0; 2];
        assert!(matches!(
            steady_state(&mut s, 0.0, &mut short, &[], &SteadyOptions::default()),
            Err(DaeError::InvalidInput(_))
        ));
    }
}
