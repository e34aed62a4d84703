//! The Newton iteration of one step, with Jacobian/LU reuse and refresh (IDA's IDANls and
//! the SUNDIALS Newton solver).
//!
//! The iteration matrix J = dF/dy + c_j·dF/dy' is reused across steps while c_j stays within
//! a factor [0.6, 1.67] of the value it was built with (the solve is then rescaled by
//! 2/(1 + c_j/c_old)). It is rebuilt when
//! * the iteration fails to converge with a stale matrix (retried at once, no step reduction);
//! * the previous step converged slowly (rate above `jacobian_refresh_rate`): stiff directions
//!   are turning, and a stale matrix would soon diverge;
//! * `max_steps_between_jacobians` steps have passed;
//! * within the iteration, when it converges slower than `jacobian_refresh_rate` (at most
//!   `max_jacobian_refreshes_in_solve` times per solve; IDA never does) and, at the rate
//!   measured, would not pass the convergence test in the iterations left: the matrix is
//!   rebuilt at the current iterate, a full Newton step, because stiff forces that switch on
//!   within the step (contact) otherwise make the iteration crawl and the step fail. A slow
//!   iteration that will still converge in time is left to do so (cheaper than a
//!   factorisation).
//!
//! With `anderson_depth` > 0 each iterate is accelerated (`anderson.rs`); a new matrix or a
//! new attempt starts the acceleration's history afresh. The norms are those of the plain
//! correction J⁻¹·F at each iterate, and the convergence test's rate is the larger of the
//! measured one and the plain map's (the first pair after a start), which bounds an
//! accelerated iterate's error. The decisions at the first measured rate (rebuild the matrix,
//! declare divergence) are the plain iteration's: they come before any accelerated iterate
//! (waiting one more iteration for them was measured, with more Newton failures on the
//! MR2120 L1 run).

use super::BdfSolver;
use crate::dae::error::{Culprit, DaeError};
use crate::dae::options::timed;
use crate::dae::problem::{DaeSystem, EvalError};
use crate::sparse::LinearSolveError;

use super::linsys::MatrixKind;

/// What made a nonlinear solve fail.
#[derive(Debug, Clone)]
pub(crate) enum NlsCause {
    /// The iteration diverged or did not converge in the allowed iterations.
    Convergence(Vec<Culprit>),
    /// The iteration matrix could not be factorised or solved with.
    Linear(LinearSolveError, Vec<Culprit>),
    /// The residual was NaN or infinite.
    NonFinite(Vec<Culprit>),
    /// A callback reported a recoverable failure.
    Eval(String),
}

impl NlsCause {
    pub(crate) fn culprits(&self) -> Vec<Culprit> {
        match self {
            NlsCause::Convergence(c) | NlsCause::Linear(_, c) | NlsCause::NonFinite(c) => c.clone(),
            NlsCause::Eval(_) => vec![],
        }
    }
}

pub(crate) enum NlsFailure {
    Recoverable(NlsCause),
    Fatal(DaeError),
}

impl<P: DaeSystem> BdfSolver<P> {
    /// Evaluates F(tn, yy, yp) into `delta`, counting it and checking it is finite.
    fn eval_residual(&mut self) -> Result<(), NlsFailure> {
        self.stats.residual_evals += 1;
        let res = timed(&mut self.stats.time.residual_s, || {
            self.sys
                .residual(self.tn, &self.yy, &self.yp, &self.p, &mut self.delta)
        });
        match res {
            Ok(()) => {}
            Err(EvalError::Recoverable(m)) => return Err(NlsFailure::Recoverable(NlsCause::Eval(m))),
            Err(EvalError::Fatal(m)) => {
                return Err(NlsFailure::Fatal(DaeError::Evaluation {
                    t: self.tn,
                    message: m,
                }))
            }
        }
        if self.delta.iter().any(|v| !v.is_finite()) {
            let bad: Vec<f64> = self
                .delta
                .iter()
                .map(|v| if v.is_finite() { 0.0 } else { 1.0 })
                .collect();
            let ones = vec![1.0; self.n];
            let mut c = self.culprits(&bad, &ones, 5);
            for x in c.iter_mut() {
                x.weighted = self.delta[x.index];
            }
            return Err(NlsFailure::Recoverable(NlsCause::NonFinite(c)));
        }
        Ok(())
    }

    /// Builds and factorises the iteration matrix at the current iterate (through the one
    /// set-up path, [`setup_matrix_kind`](Self::setup_matrix_kind)).
    fn setup_matrix(&mut self) -> Result<(), NlsFailure> {
        self.setup_matrix_kind(MatrixKind::Iteration { alpha: self.cj }, self.hh)?;
        self.jac_current = true;
        self.ss = 20.0;
        Ok(())
    }

