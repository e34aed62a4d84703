//! Filtering of the local error estimates for stiff components.
//!
//! BDF's estimate of the local error is a scaled predictor–corrector difference. In stiff
//! components that difference measures a transient the method damps anyway (the fast
//! stretch of a stiff spring, the radial velocity of a mass on it as the spring turns), so
//! the raw estimate forces tiny steps and keeps the order low although the slow solution is
//! accurate. As proposed by Shampine (1980) for BDF codes and as RADAU5 does, each estimate
//! e is replaced by
//!
//!   ẽ = c_j · J⁻¹ · (∂F/∂y') · e,   J = ∂F/∂y + c_j·∂F/∂y',
//!
//! which equals e in non-stiff directions (where J ≈ c_j·∂F/∂y') and is damped by about
//! 1/(h·|λ|) in a direction with eigenvalue λ, |hλ| ≫ 1. (∂F/∂y')·e costs one residual
//! evaluation (a directional difference in y'), ẽ one solve with the existing LU.
//! Turn it off with [`BdfOptions::filter_error_estimate`](crate::dae::BdfOptions).

use super::BdfSolver;
use crate::dae::options::timed;
use crate::dae::problem::DaeSystem;

impl<P: DaeSystem> BdfSolver<P> {
    /// Evaluates F at the corrected (tn, yy, yp) into `res_base` once per step attempt.
    pub(crate) fn filter_prepare(&mut self) -> bool {
        self.stats.residual_evals += 1;
        let ok = self
            .sys
            .residual(self.tn, &self.yy, &self.yp, &self.p, &mut self.res_base)
            .is_ok()
            && self.res_base.iter().all(|v| v.is_finite());
        self.filter_ok = ok;
        ok
    }

    /// Replaces `x` by its filtered estimate c_j·J⁻¹·(∂F/∂y')·x. Leaves `x` unchanged if the
    /// residual or the solve fails (the raw estimate is then used).
    pub(crate) fn filter_estimate(&mut self, x: &mut [f64]) {
        if !self.filter_ok {
            return;
        }
        let nrm = Self::wrms(x, &self.ewt);
        if nrm == 0.0 || !nrm.is_finite() {
            return;
        }
        let sigma = 1.0 / nrm;
        for i in 0..self.n {
            self.yp_work[i] = self.yp[i] + sigma * x[i];
        }
        self.stats.residual_evals += 1;
        if self
            .sys
            .residual(self.tn, &self.yy, &self.yp_work, &self.p, &mut self.res_work)
            .is_err()
        {
            return;
        }
        let scale = self.cj / sigma;
        for i in 0..self.n {
            self.res_work[i] = (self.res_work[i] - self.res_base[i]) * scale;
        }
        let solved = timed(&mut self.stats.time.solve_s, || {
            self.mat.solve(&mut self.res_work)
        });
        if solved.is_ok() && self.res_work.iter().all(|v| v.is_finite()) {
            x.copy_from_slice(&self.res_work);
        }
    }
}
