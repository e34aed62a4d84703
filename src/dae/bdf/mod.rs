//! Variable-order (1–5), variable-step BDF for F(t, y, y', p) = 0, in the fixed-leading-
//! coefficient form of SUNDIALS IDA (Brenan, Campbell & Petzold, ch. 3; Hindmarsh et al.,
//! ACM TOMS 31, 2005).
//!
//! One concern per file, one solver-state struct ([`BdfSolver`]):
//!
//! | file | concern |
//! |---|---|
//! | `mod.rs` | the state struct, construction, norms, accessors |
//! | `step.rs` | one step: coefficients, predictor, error test, order/step selection |
//! | `newton.rs` | the Newton iteration with Jacobian/LU reuse and refresh |
//! | `anderson.rs` | Anderson acceleration of that iteration while its matrix is frozen |
//! | `linsys.rs` | the one set-up path of the iteration matrix dF/dy + α·dF/dy' (Newton and initial conditions) and its factorisation through the [`LinearSolver`](crate::dae::LinearSolver) seam |
//! | `estimate.rs` | filtering of the local error estimates in stiff directions |
//! | `ic.rs` | consistent initial values (index 1) and the consistency check |
//! | `output.rs` | dense output, the output-time driver, stop times, events, restarts |

mod anderson;
mod estimate;
mod ic;
pub(crate) mod linsys;
mod newton;

mod output;
mod step;

pub use output::Outcome;

use super::error::{Culprit, DaeError};
use super::options::{BdfOptions, Statistics};
use super::problem::{DaeSystem, VarKind};
use linsys::IterationMatrix;

/// Largest BDF order.
pub const MAX_ORDER: usize = 5;

/// The BDF solver: the problem, its parameters, the history arrays and the work counters.
///
/// ```
/// use lash::dae::{BdfOptions, BdfSolver, DaeSystem, EvalError, JacobianSource};
/// use lash::sparse::CscPattern;
///
/// /// y' = -y, written as F = y' + y.
/// struct Decay;
/// impl DaeSystem for Decay {
///     fn dim(&self) -> usize { 1 }
///     fn residual(&mut self, _t: f64, y: &[f64], yp: &[f64], _p: &[f64], r: &mut [f64])
///         -> Result<(), EvalError> { r[0] = yp[0] + y[0]; Ok(()) }
///     fn jacobian_pattern(&self) -> CscPattern { CscPattern::dense(1, 1) }
/// }
/// let mut s = BdfSolver::new(Decay, 0.0, &[1.0], &[-1.0], &[], BdfOptions::with_tolerances(1e-8, 1e-10))?;
/// s.solve_to(1.0)?;
/// assert!((s.y()[0] - (-1.0f64).exp()).abs() < 1e-6);
/// # Ok::<(), lash::dae::DaeError>(())
/// ```
#[derive(Debug)]
pub struct BdfSolver<P: DaeSystem> {
    pub(crate) sys: P,
    pub(crate) p: Vec<f64>,
    pub(crate) opts: BdfOptions,
    pub(crate) n: usize,
    pub(crate) kinds: Vec<VarKind>,
    /// Error-test index of each component (see `DaeSystem::error_index`).
    pub(crate) err_index: Vec<u8>,
    atol: Vec<f64>,
    // --- history (modified divided differences) and coefficients ---
    pub(crate) phi: Vec<Vec<f64>>,
    pub(crate) psi: [f64; MAX_ORDER + 2],
    pub(crate) alpha: [f64; MAX_ORDER + 2],
    pub(crate) beta: [f64; MAX_ORDER + 2],
    pub(crate) sigma: [f64; MAX_ORDER + 2],
    pub(crate) gamma: [f64; MAX_ORDER + 2],
    /// Current order.
    pub(crate) kk: usize,
    /// Order of the last successful step.
    pub(crate) kused: usize,
    /// Order proposed by the error test.
    pub(crate) knew: usize,
    /// 0 while the order is still being raised after a (re)start, 1 afterwards.
    pub(crate) phase: u8,
    /// Steps taken at constant step size and order.
    pub(crate) ns: usize,
    /// Step size for the next attempt.
    pub(crate) hh: f64,
    /// Last successful step size.
    pub(crate) hused: f64,
    /// Time of the last accepted step.
    pub(crate) tn: f64,
    /// Leading coefficient α_s/h of the current step.
    pub(crate) cj: f64,
    pub(crate) cjlast: f64,
    /// Error-test coefficient of the current step.
    pub(crate) ck: f64,
    /// Newton convergence-rate estimate factor rate/(1 − rate).
    pub(crate) ss: f64,
    /// Steps since the last (re)start.
    pub(crate) nst_local: usize,
    // --- work vectors ---
    pub(crate) yy: Vec<f64>,
    pub(crate) yp: Vec<f64>,
    pub(crate) ee: Vec<f64>,
    pub(crate) delta: Vec<f64>,
    pub(crate) ypred: Vec<f64>,
    pub(crate) yppred: Vec<f64>,
    pub(crate) ewt: Vec<f64>,
    /// Weights of the error test: `ewt` with algebraic components zeroed when suppressed.
    pub(crate) ewt_err: Vec<f64>,
    /// Error-test weights scaled by the error index for the current step.
    pub(crate) ewt_test: Vec<f64>,
    pub(crate) tmp: Vec<f64>,
    /// Weights of the Newton convergence test.
    pub(crate) ewt_newton: Vec<f64>,
    /// Filtered local error estimate of the current attempt (equals `ee` without filtering).
    pub(crate) ee_est: Vec<f64>,
    pub(crate) res_base: Vec<f64>,
    pub(crate) res_work: Vec<f64>,
    pub(crate) yp_work: Vec<f64>,
    pub(crate) filter_ok: bool,
    // --- linear algebra ---
    pub(crate) mat: IterationMatrix,
    /// Anderson acceleration of the Newton iteration (`BdfOptions::anderson_depth`).
    pub(crate) anderson: anderson::Anderson,
    /// The iteration matrix was evaluated at the current step's predictor.
    pub(crate) jac_current: bool,
    /// Set-up forced on the next Newton iteration (slow convergence, restart, …).
    pub(crate) force_setup: bool,
    pub(crate) steps_since_jac: usize,
    /// Current limit on Jacobian reuse (adapted; see `newton.rs`).
    pub(crate) jac_age_limit: usize,
    pub(crate) fresh_streak: usize,
    /// Ceiling on |h| after Newton convergence failures (see
    /// `BdfOptions::step_ceiling_after_newton_failure`); infinite when none.
    pub(crate) h_ceiling: f64,
    // --- output driver state ---
    pub(crate) started: bool,
    pub(crate) tret: f64,
    pub(crate) yret: Vec<f64>,
    pub(crate) ypret: Vec<f64>,
    pub(crate) h_min: f64,
    pub(crate) events: output::EventState,
    pub(crate) stats: Statistics,
}

