//! Consistent initial values: the consistency check at the start of integration, and the
//! computation of consistent algebraic components and derivatives of an index-1 problem
//! (IDA's IDACalcIC with IDA_YA_YDP_INIT).

use super::linsys::MatrixKind;
use super::newton::{NlsCause, NlsFailure};
use super::BdfSolver;
use crate::dae::error::DaeError;
use crate::dae::problem::{DaeSystem, EvalError, VarKind};

impl<P: DaeSystem> BdfSolver<P> {
    /// Evaluates F(t, yy, yp) into `r`, counting it and checking it is finite. A recoverable
    /// callback failure and a non-finite residual are recoverable, a fatal one is fatal.
    fn ic_residual(&mut self, t: f64, r: &mut [f64]) -> Result<(), NlsFailure> {
        self.stats.residual_evals += 1;
        match self.sys.residual(t, &self.yy, &self.yp, &self.p, r) {
            Ok(()) => {}
            Err(EvalError::Recoverable(m)) => return Err(NlsFailure::Recoverable(NlsCause::Eval(m))),
            Err(EvalError::Fatal(m)) => {
                return Err(NlsFailure::Fatal(DaeError::Evaluation { t, message: m }))
            }
        }
        if r.iter().any(|v| !v.is_finite()) {
            let bad: Vec<f64> = r.iter().map(|v| if v.is_finite() { 0.0 } else { 1.0 }).collect();
            let culprits = self.culprits(&bad, &vec![1.0; self.n], 5);
            return Err(NlsFailure::Recoverable(NlsCause::NonFinite(culprits)));
        }
        Ok(())
    }

    /// The error that ends an initial-value computation or check at `t0` after `failure`
    /// (nothing is retried there): fatal errors unchanged, recoverable ones by their cause.
    fn ic_error(&self, t0: f64, failure: NlsFailure) -> DaeError {
        match failure {
            NlsFailure::Fatal(e) => e,
            NlsFailure::Recoverable(cause) => match cause {
                NlsCause::Linear(source, culprits) => DaeError::LinearSolve {
                    t: t0,
                    h: self.hh,
                    source,
                    culprits,
                },
                NlsCause::Eval(message) => DaeError::Evaluation { t: t0, message },
                NlsCause::NonFinite(culprits) => DaeError::NonFiniteResidual { t: t0, culprits },
                NlsCause::Convergence(culprits) => DaeError::InitialConditions {
                    t: t0,
                    reason: "iteration matrix".into(),
                    culprits,
                },
            },
        }
    }

    /// Checks F(t0, y0, y'0) ≈ 0 at the start: the first Newton correction
    /// δ = J⁻¹F(t0, y0, y'0), with J the iteration matrix for the initial step, must be within
    /// the tolerances (weighted RMS norm ≤ 1, with the Newton iteration's weights). The
    /// factorisation is reused by the first step.
    pub(crate) fn check_consistency(&mut self) -> Result<(), DaeError> {
        let t0 = self.tn;
        let mut r = vec![0.0; self.n];
        if let Err(f) = self.ic_residual(t0, &mut r) {
            return Err(self.ic_error(t0, f));
        }
        self.delta.copy_from_slice(&r);
        self.cj = 1.0 / self.hh;
        if let Err(f) = self.setup_matrix_kind(MatrixKind::Iteration { alpha: self.cj }, self.hh) {
            return Err(self.ic_error(t0, f));
        }
        let mut d = r.clone();
        if let Err(e) = self.mat.solve(&mut d) {
            return Err(DaeError::LinearSolve {
                t: t0,
                h: self.hh,
                source: e,
                culprits: self.singular_culprits(),
            });
        }
        self.update_newton_weights();
        let norm = Self::wrms(&d, &self.ewt_newton);
        if norm > 1.0 {
            let culprits = self.culprits(&d, &self.ewt_newton, 3);
            return Err(DaeError::InconsistentInitialValues {
                t: t0,
                norm,
                culprits,
            });
        }
        Ok(())
    }

