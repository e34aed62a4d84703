//! The equations of motion as an ODE for explicit integrators: index-1 accelerations from the
//! constraint equations at acceleration level, with Baumgarte stabilisation.
//!
//! State y = (q, w): per body q = (r, p) (7) and w = (v, ω') (6), the same layout as the first
//! 13·n_b unknowns of [`MultibodyDae`](super::MultibodyDae). At each right-hand side
//!
//! ```text
//! q̇ = H(q)·w          (ṙ = v, ṗ = ½L(p)ᵀω' − κ(pᵀp − 1)p)
//! M·ẇ + Bᵀλ = Q(t, q, w)
//! B·ẇ       = γ − 2ξω_b·(B·w + Φ_t) − ω_b²·Φ
//! ```
//! solved through the Schur complement S = B·M⁻¹·Bᵀ (M is block-diagonal per body, so M⁻¹ is
//! exact and cheap; S is dense m × m, fine for the tens of constraint equations of a
//! mechanism whose joints are mostly contacts). γ = −d/dt(B·w + Φ_t) at ẇ = 0 comes from central
//! differences of the velocity constraints along (q̇, 1) with Richardson extrapolation.
//!
//! This is the formulation explicit multibody codes step; the benchmarks use it to compare
//! Dormand–Prince with the implicit GGL/BDF pipeline on the same model.

use super::error::ModelError;
use super::evaluator::Evaluator;
use super::layout::Layout;
use super::model::Mechanism;
use super::rotation::position_rates;
use crate::dae::explicit::{OdeSystem, SecondOrderSystem};
use crate::dae::EvalError;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use std::sync::Arc;

/// Baumgarte stabilisation and normalisation gains of [`MultibodyOde`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaumgarteGains {
    /// Natural frequency ω_b of the constraint-error dynamics, rad/s.
    pub omega: f64,
    /// Damping ratio ξ of the constraint-error dynamics (1 = critical).
    pub zeta: f64,
    /// Euler-parameter normalisation rate κ, 1/s.
    pub kappa: f64,
}

impl Default for BaumgarteGains {
    /// ω_b = 50 rad/s, ξ = 1, κ = 50 1/s: drift decays within ~0.1 s, far slower than the
    /// contact dynamics, so the stabilisation does not set the explicit step.
    fn default() -> Self {
        Self {
            omega: 50.0,
            zeta: 1.0,
            kappa: 50.0,
        }
    }
}

/// A mechanism's equations of motion as an [`OdeSystem`] (see the module docs).
#[derive(Debug)]
pub struct MultibodyOde {
    model: Arc<Mechanism>,
    ev: Evaluator,
    inv_inertia: Vec<Matrix3<f64>>,
    /// Scratch state and derivative for the second-order interface.
    y_work: Vec<f64>,
    dy_work: Vec<f64>,
    /// Stabilisation gains.
    pub gains: BaumgarteGains,
}

impl MultibodyOde {
    /// Builds the ODE of a model; fails with the model's validation error.
    pub fn new(model: Arc<Mechanism>) -> Result<Self, ModelError> {
        model.validate()?;
        let ev = Evaluator::new(&model);
        let inv_inertia = model
            .bodies()
            .bodies
            .iter()
            .map(|b| b.inertia.try_inverse().unwrap_or_else(Matrix3::zeros))
            .collect();
        let n = 13 * ev.layout.bodies();
        Ok(Self {
            model,
            ev,
            inv_inertia,
            y_work: vec![0.0; n],
            dy_work: vec![0.0; n],
            gains: BaumgarteGains::default(),
        })
    }

    /// Index layout (only the q and w blocks are part of the ODE state).
    pub fn layout(&self) -> Layout {
        self.ev.layout.clone()
    }

    fn qdot(&self, q: &[f64], w: &[f64], out: &mut [f64]) {
        position_rates(q, w, self.gains.kappa, out);
    }

    /// γ along the stabilised q̇ ([`Evaluator::gamma`]).
    fn gamma(&mut self, t: f64, q: &[f64], w: &[f64]) -> Vec<f64> {
        let mut qd = vec![0.0; q.len()];
        self.qdot(q, w, &mut qd);
        let mut g = vec![0.0; self.ev.layout.constraints()];
        self.ev.gamma(t, q, &qd, w, &mut g);
        g
    }
}

impl OdeSystem for MultibodyOde {
    fn dim(&self) -> usize {
        13 * self.ev.layout.bodies()
    }