impl<P: DaeSystem> BdfSolver<P> {
    /// Creates a solver for `sys` from (t0, y0, y'0) with parameters `p`.
    ///
    /// The initial values must be consistent (F(t0, y0, y'0) ≈ 0); use
    /// [`calc_ic`](Self::calc_ic) to compute consistent algebraic components and derivatives
    /// of an index-1 problem. Consistency is checked when integration starts.
    pub fn new(
        sys: P,
        t0: f64,
        y0: &[f64],
        yp0: &[f64],
        p: &[f64],
        opts: BdfOptions,
    ) -> Result<Self, DaeError> {
        let n = sys.dim();
        if n == 0 {
            return Err(DaeError::InvalidInput("the system has no unknowns".into()));
        }
        if y0.len() != n || yp0.len() != n {
            return Err(DaeError::InvalidInput(format!(
                "y0 has length {}, y'0 has length {}, the system has {n} unknowns",
                y0.len(),
                yp0.len()
            )));
        }
        if !t0.is_finite() {
            return Err(DaeError::InvalidInput(format!("t0 = {t0} is not finite")));
        }
        if let Some(i) = y0.iter().chain(yp0).position(|v| !v.is_finite()) {
            let (which, j) = if i < n { ("y0", i) } else { ("y'0", i - n) };
            return Err(DaeError::InvalidInput(format!(
                "{which}[{j}] ({}) is not finite",
                sys.component_name(j)
            )));
        }
        if !(opts.rtol > 0.0 && opts.rtol.is_finite()) {
            return Err(DaeError::InvalidInput(format!(
                "rtol must be positive, got {}",
                opts.rtol
            )));
        }
        let atol = opts.atol.expand(n, |i| sys.component_name(i))?;
        let anderson_depth = opts.anderson_depth;
        if anderson_depth > anderson::MAX_DEPTH {
            return Err(DaeError::InvalidInput(format!(
                "anderson_depth must be 0–{}, got {anderson_depth}",
                anderson::MAX_DEPTH
            )));
        }
        if !(1..=MAX_ORDER).contains(&opts.max_order) {
            return Err(DaeError::InvalidInput(format!(
                "max_order must be 1–{MAX_ORDER}, got {}",
                opts.max_order
            )));
        }
        if opts.h_max.is_nan() || opts.h_max <= 0.0 {
            return Err(DaeError::InvalidInput(format!(
                "h_max must be positive, got {}",
                opts.h_max
            )));
        }
        if opts.step_ceiling_after_newton_failure.is_nan() || opts.step_ceiling_after_newton_failure <= 0.0 {
            return Err(DaeError::InvalidInput(format!(
                "step_ceiling_after_newton_failure must be positive (infinite for none), got {}",
                opts.step_ceiling_after_newton_failure
            )));
        }
        if !(opts.step_ceiling_relaxation >= 1.0 && opts.step_ceiling_relaxation.is_finite()) {
            return Err(DaeError::InvalidInput(format!(
                "step_ceiling_relaxation must be finite and at least 1, got {}",
                opts.step_ceiling_relaxation
            )));
        }
        if let Some(h) = opts.h_init {
            if !(h.is_finite() && h != 0.0) {
                return Err(DaeError::InvalidInput(format!(
                    "h_init must be finite and non-zero, got {h}"
                )));
            }
        }
        if opts.max_newton_iters == 0 || opts.max_steps == 0 {
            return Err(DaeError::InvalidInput(
                "max_newton_iters and max_steps must be at least 1".into(),
            ));
        }
        let kinds = sys.var_kinds();
        if kinds.len() != n {
            return Err(DaeError::InvalidInput(format!(
                "var_kinds() has length {}, expected {n}",
                kinds.len()
            )));
        }
        let err_index = sys.error_index();
        if err_index.len() != n || err_index.iter().any(|&j| !(1..=3).contains(&j)) {
            return Err(DaeError::InvalidInput(format!(
                "error_index() must give {n} values in 1..=3"
            )));
        }
        let pattern = sys.jacobian_pattern();
        if pattern.nrows() != n || pattern.ncols() != n {
            return Err(DaeError::InvalidInput(format!(
                "Jacobian pattern is {} × {}, expected {n} × {n}",
                pattern.nrows(),
                pattern.ncols()
            )));
        }
        let source = sys.jacobian_source();
        let mat = IterationMatrix::new(pattern, source, opts.linear_solver, &sys.eliminable_blocks())
            .map_err(|e| DaeError::LinearSolve {
                t: t0,
                h: 0.0,
                source: e,
                culprits: vec![],
            })?;
        let ne = sys.num_events();
        let mut phi = vec![vec![0.0; n]; MAX_ORDER + 2];
        phi[0].copy_from_slice(y0);
        phi[1].copy_from_slice(yp0);
        let opts_max_age = opts.max_steps_between_jacobians.max(1);
        let mut s = Self {
            sys,
            p: p.to_vec(),
            opts,
            n,
            kinds,
            err_index,
            atol,
            phi,
            psi: [0.0; MAX_ORDER + 2],
            alpha: [0.0; MAX_ORDER + 2],
            beta: [0.0; MAX_ORDER + 2],
            sigma: [0.0; MAX_ORDER + 2],
            gamma: [0.0; MAX_ORDER + 2],
            kk: 1,
            kused: 0,
            knew: 1,
            phase: 0,
            ns: 0,
            hh: 0.0,
            hused: 0.0,
            tn: t0,
            cj: 0.0,
            cjlast: 0.0,
            ck: 1.0,
            ss: 20.0,
            nst_local: 0,
            yy: y0.to_vec(),
            yp: yp0.to_vec(),
            ee: vec![0.0; n],
            delta: vec![0.0; n],
            ypred: vec![0.0; n],
            yppred: vec![0.0; n],
            ewt: vec![0.0; n],
            ewt_err: vec![0.0; n],
            ewt_test: vec![0.0; n],
            tmp: vec![0.0; n],
            ewt_newton: vec![0.0; n],
            ee_est: vec![0.0; n],
            res_base: vec![0.0; n],
            res_work: vec![0.0; n],
            yp_work: vec![0.0; n],
            filter_ok: false,
            mat,
            anderson: anderson::Anderson::new(n, anderson_depth),
            jac_current: false,
            force_setup: true,
            steps_since_jac: 0,
            jac_age_limit: opts_max_age,
            fresh_streak: 0,
            h_ceiling: f64::INFINITY,
            started: false,
            tret: t0,
            yret: y0.to_vec(),
            ypret: yp0.to_vec(),
            h_min: 0.0,
            events: output::EventState::new(ne),
            stats: Statistics::default(),
        };
        s.update_weights_from(y0);
        Ok(s)
    }

