//! One BDF step: coefficients, predictor, local error test, order and step-size selection.
//! (IDA's IDAStep, IDASetCoeffs, IDAPredict, IDATestError, IDAHandleNFlag, IDAComplete.)

use super::newton::{NlsCause, NlsFailure};
use super::BdfSolver;
use crate::dae::error::DaeError;
use crate::dae::problem::DaeSystem;

/// A step counts as grown when it exceeds the last accepted step by more than this factor
/// (round-off in the step-size arithmetic left aside); only a grown step whose Newton
/// iteration fails sets the step ceiling (`BdfOptions::step_ceiling_after_newton_failure`).
const GROWN: f64 = 1.01;

/// Outcome of the local error test.
struct ErrorEstimates {
    err_k: f64,
    err_km1: f64,
}

impl<P: DaeSystem> BdfSolver<P> {
    /// Takes one step from `tn`, retrying with smaller steps or lower order on failure.
    pub(crate) fn take_step(&mut self) -> Result<(), DaeError> {
        let saved_t = self.tn;
        if self.nst_local == 0 {
            self.kk = 1;
            self.kused = 0;
            self.hused = 0.0;
            self.psi[0] = self.hh;
            self.cj = 1.0 / self.hh;
            self.phase = 0;
            self.ns = 0;
        }
        let mut nef = 0usize;
        let mut ncf = 0usize;
        loop {
            self.set_coeffs();
            self.tn = saved_t + self.hh;
            if let Some(ts) = self.opts.stop_time {
                if (self.tn - ts) * self.hh > 0.0 || (self.tn - ts).abs() <= 4.0 * f64::EPSILON * ts.abs() {
                    self.tn = ts;
                }
            }
            self.predict();
            let outcome = match self.nonlinear_solve() {
                Ok(()) => match self.test_error() {
                    Ok(e) => Ok(e),
                    Err(e) => Err(StepFailure::ErrorTest(e)),
                },
                Err(NlsFailure::Recoverable(c)) => Err(StepFailure::Newton(c)),
                Err(NlsFailure::Fatal(e)) => {
                    self.restore(saved_t);
                    return Err(e);
                }
            };
            match outcome {
                Ok(est) => {
                    self.complete_step(est);
                    return Ok(());
                }
                Err(fail) => {
                    self.restore(saved_t);
                    let rr;
                    let culprits;
                    let mut specific: Option<NlsCause> = None;
                    match fail {
                        StepFailure::ErrorTest(est) => {
                            nef += 1;
                            self.stats.error_test_failures += 1;
                            culprits = self.culprits(&self.ee_est, &self.ewt_test, 3);
                            if nef >= self.opts.max_error_test_fails {
                                return Err(DaeError::ErrorTestFailures {
                                    t: saved_t,
                                    h: self.hh,
                                    fails: nef,
                                    culprits,
                                });
                            }
                            if nef == 1 {
                                let err_knew = if self.kk == self.knew {
                                    est.err_k
                                } else {
                                    est.err_km1
                                };
                                self.kk = self.knew;
                                rr = (0.9 * (2.0 * err_knew + 1e-4).powf(-1.0 / (self.kk as f64 + 1.0)))
                                    .clamp(0.25, 0.9);
                            } else if nef == 2 {
                                self.kk = self.knew;
                                rr = 0.25;
                            } else {
                                self.kk = 1;
                                rr = 0.25;
                            }
                        }
                        StepFailure::Newton(cause) => {
                            ncf += 1;
                            self.stats.newton_failures += 1;
                            culprits = cause.culprits();
                            if ncf >= self.opts.max_newton_fails {
                                return Err(self.newton_error(saved_t, ncf, cause));
                            }
                            if !matches!(cause, NlsCause::Convergence(_)) {
                                specific = Some(cause);
                            }
                            rr = 0.25;
                            // Only a step that had just grown past the last accepted one
                            // sets a ceiling: there the growth is what failed. A failure at
                            // an unchanged or smaller step (a contact switching within it)
                            // says nothing about the step size that converges.
                            if self.hh.abs() > GROWN * self.hused.abs() {
                                self.h_ceiling = self
                                    .h_ceiling
                                    .min(self.opts.step_ceiling_after_newton_failure * self.hh.abs());
                            }
                        }
                    }
                    self.hh *= rr;
                    let floor = self.h_min.max(16.0 * f64::EPSILON * saved_t.abs()).max(1e-290);
                    if self.hh.abs() < floor {
                        // A NaN residual, a singular matrix or a failing callback is the
                        // cause, not the step size: report it.
                        if let Some(cause) = specific {
                            return Err(self.newton_error(saved_t, ncf, cause));
                        }
                        return Err(DaeError::StepTooSmall {
                            t: saved_t,
                            h: self.hh,
                            h_min: floor,
                            culprits,
                        });
                    }
                    if self.nst_local == 0 {
                        self.psi[0] = self.hh;
                        for v in self.phi[1].iter_mut() {
                            *v *= rr;
                        }
                    }
                }
            }
        }
    }