    /// Computes consistent initial values of an index-1 problem: keeps the differential
    /// components of y0, and solves F(t0, y, y') = 0 for the algebraic components of y and
    /// the derivatives of the differential ones (algebraic derivatives are set to zero).
    ///
    /// `h_scale` is a time scale of the first steps (e.g. 1e-3 of the output interval); it
    /// weighs the derivative corrections in the convergence test. Returns the number of
    /// Newton iterations used.
    pub fn calc_ic(&mut self, h_scale: f64) -> Result<usize, DaeError> {
        let t0 = self.tn;
        if self.started {
            return Err(DaeError::InvalidInput(
                "calc_ic must be called before integration starts (or after restart)".into(),
            ));
        }
        if !(h_scale.is_finite() && h_scale > 0.0) {
            return Err(DaeError::InvalidInput(format!(
                "h_scale must be positive, got {h_scale}"
            )));
        }
        let n = self.n;
        self.yy.copy_from_slice(&self.phi[0]);
        self.yp.copy_from_slice(&self.phi[1]);
        for i in 0..n {
            if self.kinds[i] == VarKind::Algebraic {
                self.yp[i] = 0.0;
            }
        }
        let y0 = self.yy.clone();
        self.update_weights_from(&y0);
        let mut r = vec![0.0; n];
        let mut iters = 0;
        let max_iters = 30;
        loop {
            if let Err(f) = self.ic_residual(t0, &mut r) {
                return Err(self.ic_error(t0, f));
            }
            self.delta.copy_from_slice(&r);
            let mut d = r.clone();
            let solved = match self.setup_matrix_kind(MatrixKind::InitialCondition, h_scale) {
                Ok(()) => self.mat.solve(&mut d),
                Err(NlsFailure::Recoverable(NlsCause::Linear(e, _))) => Err(e),
                Err(f) => return Err(self.ic_error(t0, f)),
            };
            if let Err(e) = solved {
                return Err(DaeError::InitialConditions {
                    t: t0,
                    reason: format!("the matrix [dF/dy' (differential) | dF/dy (algebraic)] is singular: {e}; is the problem index 1?"),
                    culprits: self.singular_culprits(),
                });
            }
            // Damped update: halve while the residual norm grows.
            let rnorm0 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            let (y_old, yp_old) = (self.yy.clone(), self.yp.clone());
            let mut lambda = 1.0;
            let mut accepted = false;
            for _ in 0..8 {
                for i in 0..n {
                    if self.kinds[i] == VarKind::Differential {
                        self.yp[i] = yp_old[i] - lambda * d[i];
                    } else {
                        self.yy[i] = y_old[i] - lambda * d[i];
                    }
                }
                let mut r_try = vec![0.0; n];
                match self.ic_residual(t0, &mut r_try) {
                    Ok(()) => {
                        let rn = r_try.iter().map(|v| v * v).sum::<f64>().sqrt();
                        if rn <= rnorm0 * (1.0 - 1e-4 * lambda) || rn <= 1e-14 || lambda < 0.01 {
                            accepted = true;
                            break;
                        }
                    }
                    // Outside the model's domain: shorten the update.
                    Err(NlsFailure::Recoverable(_)) => {}
                    Err(f @ NlsFailure::Fatal(_)) => return Err(self.ic_error(t0, f)),
                }
                lambda *= 0.5;
            }
            iters += 1;
            self.stats.newton_iters += 1;
            let w: Vec<f64> = (0..n)
                .map(|i| {
                    if self.kinds[i] == VarKind::Differential {
                        self.ewt[i] * h_scale
                    } else {
                        self.ewt[i]
                    }
                })
                .collect();
            let dnorm = Self::wrms(&d, &w) * lambda;
            if accepted && dnorm <= 1e-3 {
                break;
            }
            if iters >= max_iters {
                let culprits = self.culprits(&r, &vec![1.0; n], 3);
                return Err(DaeError::InitialConditions {
                    t: t0,
                    reason: format!("no convergence in {max_iters} Newton iterations (last weighted correction {dnorm:.3e})"),
                    culprits,
                });
            }
        }
        self.phi[0].copy_from_slice(&self.yy);
        self.phi[1].copy_from_slice(&self.yp);
        self.yret.copy_from_slice(&self.yy);
        self.ypret.copy_from_slice(&self.yp);
        Ok(iters)
    }
}