    /// Names the equations and unknowns whose rows or columns of J are entirely zero.
    pub(crate) fn singular_culprits(&self) -> Vec<Culprit> {
        let mut out = Vec::new();
        for r in self.mat.zero_rows() {
            out.push(Culprit {
                index: r,
                name: format!("equation {} (row of zeros)", self.sys.component_name(r)),
                weighted: 0.0,
            });
        }
        for c in self.mat.zero_columns() {
            out.push(Culprit {
                index: c,
                name: format!("unknown {} (column of zeros)", self.sys.component_name(c)),
                weighted: 0.0,
            });
        }
        out.truncate(8);
        out
    }

    /// Solves the corrector equation F(tn, y_pred + e, y'_pred + c_j·e) = 0 for e (`ee`),
    /// leaving the corrected solution in `yy`, `yp`.
    pub(crate) fn nonlinear_solve(&mut self) -> Result<(), NlsFailure> {
        let cjratio = if self.mat.alpha != 0.0 {
            self.cj / self.mat.alpha
        } else {
            0.0
        };
        let mut call_setup = self.force_setup
            || !self.mat.is_factored()
            || !(0.6..=1.0 / 0.6).contains(&cjratio)
            || self.steps_since_jac >= self.jac_age_limit;
        if self.cj != self.cjlast {
            self.ss = 100.0;
        }
        self.jac_current = false;
        loop {
            match self.newton_attempt(call_setup) {
                Ok(rate) => {
                    self.adapt_jacobian_age(!call_setup, rate <= self.opts.jacobian_refresh_rate);
                    return Ok(());
                }
                Err(NlsFailure::Recoverable(cause)) => {
                    let retry =
                        !self.jac_current && !matches!(cause, NlsCause::Eval(_) | NlsCause::NonFinite(_));
                    if retry {
                        self.adapt_jacobian_age(true, false);
                        call_setup = true;
                        continue;
                    }
                    // A fresh matrix will be needed after the step-size change.
                    self.force_setup = true;
                    return Err(NlsFailure::Recoverable(cause));
                }
                Err(f) => return Err(f),
            }
        }
    }

    /// Weights of the Newton convergence test: the error weights, with algebraic components
    /// scaled by min(|h|, 1) when they are suppressed from the error test. Multipliers of an
    /// index-2 formulation act on the solution only through h·λ (an impulse over the step),
    /// and the iteration matrix has condition ~1/h², so their round-off grows like 1/h and
    /// must not stop the iteration at tiny steps (Hairer & Wanner II, VII.3 scale index-2
    /// variables the same way).
    pub(crate) fn update_newton_weights(&mut self) {
        let scale = self.hh.abs().min(1.0);
        for i in 0..self.n {
            self.ewt_newton[i] =
                if self.opts.suppress_algebraic && self.kinds[i] == crate::dae::VarKind::Algebraic {
                    self.ewt[i] * scale
                } else {
                    self.ewt[i]
                };
        }
    }

    /// Adapts how many steps a Jacobian may be reused. A reused matrix that failed or
    /// converged slowly drops the limit to 1 (a fresh matrix every step: stiff directions are
    /// turning); successful reuse doubles it back towards `max_steps_between_jacobians`, and
    /// after 8 steps at limit 1 reuse is probed again.
    fn adapt_jacobian_age(&mut self, reused: bool, good: bool) {
        let max = self.opts.max_steps_between_jacobians.max(1);
        if reused {
            self.jac_age_limit = if good {
                (2 * self.jac_age_limit).min(max)
            } else {
                1
            };
            self.fresh_streak = 0;
        } else if self.jac_age_limit == 1 {
            self.fresh_streak += 1;
            if self.fresh_streak >= 8 {
                self.jac_age_limit = 2.min(max);
                self.fresh_streak = 0;
            }
        }
    }