    /// Recomputes the BDF coefficients for step `hh` at order `kk` (IDASetCoeffs) and scales
    /// the history by β.
    fn set_coeffs(&mut self) {
        let kk = self.kk;
        if self.hh != self.hused || kk != self.kused {
            self.ns = 0;
        }
        self.ns = (self.ns + 1).min(self.kused + 2);
        if kk + 1 >= self.ns {
            self.beta[0] = 1.0;
            self.alpha[0] = 1.0;
            let mut temp1 = self.hh;
            self.gamma[0] = 0.0;
            self.sigma[0] = 1.0;
            for i in 1..=kk {
                let temp2 = self.psi[i - 1];
                self.psi[i - 1] = temp1;
                self.beta[i] = self.beta[i - 1] * self.psi[i - 1] / temp2;
                temp1 = temp2 + self.hh;
                self.alpha[i] = self.hh / temp1;
                self.sigma[i] = i as f64 * self.sigma[i - 1] * self.alpha[i];
                self.gamma[i] = self.gamma[i - 1] + self.alpha[i - 1] / self.hh;
            }
            self.psi[kk] = temp1;
        }
        let mut alphas = 0.0;
        let mut alpha0 = 0.0;
        for i in 0..kk {
            alphas -= 1.0 / (i as f64 + 1.0);
            alpha0 -= self.alpha[i];
        }
        self.cjlast = self.cj;
        self.cj = -alphas / self.hh;
        self.ck = ((self.alpha[kk] + alphas - alpha0).abs()).max(self.alpha[kk]);
        if self.ns <= kk {
            for i in self.ns..=kk {
                let b = self.beta[i];
                for v in self.phi[i].iter_mut() {
                    *v *= b;
                }
            }
        }
    }

    /// Predictor: y_pred = Σ φ_j, y'_pred = Σ γ_j φ_j.
    fn predict(&mut self) {
        let kk = self.kk;
        self.ypred.copy_from_slice(&self.phi[0]);
        self.yppred.iter_mut().for_each(|v| *v = 0.0);
        for j in 1..=kk {
            let g = self.gamma[j];
            for ((yp, ypp), ph) in self
                .ypred
                .iter_mut()
                .zip(self.yppred.iter_mut())
                .zip(&self.phi[j])
            {
                *yp += ph;
                *ypp += g * ph;
            }
        }
    }

    /// Local error test on the accumulated correction `ee` (IDATestError). Also proposes the
    /// order `knew` for a retry.
    fn test_error(&mut self) -> Result<ErrorEstimates, ErrorEstimates> {
        let kk = self.kk;
        self.update_test_weights();
        let filter = self.opts.filter_error_estimate && self.filter_prepare();
        let mut e = std::mem::take(&mut self.ee_est);
        e.copy_from_slice(&self.ee);
        if filter {
            self.filter_estimate(&mut e);
        }
        self.ee_est = e;
        let enorm_k = Self::wrms(&self.ee_est, &self.ewt_test);
        let err_k = self.sigma[kk] * enorm_k;
        let terr_k = (kk as f64 + 1.0) * err_k;
        let mut err_km1 = 0.0;
        self.knew = kk;
        if kk > 1 {
            let mut d = std::mem::take(&mut self.delta);
            d.copy_from_slice(&self.phi[kk]);
            if filter {
                self.filter_estimate(&mut d);
            }
            for i in 0..self.n {
                d[i] += self.ee_est[i];
            }
            let enorm_km1 = Self::wrms(&d, &self.ewt_test);
            err_km1 = self.sigma[kk - 1] * enorm_km1;
            let terr_km1 = kk as f64 * err_km1;
            if kk > 2 {
                let mut d2 = std::mem::take(&mut self.tmp);
                d2.copy_from_slice(&self.phi[kk - 1]);
                if filter {
                    self.filter_estimate(&mut d2);
                }
                for i in 0..self.n {
                    d[i] += d2[i];
                }
                self.tmp = d2;
                let enorm_km2 = Self::wrms(&d, &self.ewt_test);
                let err_km2 = self.sigma[kk - 2] * enorm_km2;
                let terr_km2 = (kk as f64 - 1.0) * err_km2;
                if terr_km1.max(terr_km2) <= terr_k {
                    self.knew = kk - 1;
                }
            } else if terr_km1 <= 0.5 * terr_k {
                self.knew = kk - 1;
            }
            self.delta = d;
        }
        let est = ErrorEstimates { err_k, err_km1 };
        if self.ck * enorm_k > 1.0 || !enorm_k.is_finite() {
            Err(est)
        } else {
            Ok(est)
        }
    }

    /// Undoes the history scaling of a failed attempt (IDARestore).
    fn restore(&mut self, saved_t: f64) {
        self.tn = saved_t;
        for j in 1..=self.kk {
            self.psi[j - 1] = self.psi[j] - self.hh;
        }
        if self.ns <= self.kk {
            for j in self.ns..=self.kk {
                let b = 1.0 / self.beta[j];
                for v in self.phi[j].iter_mut() {
                    *v *= b;
                }
            }
        }
    }

