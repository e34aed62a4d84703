//! Robertson's chemical kinetics (Robertson 1966; Hairer & Wanner II, sec. IV.1) in the
//! index-1 DAE form used by IDA's example and the Bari test set's DAE variant:
//!
//! y1' = −0.04·y1 + 1e4·y2·y3,  y2' = 0.04·y1 − 1e4·y2·y3 − 3e7·y2²,  0 = y1 + y2 + y3 − 1.
//!
//! Dimensionless concentrations; time in s. Analytic Jacobian.

use crate::dae::{DaeSystem, EvalError, JacobianSource, VarKind};
use crate::sparse::CscPattern;

/// Robertson's kinetics as an index-1 DAE.
#[derive(Debug, Clone, Copy, Default)]
pub struct Robertson;

impl Robertson {
    /// Initial values y = (1, 0, 0) and consistent derivatives.
    pub fn initial_values() -> (Vec<f64>, Vec<f64>) {
        (vec![1.0, 0.0, 0.0], vec![-0.04, 0.04, 0.0])
    }

    /// Largest relative error of y against the reference at t = 1e11.
    pub fn relative_error(y: &[f64]) -> f64 {
        let r = &super::reference::ROBERTSON_T1E11;
        (0..3).map(|i| ((y[i] - r[i]) / r[i]).abs()).fold(0.0, f64::max)
    }
}

impl DaeSystem for Robertson {
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
        r[0] = yp[0] + 0.04 * y[0] - 1e4 * y[1] * y[2];
        r[1] = yp[1] - 0.04 * y[0] + 1e4 * y[1] * y[2] + 3e7 * y[1] * y[1];
        r[2] = y[0] + y[1] + y[2] - 1.0;
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(3, 3)
    }

    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::Analytic
    }

    fn jacobian(
        &mut self,
        _t: f64,
        y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        alpha: f64,
        v: &mut [f64],
    ) -> Result<(), EvalError> {
        // Column-major 3×3.
        v[0] = 0.04 + alpha;
        v[1] = -0.04;
        v[2] = 1.0;
        v[3] = -1e4 * y[2];
        v[4] = 1e4 * y[2] + 6e7 * y[1] + alpha;
        v[5] = 1.0;
        v[6] = -1e4 * y[1];
        v[7] = 1e4 * y[1];
        v[8] = 1.0;
        Ok(())
    }

    fn var_kinds(&self) -> Vec<VarKind> {
        vec![VarKind::Differential, VarKind::Differential, VarKind::Algebraic]
    }

    fn component_name(&self, i: usize) -> String {
        format!("y{}", i + 1)
    }
}
