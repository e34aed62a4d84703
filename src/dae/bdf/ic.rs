//! Consistent initial values: the consistency check at the start of integration, and the
//! computation of consistent algebraic components and derivatives of an index-1 problem
//! (IDA's IDACalcIC with IDA_YA_YDP_INIT).

use super::newton::NlsCause;
use super::BdfSolver;
use crate::dae::error::DaeError;
use crate::dae::problem::{DaeSystem, EvalError, VarKind};

impl<P: DaeSystem> BdfSolver<P> {
    fn ic_residual(&mut self, t: f64, r: &mut [f64]) -> Result<(), DaeError> {
        self.stats.residual_evals += 1;
        self.sys
            .residual(t, &self.yy, &self.yp, &self.p, r)
            .map_err(|e| match e {
                EvalError::Recoverable(m) | EvalError::Fatal(m) => DaeError::Evaluation { t, message: m },
            })?;
        if r.iter().any(|v| !v.is_finite()) {
            let bad: Vec<f64> = r.iter().map(|v| if v.is_finite() { 0.0 } else { 1.0 }).collect();
            return Err(DaeError::NonFiniteResidual {
                t,
                culprits: self.culprits(&bad, &vec![1.0; self.n], 5),
            });
        }
        Ok(())
    }

    /// Checks F(t0, y0, y'0) ≈ 0 at the start: the first Newton correction
    /// δ = J⁻¹F(t0, y0, y'0), with J the iteration matrix for the initial step, must be within
    /// the tolerances (weighted RMS norm ≤ 1, with the Newton iteration's weights). The factorisation is reused by the first step.
    pub(crate) fn check_consistency(&mut self) -> Result<(), DaeError> {
        let t0 = self.tn;
        let mut r = vec![0.0; self.n];
        self.ic_residual(t0, &mut r)?;
        self.delta.copy_from_slice(&r);
        self.cj = 1.0 / self.hh;
        let res = self.setup_for_ic_check();
        if let Err(cause) = res {
            return Err(match cause {
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
            });
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
            let culprits = self.culprits(&d, &self.ewt_newton.clone(), 3);
            return Err(DaeError::InconsistentInitialValues {
                t: t0,
                norm,
                culprits,
            });
        }
        Ok(())
    }

    fn setup_for_ic_check(&mut self) -> Result<(), NlsCause> {
        self.stats.jacobian_evals += 1;
        self.stats.residual_evals += self.mat.fd_cost();
        let r0 = self.delta.clone();
        let res = self.mat.setup(
            &mut self.sys,
            self.tn,
            &self.yy,
            &self.yp,
            &self.p,
            self.cj,
            &r0,
            &self.ewt,
            self.hh,
            &mut self.stats.time,
        );
        self.stats.lu_factorisations += 1;
        match res {
            Ok(()) => {
                self.force_setup = false;
                self.steps_since_jac = 0;
                Ok(())
            }
            Err(super::linsys::SetupError::Eval(EvalError::Recoverable(m) | EvalError::Fatal(m))) => {
                Err(NlsCause::Eval(m))
            }
            Err(super::linsys::SetupError::Linear(e)) => Err(NlsCause::Linear(e, self.singular_culprits())),
        }
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
        let mut j0 = vec![0.0; self.mat.pattern.nnz()];
        let mut iters = 0;
        let max_iters = 30;
        loop {
            self.ic_residual(t0, &mut r)?;
            // dF/dy (α = 0), then dF/dy + dF/dy' (α = 1).
            let (yy, yp, p) = (self.yy.clone(), self.yp.clone(), self.p.clone());
            let eval_err = |e: EvalError| match e {
                EvalError::Recoverable(m) | EvalError::Fatal(m) => DaeError::Evaluation { t: t0, message: m },
            };
            self.stats.jacobian_evals += 2;
            self.stats.residual_evals += 2 * self.mat.fd_cost();
            self.mat
                .evaluate(&mut self.sys, t0, &yy, &yp, &p, 0.0, &r, &self.ewt, h_scale)
                .map_err(eval_err)?;
            j0.copy_from_slice(&self.mat.values);
            self.mat
                .evaluate(&mut self.sys, t0, &yy, &yp, &p, 1.0, &r, &self.ewt, h_scale)
                .map_err(eval_err)?;
            for c in 0..n {
                let differential = self.kinds[c] == VarKind::Differential;
                for k in self.mat.pattern.col_range(c) {
                    self.mat.values[k] = if differential {
                        self.mat.values[k] - j0[k]
                    } else {
                        j0[k]
                    };
                }
            }
            self.mat.alpha = f64::NAN; // this factorisation is not an iteration matrix
            self.force_setup = true;
            self.stats.lu_factorisations += 1;
            let mut d = r.clone();
            if let Err(e) = self.mat.factor().and_then(|_| self.mat.solve(&mut d)) {
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
                if self.ic_residual(t0, &mut r_try).is_ok() {
                    let rn = r_try.iter().map(|v| v * v).sum::<f64>().sqrt();
                    if rn <= rnorm0 * (1.0 - 1e-4 * lambda) || rn <= 1e-14 || lambda < 0.01 {
                        accepted = true;
                        break;
                    }
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