    fn rhs(&mut self, t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
        let lay = self.ev.layout.clone();
        let nb = lay.bodies();
        let (q, w) = (&y[..7 * nb], &y[7 * nb..13 * nb]);
        let gamma = if lay.constraints() > 0 {
            self.gamma(t, q, w)
        } else {
            vec![]
        };
        self.ev.set_state(q, w);
        self.ev.eval_constraints(t);
        self.ev.eval_loads(&self.model, t);
        let (qdot, wdot) = dy.split_at_mut(7 * nb);
        self.qdot(q, w, qdot);
        // Unconstrained accelerations ẇ₀ = M⁻¹Q.
        for (b, body) in self.model.bodies().bodies.iter().enumerate() {
            let st = &self.ev.states[b];
            let ld = &self.ev.loads[b];
            let a = ld.force / body.mass;
            let al = self.inv_inertia[b] * (ld.torque - st.omega.cross(&(body.inertia * st.omega)));
            wdot[6 * b..6 * b + 3].copy_from_slice(a.as_slice());
            wdot[6 * b + 3..6 * b + 6].copy_from_slice(al.as_slice());
        }
        if lay.constraints() == 0 {
            return check_finite(t, dy);
        }
        // Constraint rows restricted to their bodies: (body, translational, rotational).
        let m = lay.constraints();
        let mut brows: Vec<[Option<BodyRow>; 2]> = Vec::with_capacity(m);
        for (k, &(si, sj)) in self.ev.row_sides().iter().enumerate() {
            let mut r = [None, None];
            for (slot, (side_i, b)) in [(true, si), (false, sj)].into_iter().enumerate() {
                if let Some(b) = b {
                    let (bt, br) = self.ev.b_row(k, side_i, b);
                    r[slot] = Some((b, bt, br));
                }
            }
            brows.push(r);
        }
        let mut vel = vec![0.0; m];
        self.ev.velocity_constraints(&mut vel);
        let (wz, om, g) = (self.gains.zeta, self.gains.omega, &gamma);
        let mut rhs = DVector::zeros(m);
        let mut s = DMatrix::zeros(m, m);
        let mass: Vec<f64> = self.model.bodies().bodies.iter().map(|b| b.mass).collect();
        // M⁻¹Bᵀ column k, per body touched.
        let minv_bt =
            |b: usize, bt: &Vector3<f64>, br: &Vector3<f64>| (bt / mass[b], self.inv_inertia[b] * br);
        for k in 0..m {
            let mut bw0 = 0.0;
            for (b, bt, br) in brows[k].iter().flatten() {
                let a = Vector3::new(wdot[6 * b], wdot[6 * b + 1], wdot[6 * b + 2]);
                let al = Vector3::new(wdot[6 * b + 3], wdot[6 * b + 4], wdot[6 * b + 5]);
                bw0 += bt.dot(&a) + br.dot(&al);
            }
            rhs[k] = bw0 - (g[k] - 2.0 * wz * om * vel[k] - om * om * self.ev.rows[k].phi);
            for l in 0..=k {
                let mut v = 0.0;
                for (b, bt, br) in brows[k].iter().flatten() {
                    for (c, ct, cr) in brows[l].iter().flatten() {
                        if b == c {
                            let (mt, mr) = minv_bt(*c, ct, cr);
                            v += bt.dot(&mt) + br.dot(&mr);
                        }
                    }
                }
                s[(k, l)] = v;
                s[(l, k)] = v;
            }
        }
        let lam = match s.clone().cholesky() {
            Some(ch) => ch.solve(&rhs),
            None => s.lu().solve(&rhs).ok_or_else(|| {
                EvalError::Recoverable(format!(
                    "constraint Jacobian is rank deficient at t = {t:e} (singular configuration)"
                ))
            })?,
        };
        for k in 0..m {
            for (b, bt, br) in brows[k].iter().flatten() {
                let (mt, mr) = minv_bt(*b, bt, br);
                for c in 0..3 {
                    wdot[6 * b + c] -= mt[c] * lam[k];
                    wdot[6 * b + 3 + c] -= mr[c] * lam[k];
                }
            }
        }
        check_finite(t, dy)
    }
}

/// The same equations in velocity form for fixed-step symplectic Euler: positions q (7 per
/// body), velocities w (6 per body), q' = H(q)·w.
impl SecondOrderSystem for MultibodyOde {
    fn npos(&self) -> usize {
        7 * self.ev.layout.bodies()
    }
    fn nvel(&self) -> usize {
        6 * self.ev.layout.bodies()
    }
    fn position_rate(&mut self, _t: f64, q: &[f64], v: &[f64], qdot: &mut [f64]) {
        self.qdot(q, v, qdot);
    }
    fn acceleration(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        p: &[f64],
        a: &mut [f64],
    ) -> Result<(), EvalError> {
        let nq = q.len();
        let mut y = std::mem::take(&mut self.y_work);
        let mut dy = std::mem::take(&mut self.dy_work);
        y[..nq].copy_from_slice(q);
        y[nq..].copy_from_slice(v);
        let r = self.rhs(t, &y, p, &mut dy);
        a.copy_from_slice(&dy[nq..]);
        self.y_work = y;
        self.dy_work = dy;
        r
    }
}

/// A constraint row restricted to one body: (body, translational part, rotational part).
type BodyRow = (usize, Vector3<f64>, Vector3<f64>);

fn check_finite(t: f64, dy: &[f64]) -> Result<(), EvalError> {
    match dy.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(EvalError::Recoverable(format!(
            "non-finite derivative of state component {i} at t = {t:e}"
        ))),
    }
}
