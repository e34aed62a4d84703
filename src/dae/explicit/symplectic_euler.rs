//! Fixed-step semi-implicit (symplectic) Euler for second-order systems, as used by
//! game-style contact engines: v_{n+1} = v_n + h·a(t_n, q_n, v_n),
//! q_{n+1} = q_n + h·H(q_n)·v_{n+1} (H = I for q'' = a).

use super::{ExplicitError, ExplicitStats};
use crate::dae::problem::EvalError;

/// A second-order system in velocity form: q' = H(q)·v, v' = a(t, q, v, p).
///
/// The default is the plain q'' = a(t, q, q', p) (H = I, as many velocities as positions);
/// systems whose positions are not the integrals of their velocities (rigid bodies with Euler
/// parameters: q' = ½L(p)ᵀω') override [`nvel`](Self::nvel) and
/// [`position_rate`](Self::position_rate).
pub trait SecondOrderSystem {
    /// Number of positions.
    fn npos(&self) -> usize;
    /// Number of velocities (default: [`npos`](Self::npos)).
    fn nvel(&self) -> usize {
        self.npos()
    }
    /// q' at positions `q` and velocities `v` (default: q' = v).
    fn position_rate(&mut self, _t: f64, _q: &[f64], v: &[f64], qdot: &mut [f64]) {
        qdot.copy_from_slice(v);
    }
    /// Evaluates the accelerations.
    fn acceleration(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        p: &[f64],
        a: &mut [f64],
    ) -> Result<(), EvalError>;
}

/// Fixed-step symplectic Euler integrator.
#[derive(Debug)]
pub struct SymplecticEuler<S: SecondOrderSystem> {
    sys: S,
    p: Vec<f64>,
    h: f64,
    t: f64,
    /// Positions followed by velocities.
    y: Vec<f64>,
    a: Vec<f64>,
    qdot: Vec<f64>,
    stats: ExplicitStats,
}

impl<S: SecondOrderSystem> SymplecticEuler<S> {
    /// Creates the integrator with the fixed step `h` (> 0).
    pub fn new(sys: S, t0: f64, q0: &[f64], v0: &[f64], p: &[f64], h: f64) -> Result<Self, ExplicitError> {
        let (n, nv) = (sys.npos(), sys.nvel());
        if q0.len() != n || v0.len() != nv {
            return Err(ExplicitError::InvalidInput(format!(
                "q0 and v0 have lengths {} and {}, expected {n} and {nv}",
                q0.len(),
                v0.len()
            )));
        }
        if !(h > 0.0 && h.is_finite()) {
            return Err(ExplicitError::InvalidInput(format!(
                "step size must be positive, got {h}"
            )));
        }
        Ok(Self {
            sys,
            p: p.to_vec(),
            h,
            t: t0,
            y: q0.iter().chain(v0).copied().collect(),
            a: vec![0.0; nv],
            qdot: vec![0.0; n],
            stats: ExplicitStats::default(),
        })
    }
    /// Current time.
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Positions.
    pub fn q(&self) -> &[f64] {
        &self.y[..self.qdot.len()]
    }
    /// Velocities.
    pub fn v(&self) -> &[f64] {
        &self.y[self.qdot.len()..]
    }
    /// Positions followed by velocities.
    pub fn state(&self) -> &[f64] {
        &self.y
    }
    /// Work counters.
    pub fn stats(&self) -> &ExplicitStats {
        &self.stats
    }

    /// Steps to `t_end`; the last step is shortened to land on it.
    pub fn solve_to(&mut self, t_end: f64) -> Result<(), ExplicitError> {
        while self.t < t_end {
            // Round-off of the accumulated time, not a step to take.
            if t_end - self.t <= 1e-9 * self.h {
                self.t = t_end;
                break;
            }
            let h = self.h.min(t_end - self.t);
            let (q, v) = self.y.split_at_mut(self.qdot.len());
            self.sys
                .acceleration(self.t, q, v, &self.p, &mut self.a)
                .map_err(|e| match e {
                    EvalError::Recoverable(m) | EvalError::Fatal(m) => ExplicitError::Evaluation {
                        t: self.t,
                        message: m,
                    },
                })?;
            self.stats.rhs_evals += 1;
            for i in 0..v.len() {
                v[i] += h * self.a[i];
            }
            self.sys.position_rate(self.t, q, v, &mut self.qdot);
            for i in 0..q.len() {
                q[i] += h * self.qdot[i];
            }
            self.t = if t_end - self.t <= self.h {
                t_end
            } else {
                self.t + h
            };
            self.stats.steps += 1;
            if let Some(i) = self.y.iter().position(|x| !x.is_finite()) {
                return Err(ExplicitError::NonFinite { t: self.t, index: i });
            }
        }
        Ok(())
    }
}