    /// Time of the solution returned last ([`y`](Self::y), [`yp`](Self::yp)).
    pub fn t(&self) -> f64 {
        self.tret
    }
    /// Solution at [`t`](Self::t).
    pub fn y(&self) -> &[f64] {
        &self.yret
    }
    /// Derivative at [`t`](Self::t).
    #[allow(clippy::misnamed_getters)] // `yp` is the internal corrector value at t_n
    pub fn yp(&self) -> &[f64] {
        &self.ypret
    }
    /// Time the integrator has actually reached (≥ [`t`](Self::t) in the direction of
    /// integration).
    pub fn t_internal(&self) -> f64 {
        self.tn
    }
    /// Work counters.
    pub fn stats(&self) -> &Statistics {
        &self.stats
    }
    /// The parameters p.
    pub fn params(&self) -> &[f64] {
        &self.p
    }
    /// Replaces the parameters p (same length). A change is a discontinuity for the
    /// integrator: follow it with [`restart`](Self::restart) or
    /// [`restart_from`](Self::restart_from).
    pub fn set_params(&mut self, p: &[f64]) -> Result<(), DaeError> {
        if p.len() != self.p.len() {
            return Err(DaeError::InvalidInput(format!(
                "parameter vector has length {}, expected {}",
                p.len(),
                self.p.len()
            )));
        }
        self.p.copy_from_slice(p);
        self.force_setup = true;
        Ok(())
    }
    /// The problem (read-only).
    pub fn system(&self) -> &P {
        &self.sys
    }
    /// The problem (mutable, e.g. to change an input between output times; declare a
    /// discontinuity with [`restart`](Self::restart) if the change is not smooth).
    pub fn system_mut(&mut self) -> &mut P {
        &mut self.sys
    }
    /// The options.
    pub fn options(&self) -> &BdfOptions {
        &self.opts
    }
    /// Sets (or clears) the stop time; the solver never steps past it.
    pub fn set_stop_time(&mut self, t_stop: Option<f64>) {
        self.opts.stop_time = t_stop;
    }
    /// Consumes the solver, returning the problem.
    pub fn into_system(self) -> P {
        self.sys
    }