    /// Accepts the step: updates the history and chooses the next order and step size
    /// (IDACompleteStep).
    fn complete_step(&mut self, est: ErrorEstimates) {
        let ErrorEstimates { err_k, err_km1 } = est;
        self.stats.steps += 1;
        self.nst_local += 1;
        self.steps_since_jac += 1;
        let kdiff = self.kk as isize - self.kused as isize;
        self.kused = self.kk;
        self.hused = self.hh;
        let max_order = self.opts.max_order;
        if self.knew + 1 == self.kk || self.kk == max_order {
            self.phase = 1;
        }
        let hmax = self.opts.h_max;
        if self.phase == 0 {
            if self.nst_local > 1 {
                self.kk += 1;
                let mut hnew = 2.0 * self.hh;
                if hnew.abs() > hmax {
                    hnew = hmax.copysign(hnew);
                }
                self.hh = hnew;
            }
        } else {
            #[derive(PartialEq)]
            enum Action {
                Unset,
                Lower,
                Maintain,
                Raise,
            }
            let kk = self.kk;
            let mut action = Action::Unset;
            if self.knew + 1 == kk {
                action = Action::Lower;
            } else if kk == max_order || kk + 1 >= self.ns || kdiff == 1 {
                action = Action::Maintain;
            }
            let mut err_kp1 = 0.0;
            if action == Action::Unset {
                let mut d = std::mem::take(&mut self.tmp);
                d.copy_from_slice(&self.phi[kk + 1]);
                if self.opts.filter_error_estimate && self.filter_ok {
                    self.filter_estimate(&mut d);
                }
                for i in 0..self.n {
                    d[i] = self.ee_est[i] - d[i];
                }
                self.tmp = d;
                let enorm_kp1 = Self::wrms(&self.tmp, &self.ewt_test);
                err_kp1 = enorm_kp1 / (kk as f64 + 2.0);
                action = if kk == 1 {
                    if err_kp1 >= 0.5 * err_k {
                        Action::Maintain
                    } else {
                        Action::Raise
                    }
                } else if err_km1 <= err_k.min(err_kp1) {
                    Action::Lower
                } else if err_kp1 >= err_k {
                    Action::Maintain
                } else {
                    Action::Raise
                };
            }
            let err_knew = match action {
                Action::Raise => {
                    self.kk += 1;
                    err_kp1
                }
                Action::Lower => {
                    self.kk -= 1;
                    err_km1
                }
                _ => err_k,
            };
            let rr = (2.0 * err_knew + 1e-4).powf(-1.0 / (self.kk as f64 + 1.0));
            let mut hnew = if rr >= 2.0 {
                2.0 * self.hh
            } else if rr <= 1.0 {
                self.hh * rr.clamp(0.5, 0.9)
            } else {
                self.hh
            };
            if hnew.abs() > hmax {
                hnew = hmax.copysign(hnew);
            }
            self.hh = hnew;
        }
        // Below the ceiling a Newton failure set; the ceiling rises with every accepted step.
        if self.h_ceiling.is_finite() {
            if self.hh.abs() > self.h_ceiling {
                self.hh = self.h_ceiling.copysign(self.hh);
            }
            self.h_ceiling *= self.opts.step_ceiling_relaxation;
        }
        // Save ee for a possible order increase on the next step; update the history.
        let kused = self.kused;
        if kused < max_order {
            self.phi[kused + 1].copy_from_slice(&self.ee);
        }
        for i in 0..self.n {
            self.phi[kused][i] += self.ee[i];
        }
        for j in (0..kused).rev() {
            let (lo, hi) = self.phi.split_at_mut(j + 1);
            for (a, b) in lo[j].iter_mut().zip(&hi[0]) {
                *a += b;
            }
        }
        self.stats.last_order = self.kused;
        self.stats.last_step = self.hused;
        // Optional projection onto the problem's invariants (Eich 1993: projecting the
        // current value only keeps a multistep method's order).
        let mut y = std::mem::take(&mut self.tmp);
        y.copy_from_slice(&self.phi[0]);
        if self.sys.project(self.tn, &mut y, &self.p) {
            self.phi[0].copy_from_slice(&y);
        }
        self.yy.copy_from_slice(&y);
        self.update_weights_from(&y);
        self.tmp = y;
    }
}

enum StepFailure {
    ErrorTest(ErrorEstimates),
    Newton(NlsCause),
}

impl<P: DaeSystem> BdfSolver<P> {
    /// The error reported when a step fails for good in the nonlinear solve.
    fn newton_error(&self, t: f64, fails: usize, cause: NlsCause) -> DaeError {
        match cause {
            NlsCause::Convergence(culprits) => DaeError::NewtonFailures {
                t,
                h: self.hh,
                fails,
                culprits,
            },
            NlsCause::Linear(source, culprits) => DaeError::LinearSolve {
                t,
                h: self.hh,
                source,
                culprits,
            },
            NlsCause::NonFinite(culprits) => DaeError::NonFiniteResidual { t, culprits },
            NlsCause::Eval(message) => DaeError::Evaluation { t, message },
        }
    }
}
