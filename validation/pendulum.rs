//! A planar pendulum in GGL-stabilised index-2 form (Gear, Gupta & Leimkuhler 1985):
//!
//! q' = v − Gᵀμ,  m·v' = f − Gᵀλ,  0 = g(q),  0 = G(q)·v,
//!
//! with q = (x, y) in m, v in m/s, g(q) = (x² + y² − L²)/2, G = (x, y), gravity along −y.
//! λ and μ are algebraic (excluded from the error test). Both position and velocity
//! constraints hold at every step, so the constraint drift stays at the Newton tolerance.

use super::reference::G;
use crate::dae::explicit::OdeSystem;
use crate::dae::{DaeSystem, EvalError, JacobianSource, VarKind};
use crate::sparse::CscPattern;

/// GGL pendulum: mass `m` (kg) on a massless rod of length `l` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GglPendulum {
    /// Mass, kg.
    pub m: f64,
    /// Rod length, m.
    pub l: f64,
    /// Gravity, m/s².
    pub g: f64,
}

impl Default for GglPendulum {
    fn default() -> Self {
        Self { m: 1.0, l: 1.0, g: G }
    }
}

impl GglPendulum {
    /// Initial state released at rest at angle `theta0` from the downward vertical:
    /// y = (x, y, u, v, λ, μ) and a consistent y'.
    pub fn initial_values(&self, theta0: f64) -> (Vec<f64>, Vec<f64>) {
        let (s, c) = theta0.sin_cos();
        let (x, y) = (self.l * s, -self.l * c);
        // At rest: λ from the normal balance, m·v' = −λ(x, y) − m·g·ŷ with v'·q = 0 (|v| = 0).
        let lam = -self.m * self.g * y / (self.l * self.l);
        let ax = -lam * x / self.m;
        let ay = -lam * y / self.m - self.g;
        (vec![x, y, 0.0, 0.0, lam, 0.0], vec![0.0, 0.0, ax, ay, 0.0, 0.0])
    }

    /// Position-constraint violation |x² + y² − L²|/2, m².
    pub fn drift(&self, y: &[f64]) -> f64 {
        (0.5 * (y[0] * y[0] + y[1] * y[1] - self.l * self.l)).abs()
    }

    /// Angle from the downward vertical, rad.
    pub fn angle(y: &[f64]) -> f64 {
        y[0].atan2(-y[1])
    }

    /// Total energy, J (potential zero at the pivot height).
    pub fn energy(&self, y: &[f64]) -> f64 {
        0.5 * self.m * (y[2] * y[2] + y[3] * y[3]) + self.m * self.g * y[1]
    }
}

impl DaeSystem for GglPendulum {
    fn dim(&self) -> usize {
        6
    }

    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        let (x, yy, u, v, lam, mu) = (y[0], y[1], y[2], y[3], y[4], y[5]);
        r[0] = yp[0] - u + mu * x;
        r[1] = yp[1] - v + mu * yy;
        r[2] = self.m * yp[2] + lam * x;
        r[3] = self.m * yp[3] + lam * yy + self.m * self.g;
        r[4] = 0.5 * (x * x + yy * yy - self.l * self.l);
        r[5] = x * u + yy * v;
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        let e = [
            (0, 0),
            (1, 1),
            (2, 0),
            (3, 1),
            (4, 0),
            (4, 1),
            (5, 0),
            (5, 1), // x, y columns
            (0, 2),
            (2, 2),
            (5, 2), // u
            (1, 3),
            (3, 3),
            (5, 3), // v
            (2, 4),
            (3, 4), // λ
            (0, 5),
            (1, 5), // μ
        ];
        CscPattern::from_entries(6, 6, e).expect("static pattern is valid")
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
        let p = self.jacobian_pattern();
        let (x, yy, u, vv, lam, mu) = (y[0], y[1], y[2], y[3], y[4], y[5]);
        let mut set = |r: usize, c: usize, val: f64| v[p.find(r, c).expect("in pattern")] = val;
        set(0, 0, alpha + mu);
        set(2, 0, lam);
        set(4, 0, x);
        set(5, 0, u);
        set(1, 1, alpha + mu);
        set(3, 1, lam);
        set(4, 1, yy);
        set(5, 1, vv);
        set(0, 2, -1.0);
        set(2, 2, alpha * self.m);
        set(5, 2, x);
        set(1, 3, -1.0);
        set(3, 3, alpha * self.m);
        set(5, 3, yy);
        set(2, 4, x);
        set(3, 4, yy);
        set(0, 5, x);
        set(1, 5, yy);
        Ok(())
    }

    fn var_kinds(&self) -> Vec<VarKind> {
        use VarKind::*;
        vec![
            Differential,
            Differential,
            Differential,
            Differential,
            Algebraic,
            Algebraic,
        ]
    }

    fn component_name(&self, i: usize) -> String {
        ["x", "y", "u", "v", "lambda", "mu"][i].to_string()
    }
}

/// The same pendulum as an ODE in the angle, θ'' = −(g/L)·sin θ, for reference solutions.
#[derive(Debug, Clone, Copy)]
pub struct AnglePendulum {
    /// g/L, 1/s².
    pub g_over_l: f64,
}

impl OdeSystem for AnglePendulum {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
        dy[0] = y[1];
        dy[1] = -self.g_over_l * y[0].sin();
        Ok(())
    }
}