    /// One Newton iteration run; returns the last measured convergence rate (0 if the first
    /// iterate was accepted).
    fn newton_attempt(&mut self, call_setup: bool) -> Result<f64, NlsFailure> {
        self.update_newton_weights();
        self.yy.copy_from_slice(&self.ypred);
        self.yp.copy_from_slice(&self.yppred);
        self.ee.iter_mut().for_each(|v| *v = 0.0);
        self.anderson.reset();
        self.eval_residual()?;
        if call_setup {
            self.setup_matrix()?;
        }
        let scale = {
            let r = self.cj / self.mat.alpha;
            if (r - 1.0).abs() > 0.0 {
                2.0 / (1.0 + r)
            } else {
                1.0
            }
        };
        let mut scale = scale;
        let mut oldnrm = 0.0;
        // Iterations since the matrix was last rebuilt (the rate is measured from there).
        let mut since = 0usize;
        let mut refreshes = 0usize;
        // The plain iteration's rate over the first pair since the last start (0 before it
        // is measured); used only with the acceleration.
        let mut plain_rate = 0.0f64;
        let maxcor = self.opts.max_newton_iters;
        for m in 0..maxcor {
            self.stats.newton_iters += 1;
            // delta ← J⁻¹ F
            if let Err(e) = timed(&mut self.stats.time.solve_s, || self.mat.solve(&mut self.delta)) {
                return Err(NlsFailure::Recoverable(NlsCause::Linear(
                    e,
                    self.singular_culprits(),
                )));
            }
            if scale != 1.0 {
                self.delta.iter_mut().for_each(|v| *v *= scale);
            }
            let cj = self.cj;
            self.anderson.advance(&mut self.ee, &self.delta, &self.ewt_newton);
            for ((((y, p), &yh), &ph), &e) in self
                .yy
                .iter_mut()
                .zip(self.yp.iter_mut())
                .zip(&self.ypred)
                .zip(&self.yppred)
                .zip(&self.ee)
                .take(self.n)
            {
                *y = yh + e;
                *p = ph + cj * e;
            }
            let delnrm = Self::wrms(&self.delta, &self.ewt_newton);
            if !delnrm.is_finite() {
                let c = self.culprits(&self.delta, &self.ewt_newton, 3);
                return Err(NlsFailure::Recoverable(NlsCause::Convergence(c)));
            }
            let mut rate = 0.0;
            if since == 0 {
                oldnrm = delnrm;
                if delnrm <= 100.0 * f64::EPSILON * Self::wrms(&self.yy, &self.ewt_newton) {
                    return Ok(0.0);
                }
            } else {
                rate = (delnrm / oldnrm).powf(1.0 / since as f64);
                if since == 1 {
                    // The first pair after a new start is the plain iteration's: e₁ = e₀ − δ₀.
                    plain_rate = rate;
                }
                // Slow or diverging with a matrix from the start of the step: a contact or
                // other stiff force has changed within the step. Rebuild the matrix at the
                // current iterate (a full Newton step) instead of failing the step.
                // Only when, at the measured rate, the iterations left would not converge:
                // a slow iteration that will still make it costs less than a factorisation.
                if rate > self.opts.jacobian_refresh_rate
                    && refreshes < self.opts.max_jacobian_refreshes_in_solve
                    && m + 1 < maxcor
                    && !converges_within(rate, delnrm, self.opts.newton_tol, maxcor - m - 1)
                {
                    refreshes += 1;
                    self.anderson.reset();
                    plain_rate = 0.0;
                    self.eval_residual()?;
                    self.setup_matrix()?;
                    scale = 1.0;
                    since = 0;
                    continue;
                }
                if rate > self.opts.newton_max_rate {
                    let c = self.culprits(&self.delta, &self.ewt_newton, 3);
                    return Err(NlsFailure::Recoverable(NlsCause::Convergence(c)));
                }
                // An accelerated iterate's error is bounded through the plain map's
                // contraction, not the accelerated residuals' (which fall faster): the test
                // takes the larger of the two rates.
                let r = if self.opts.anderson_depth > 0 {
                    rate.max(plain_rate)
                } else {
                    rate
                };
                self.ss = r / (1.0 - r);
            }
            // With a matrix from an earlier step, the rate estimate of that step says nothing
            // about this one (stiff directions may have turned): measure it, i.e. do not
            // accept the first iterate.
            let trust = since > 0 || self.jac_current || !self.opts.measure_rate_with_stale_jacobian;
            if trust && self.ss * delnrm <= self.opts.newton_tol {
                if rate > self.opts.jacobian_refresh_rate {
                    self.force_setup = true;
                }
                return Ok(rate);
            }
            if m + 1 == maxcor {
                break;
            }
            since += 1;
            self.eval_residual()?;
        }
        let c = self.culprits(&self.delta, &self.ewt_newton, 3);
        Err(NlsFailure::Recoverable(NlsCause::Convergence(c)))
    }
}

/// Whether an iteration contracting at `rate` from a correction of weighted norm `delnrm`
/// passes the convergence test ss·‖δ‖ ≤ `tol` (ss = rate/(1 − rate)) within `left` more
/// iterations.
fn converges_within(rate: f64, delnrm: f64, tol: f64, left: usize) -> bool {
    if rate.is_nan() || rate >= 1.0 || left == 0 {
        return false;
    }
    let ss = rate / (1.0 - rate);
    ss * delnrm * rate.powi(left as i32) <= tol
}

#[cfg(test)]
mod tests {
    use super::converges_within;

    #[test]
    fn a_slow_iteration_is_kept_only_when_it_converges_in_the_iterations_left() {
        // rate 0.5, ss = 1: 1·0.5² = 0.25 ≤ 0.33 after two more iterations, 0.5 after one.
        assert!(converges_within(0.5, 1.0, 0.33, 2));
        assert!(!converges_within(0.5, 1.0, 0.33, 1));
        assert!(!converges_within(0.95, 1e-3, 0.33, 0));
        assert!(!converges_within(1.2, 1e-6, 0.33, 5));
        assert!(!converges_within(f64::NAN, 1e-6, 0.33, 5));
    }
}
