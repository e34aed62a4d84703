//! The turning stiff spring: a point mass on a very stiff spring to the origin, swinging as a
//! pendulum, so the stiff direction (along the spring) turns with the motion. A stale
//! Jacobian is wrong exactly in the stiff direction here, which is what makes this problem
//! hard for BDF codes that keep their Jacobian too long.
//!
//! m = 1 kg, rest length L = 1 m, k = 1e9 N/m, Kelvin–Voigt damping c = 2·√(k·m) along the
//! spring (or 0), gravity 9.81 m/s² along −y. Released at rest 45° from the downward vertical,
//! stretched statically by g·cos45°·m/k. Unknowns (x, y, ẋ, ẏ) in m and m/s.

use super::reference::G;
use crate::dae::explicit::{OdeSystem, SecondOrderSystem};
use crate::dae::{DaeSystem, EvalError, JacobianSource};
use crate::sparse::CscPattern;

/// Parameters of the turning stiff spring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffSpring {
    /// Mass, kg.
    pub m: f64,
    /// Spring rest length, m.
    pub l: f64,
    /// Spring stiffness, N/m.
    pub k: f64,
    /// Damping along the spring, N·s/m.
    pub c: f64,
    /// Gravity, m/s² (acting along −y).
    pub g: f64,
}

impl StiffSpring {
    /// The validation case: k = 1e9 N/m, critically damped (c = 2√(km)) when `damped`.
    pub fn validation(damped: bool) -> Self {
        let (m, k) = (1.0, 1e9);
        Self {
            m,
            l: 1.0,
            k,
            c: if damped { 2.0 * (k * m).sqrt() } else { 0.0 },
            g: G,
        }
    }

    /// Initial state (x, y, ẋ, ẏ) and its derivative.
    pub fn initial_values(&self) -> (Vec<f64>, Vec<f64>) {
        let a = std::f64::consts::FRAC_PI_4;
        let r = self.l + self.g * a.cos() * self.m / self.k;
        let y = vec![r * a.sin(), -r * a.cos(), 0.0, 0.0];
        let mut acc = [0.0; 2];
        self.accel(&y[0..2], &y[2..4], &mut acc);
        (y, vec![0.0, 0.0, acc[0], acc[1]])
    }

    /// Pendulum angle from the downward vertical, rad.
    pub fn angle(y: &[f64]) -> f64 {
        y[0].atan2(-y[1])
    }

    /// Spring force plus gravity divided by mass.
    fn accel(&self, q: &[f64], v: &[f64], a: &mut [f64]) {
        let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
        let (nx, ny) = (q[0] / r, q[1] / r);
        let s = r - self.l;
        let sd = nx * v[0] + ny * v[1];
        let f = self.k * s + self.c * sd;
        a[0] = -f * nx / self.m;
        a[1] = -f * ny / self.m - self.g;
    }
}

impl DaeSystem for StiffSpring {
    fn dim(&self) -> usize {
        4
    }

    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        let mut a = [0.0; 2];
        self.accel(&y[0..2], &y[2..4], &mut a);
        r[0] = yp[0] - y[2];
        r[1] = yp[1] - y[3];
        r[2] = self.m * (yp[2] - a[0]);
        r[3] = self.m * (yp[3] - a[1]);
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(4, 4)
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
        // Spring force F = −f·n, f = k·s + c·ṡ, s = r − L, ṡ = n·v.
        let r = (y[0] * y[0] + y[1] * y[1]).sqrt();
        let n = [y[0] / r, y[1] / r];
        let vel = [y[2], y[3]];
        let s = r - self.l;
        let sd = n[0] * vel[0] + n[1] * vel[1];
        let f = self.k * s + self.c * sd;
        // P = I − n nᵀ; ∂n/∂x = P/r; ∂ṡ/∂x = P·v/r.
        let p = [
            [1.0 - n[0] * n[0], -n[0] * n[1]],
            [-n[1] * n[0], 1.0 - n[1] * n[1]],
        ];
        let pv = [
            p[0][0] * vel[0] + p[0][1] * vel[1],
            p[1][0] * vel[0] + p[1][1] * vel[1],
        ];
        let mut dfdx = [[0.0; 2]; 2]; // ∂F_i/∂x_j
        let mut dfdv = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                dfdx[i][j] = -(n[i] * (self.k * n[j] + self.c * pv[j] / r) + f * p[i][j] / r);
                dfdv[i][j] = -self.c * n[i] * n[j];
            }
        }
        // Dense column-major 4×4: dF/dy + α dF/dy'.
        let mut jm = [[0.0; 4]; 4];
        jm[0][0] = alpha;
        jm[1][1] = alpha;
        jm[0][2] = -1.0;
        jm[1][3] = -1.0;
        for i in 0..2 {
            for j in 0..2 {
                jm[2 + i][j] = -dfdx[i][j];
                jm[2 + i][2 + j] = -dfdv[i][j] + if i == j { alpha * self.m } else { 0.0 };
            }
        }
        for c in 0..4 {
            for rr in 0..4 {
                v[c * 4 + rr] = jm[rr][c];
            }
        }
        Ok(())
    }

    fn component_name(&self, i: usize) -> String {
        ["x", "y", "vx", "vy"][i].to_string()
    }
}

impl OdeSystem for StiffSpring {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&mut self, _t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
        dy[0] = y[2];
        dy[1] = y[3];
        let mut a = [0.0; 2];
        self.accel(&y[0..2], &y[2..4], &mut a);
        dy[2] = a[0];
        dy[3] = a[1];
        Ok(())
    }
}

impl SecondOrderSystem for StiffSpring {
    fn npos(&self) -> usize {
        2
    }
    fn acceleration(
        &mut self,
        _t: f64,
        q: &[f64],
        v: &[f64],
        _p: &[f64],
        a: &mut [f64],
    ) -> Result<(), EvalError> {
        self.accel(q, v, a);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analytic_jacobian_matches_finite_differences() {
        let mut s = StiffSpring::validation(true);
        let y = [0.6, -0.8000001, 0.3, 0.2];
        let yp = [0.3, 0.2, 1.0, -2.0];
        let alpha = 7.0;
        let mut jv = vec![0.0; 16];
        s.jacobian(0.0, &y, &yp, &[], alpha, &mut jv).unwrap();
        let mut r0 = [0.0; 4];
        s.residual(0.0, &y, &yp, &[], &mut r0).unwrap();
        for c in 0..4 {
            let h = 1e-7 * (1.0 + y[c].abs());
            let mut y2 = y;
            let mut yp2 = yp;
            y2[c] += h;
            yp2[c] += alpha * h;
            let mut r1 = [0.0; 4];
            s.residual(0.0, &y2, &yp2, &[], &mut r1).unwrap();
            for r in 0..4 {
                let fd = (r1[r] - r0[r]) / h;
                let an = jv[c * 4 + r];
                assert!(
                    (fd - an).abs() <= 1e-5 * (1.0 + an.abs()),
                    "({r},{c}): fd {fd} analytic {an}"
                );
            }
        }
    }
}