    /// Recomputes the error weights 1/(rtol·|y_i| + atol_i) from `y`.
    pub(crate) fn update_weights_from(&mut self, y: &[f64]) {
        let suppress = self.opts.suppress_algebraic;
        for i in 0..self.n {
            let w = 1.0 / (self.opts.rtol * y[i].abs() + self.atol[i]);
            self.ewt[i] = w;
            self.ewt_err[i] = if suppress && self.kinds[i] == VarKind::Algebraic {
                0.0
            } else {
                w
            };
        }
    }

    /// Error-test weights for the current step size: `ewt_err` times min(|h|, 1)^(index − 1).
    pub(crate) fn update_test_weights(&mut self) {
        let hs = self.hh.abs().min(1.0);
        for i in 0..self.n {
            self.ewt_test[i] = match self.err_index[i] {
                1 => self.ewt_err[i],
                2 => self.ewt_err[i] * hs,
                _ => self.ewt_err[i] * hs * hs,
            };
        }
    }

    /// Weighted root-mean-square norm of `x` with weights `w`.
    pub(crate) fn wrms(x: &[f64], w: &[f64]) -> f64 {
        let s: f64 = x.iter().zip(w).map(|(a, b)| (a * b) * (a * b)).sum();
        (s / x.len() as f64).sqrt()
    }

    /// The `k` components with the largest |x_i|·w_i, named.
    pub(crate) fn culprits(&self, x: &[f64], w: &[f64], k: usize) -> Vec<Culprit> {
        crate::dae::error::largest(&self.sys, x, w, k)
    }
}
