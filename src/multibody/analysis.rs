//! Kinematic and static analyses on the model: position assembly, velocity and acceleration
//! analysis (with the constraint forces, i.e. inverse dynamics of driven mechanisms), joint
//! reactions, and the singularity measure of the constraint Jacobian.
//!
//! These use dense linear algebra (SVD for minimum-norm corrections, which tolerates
//! redundant constraints); they run once per output point, not in the integrator's loop.

use super::body::Attach;
use super::error::ModelError;
use super::formulation::{Evaluator, Layout};
use super::model::Mechanism;
use super::rotation::l_matrix;
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;
use std::sync::Arc;

/// A consistent state of the mechanism at time t.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Snapshot {
    /// Time, s.
    pub t: f64,
    /// Positions (r, p) per body (7 each).
    pub q: Vec<f64>,
    /// Velocities (v, ω') per body (6 each).
    pub w: Vec<f64>,
    /// Accelerations (v̇, ω̇') per body (6 each).
    pub wdot: Vec<f64>,
    /// Constraint multipliers λ (joints, then drivers).
    pub lambda: Vec<f64>,
}

/// Force and torque a joint exerts on its side-j body, at the joint origin, base frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reaction {
    /// Force, N.
    pub force: [f64; 3],
    /// Torque about the joint origin, N·m.
    pub torque: [f64; 3],
}

/// Analyses on a mechanism.
#[derive(Debug)]
pub struct Analysis {
    pub(crate) ev: Evaluator,
    /// Largest number of Newton iterations in position assembly.
    pub max_iterations: usize,
    /// Constraint residual accepted by assembly (m, or dimensionless for orientations).
    pub tolerance: f64,
    /// Length scale of the model (mean distance of joint origins from body centres of mass),
    /// m: converts angular to linear velocities in the singularity measure.
    pub length_scale: f64,
}

impl Analysis {
    /// Checks the model and prepares the analyses.
    pub fn new(model: Arc<Mechanism>) -> Result<Self, ModelError> {
        model.validate()?;
        let mut sum = 0.0;
        let mut n = 0usize;
        for j in &model.joints {
            for (side, f) in [(j.body_i, &j.frame_i), (j.body_j, &j.frame_j)] {
                if let Attach::Body(_) = side {
                    sum += f.origin.norm();
                    n += 1;
                }
            }
        }
        let length_scale = if n > 0 && sum > 0.0 { sum / n as f64 } else { 1.0 };
        Ok(Self {
            ev: Evaluator::new(model),
            max_iterations: 50,
            tolerance: 1e-12,
            length_scale,
        })
    }

    /// Index layout.
    pub fn layout(&self) -> Layout {
        self.ev.layout
    }

    /// The model.
    pub fn model(&self) -> &Mechanism {
        &self.ev.model
    }

    /// The bodies' initial positions (r, p) as given in the model (not yet assembled).
    pub fn initial_guess(&self) -> (Vec<f64>, Vec<f64>) {
        let mut q = Vec::with_capacity(7 * self.ev.layout.nb);
        let mut w = Vec::with_capacity(6 * self.ev.layout.nb);
        for b in &self.ev.model.bodies.bodies {
            q.extend(b.position.iter());
            q.extend(b.orientation.normalize().iter());
            w.extend(b.velocity.iter());
            w.extend(b.angular_velocity.iter());
        }
        (q, w)
    }

    /// Φ and [Φ; normalisation] Jacobian (dense) at (q, t).
    fn position_system(&mut self, t: f64, q: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let lay = self.ev.layout;
        let zeros = vec![0.0; 6 * lay.nb];
        self.ev.set_state(q, &zeros);
        self.ev.eval_constraints(t);
        let sides = self.ev.row_sides();
        let n_eq = lay.m + lay.nb;
        let mut f = DVector::zeros(n_eq);
        let mut j = DMatrix::zeros(n_eq, 7 * lay.nb);
        for (k, &(si, sj)) in sides.iter().enumerate() {
            let row = &self.ev.rows[k];
            f[k] = row.phi;
            if let Some(b) = si {
                for c in 0..3 {
                    j[(k, 7 * b + c)] += row.d_ri[c];
                }
                for c in 0..4 {
                    j[(k, 7 * b + 3 + c)] += row.d_pi[c];
                }
            }
            if let Some(b) = sj {
                for c in 0..3 {
                    j[(k, 7 * b + c)] += row.d_rj[c];
                }
                for c in 0..4 {
                    j[(k, 7 * b + 3 + c)] += row.d_pj[c];
                }
            }
        }
        for b in 0..lay.nb {
            let p = &q[7 * b + 3..7 * b + 7];
            f[lay.m + b] = 0.5 * (p.iter().map(|v| v * v).sum::<f64>() - 1.0);
            for c in 0..4 {
                j[(lay.m + b, 7 * b + 3 + c)] = p[c];
            }
        }
        (f, j)
    }

    /// Velocity Jacobian B (m × 6nb) and Φ_t at the state last set.
    fn velocity_system(&self) -> (DMatrix<f64>, DVector<f64>) {
        let lay = self.ev.layout;
        let sides = self.ev.row_sides();
        let mut bm = DMatrix::zeros(lay.m, 6 * lay.nb);
        let mut phit = DVector::zeros(lay.m);
        for (k, &(si, sj)) in sides.iter().enumerate() {
            phit[k] = self.ev.rows[k].phi_t;
            for (side_i, b) in [(true, si), (false, sj)] {
                let Some(b) = b else { continue };
                let (bt, br) = self.ev.b_row(k, side_i, b);
                for c in 0..3 {
                    bm[(k, 6 * b + c)] += bt[c];
                    bm[(k, 6 * b + 3 + c)] += br[c];
                }
            }
        }
        (bm, phit)
    }

    fn constraint_name(&self, k: usize) -> String {
        let lay = self.ev.layout;
        if k < lay.m {
            let mut i = 0;
            for blk in &self.ev.blocks {
                if k < i + blk.prim.len() {
                    return blk.names[k - i].clone();
                }
                i += blk.prim.len();
            }
        }
        format!(
            "normalisation of body '{}'",
            self.ev.model.bodies.bodies[k - lay.m].name
        )
    }

    /// Largest |Φ_k(q, t)| over the constraints and Euler-parameter normalisations (drift).
    pub fn constraint_residual(&mut self, t: f64, q: &[f64]) -> f64 {
        self.position_system(t, q).0.amax()
    }

    /// Position assembly: Gauss–Newton with minimum-norm steps on Φ(q, t) = 0 and the
    /// normalisations, from `guess`. On failure the error names the unsatisfied constraints.
    pub fn assemble(&mut self, t: f64, guess: &[f64]) -> Result<Vec<f64>, ModelError> {
        let lay = self.ev.layout;
        if guess.len() != 7 * lay.nb || guess.iter().any(|v| !v.is_finite()) {
            return Err(ModelError::Output(format!(
                "assembly guess must have {} finite values",
                7 * lay.nb
            )));
        }
        let mut q = guess.to_vec();
        if lay.m == 0 {
            // No constraints: only the Euler parameters need normalising.
            for b in 0..lay.nb {
                let p = &mut q[7 * b + 3..7 * b + 7];
                let n = p.iter().map(|v| v * v).sum::<f64>().sqrt();
                if n == 0.0 {
                    return Err(ModelError::Output(format!("body {b} has zero Euler parameters")));
                }
                p.iter_mut().for_each(|v| *v /= n);
            }
            return Ok(q);
        }
        let mut last = f64::INFINITY;
        for _ in 0..self.max_iterations {
            let (f, j) = self.position_system(t, &q);
            let norm = f.amax();
            if norm <= self.tolerance {
                return Ok(q);
            }
            let step = j
                .svd(true, true)
                .solve(&f, 1e-12)
                .map_err(|e| ModelError::Output(e.to_string()))?;
            let mut alpha = 1.0;
            // Damped step: halve while the residual grows a lot (far from the solution).
            for _ in 0..10 {
                let trial: Vec<f64> = q.iter().zip(step.iter()).map(|(a, b)| a - alpha * b).collect();
                let (ft, _) = self.position_system(t, &trial);
                if ft.amax() < norm.max(1e-300) * 1.5 || alpha < 1e-3 {
                    q = trial;
                    break;
                }
                alpha *= 0.5;
            }
            if (last - norm).abs() < 1e-16 && norm > self.tolerance * 1e3 {
                break;
            }
            last = norm;
        }
        let (f, _) = self.position_system(t, &q);
        if f.amax() <= self.tolerance * 10.0 {
            return Ok(q);
        }
        let mut res: Vec<(String, f64)> = (0..f.len())
            .filter(|&k| f[k].abs() > self.tolerance * 10.0)
            .map(|k| (self.constraint_name(k), f[k]))
            .collect();
        res.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        Err(ModelError::AssemblyFailed { residuals: res })
    }

    /// Velocity analysis: the velocities closest to `guess` (minimum change) that satisfy
    /// B·w + Φ_t = 0 at (q, t).
    pub fn velocities(&mut self, t: f64, q: &[f64], guess: &[f64]) -> Result<Vec<f64>, ModelError> {
        if self.ev.layout.m == 0 {
            return Ok(guess.to_vec());
        }
        self.ev.set_state(q, guess);
        self.ev.eval_constraints(t);
        let (bm, phit) = self.velocity_system();
        let w0 = DVector::from_column_slice(guess);
        let r = &bm * &w0 + phit;
        let dw = bm
            .svd(true, true)
            .solve(&r, 1e-12)
            .map_err(|e| ModelError::Output(e.to_string()))?;
        Ok((w0 - dw).iter().copied().collect())
    }

    /// c(q, t) = B(q, t)·w + Φ_t(q, t) for fixed w.
    fn vel_residual(&mut self, t: f64, q: &[f64], w: &[f64]) -> DVector<f64> {
        self.ev.set_state(q, w);
        self.ev.eval_constraints(t);
        let (bm, phit) = self.velocity_system();
        bm * DVector::from_column_slice(w) + phit
    }

    /// q̇ = H(q)·w.
    fn qdot(&self, q: &[f64], w: &[f64]) -> Vec<f64> {
        let nb = self.ev.layout.nb;
        let mut qd = vec![0.0; 7 * nb];
        for b in 0..nb {
            let p = nalgebra::Vector4::new(q[7 * b + 3], q[7 * b + 4], q[7 * b + 5], q[7 * b + 6]);
            let om = Vector3::new(w[6 * b + 3], w[6 * b + 4], w[6 * b + 5]);
            let pd = 0.5 * l_matrix(&p).transpose() * om;
            qd[7 * b..7 * b + 3].copy_from_slice(&w[6 * b..6 * b + 3]);
            qd[7 * b + 3..7 * b + 7].copy_from_slice(pd.as_slice());
        }
        qd
    }

    /// γ = −d/dt(B·w + Φ_t) at ẇ = 0: central differences along (q̇, 1) with Richardson
    /// extrapolation (error O(ε⁴)).
    fn gamma(&mut self, t: f64, q: &[f64], w: &[f64]) -> DVector<f64> {
        let qd = self.qdot(q, w);
        let scale = 1.0 + qd.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let mut central = |eps: f64| {
            let qp: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + eps * b).collect();
            let qm: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a - eps * b).collect();
            (self.vel_residual(t + eps, &qp, w) - self.vel_residual(t - eps, &qm, w)) / (2.0 * eps)
        };
        let h = 1e-3 / scale;
        let d1 = central(h);
        let d2 = central(0.5 * h);
        -(4.0 * d2 - d1) / 3.0
    }

    /// Acceleration analysis: solves [M Bᵀ; B 0]·[ẇ; λ] = [Q; γ] at (q, w, t). Returns
    /// (ẇ, λ). With a driven mechanism (no free degrees of freedom) λ of the drivers are the
    /// actuator loads: inverse dynamics.
    pub fn accelerations(
        &mut self,
        t: f64,
        q: &[f64],
        w: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), ModelError> {
        let lay = self.ev.layout;
        if lay.m == 0 {
            // Free bodies: Newton–Euler per body, no global system.
            self.ev.set_state(q, w);
            self.ev.eval_loads(t);
            let mut wdot = vec![0.0; 6 * lay.nb];
            for (b, body) in self.ev.model.bodies.bodies.iter().enumerate() {
                let st = &self.ev.states[b];
                let ld = &self.ev.loads[b];
                let a = ld.force / body.mass;
                let rhs = ld.torque - st.omega.cross(&(body.inertia * st.omega));
                let al = body.inertia.lu().solve(&rhs).ok_or_else(|| {
                    ModelError::Output(format!("body '{}' has a singular inertia", body.name))
                })?;
                wdot[6 * b..6 * b + 3].copy_from_slice(a.as_slice());
                wdot[6 * b + 3..6 * b + 6].copy_from_slice(al.as_slice());
            }
            return Ok((wdot, vec![]));
        }
        let gamma = self.gamma(t, q, w);
        self.ev.set_state(q, w);
        self.ev.eval_constraints(t);
        self.ev.eval_loads(t);
        let (bm, _) = self.velocity_system();
        let n = 6 * lay.nb;
        let mut k = DMatrix::zeros(n + lay.m, n + lay.m);
        let mut rhs = DVector::zeros(n + lay.m);
        for (b, body) in self.ev.model.bodies.bodies.iter().enumerate() {
            let st = &self.ev.states[b];
            for c in 0..3 {
                k[(6 * b + c, 6 * b + c)] = body.mass;
            }
            k.view_mut((6 * b + 3, 6 * b + 3), (3, 3))
                .copy_from(&body.inertia);
            let gyro = st.omega.cross(&(body.inertia * st.omega));
            let ld = &self.ev.loads[b];
            for c in 0..3 {
                rhs[6 * b + c] = ld.force[c];
                rhs[6 * b + 3 + c] = ld.torque[c] - gyro[c];
            }
        }
        k.view_mut((0, n), (n, lay.m)).copy_from(&bm.transpose());
        k.view_mut((n, 0), (lay.m, n)).copy_from(&bm);
        rhs.rows_mut(n, lay.m).copy_from(&gamma);
        let sol = match k.clone().lu().solve(&rhs) {
            Some(s) if s.iter().all(|v| v.is_finite()) => s,
            _ => k
                .svd(true, true)
                .solve(&rhs, 1e-12)
                .map_err(|e| ModelError::Output(e.to_string()))?,
        };
        Ok((
            sol.rows(0, n).iter().copied().collect(),
            sol.rows(n, lay.m).iter().copied().collect(),
        ))
    }

    /// The consistent initial state at `t0` from the model's initial poses and velocities.
    pub fn initial_state(&mut self, t0: f64) -> Result<Snapshot, ModelError> {
        let (q0, w0) = self.initial_guess();
        self.state_at(t0, &q0, &w0)
    }

    /// A consistent snapshot at `t` from approximate positions and velocities.
    pub fn state_at(&mut self, t: f64, q_guess: &[f64], w_guess: &[f64]) -> Result<Snapshot, ModelError> {
        let q = self.assemble(t, q_guess)?;
        let w = self.velocities(t, &q, w_guess)?;
        let (wdot, lambda) = self.accelerations(t, &q, &w)?;
        Ok(Snapshot {
            t,
            q,
            w,
            wdot,
            lambda,
        })
    }

    /// Kinematic analysis of a driven mechanism over `times`: positions by assembly
    /// (continuing from the previous point), velocities, accelerations and constraint forces.
    pub fn kinematics(&mut self, times: &[f64]) -> Result<Vec<Snapshot>, ModelError> {
        let (mut q, w0) = self.initial_guess();
        let mut w = w0;
        let mut out = Vec::with_capacity(times.len());
        for &t in times {
            let s = self.state_at(t, &q, &w)?;
            q.clone_from(&s.q);
            w.clone_from(&s.w);
            out.push(s);
        }
        Ok(out)
    }

    /// Smallest singular value of the row-normalised velocity Jacobian B at (q, t), divided by
    /// the largest: 1 for a well-conditioned constraint set, 0 at a singular configuration.
    pub fn singularity_measure(&mut self, t: f64, q: &[f64]) -> f64 {
        if self.ev.layout.m == 0 {
            return 1.0;
        }
        let zeros = vec![0.0; 6 * self.ev.layout.nb];
        self.ev.set_state(q, &zeros);
        self.ev.eval_constraints(t);
        let (mut bm, _) = self.velocity_system();
        // Angular-velocity columns in units of a velocity at the model's length scale.
        for b in 0..self.ev.layout.nb {
            for c in 3..6 {
                let mut col = bm.column_mut(6 * b + c);
                col /= self.length_scale;
            }
        }
        for mut r in bm.row_iter_mut() {
            let n = r.norm();
            if n > 0.0 {
                r /= n;
            }
        }
        let sv = bm.singular_values();
        let max = sv.iter().copied().fold(0.0, f64::max);
        let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
        if max > 0.0 {
            min / max
        } else {
            0.0
        }
    }

    /// Position (m), axes (columns, base frame) and velocity (m/s) of a marker for the state
    /// (q, w).
    pub fn marker_state(
        &self,
        m: super::model::MarkerHandle,
        q: &[f64],
        w: &[f64],
    ) -> (Vector3<f64>, nalgebra::Matrix3<f64>, Vector3<f64>) {
        let mk = &self.ev.model.markers[m.0];
        match mk.attach {
            Attach::Ground => (mk.frame.origin, mk.frame.axes, Vector3::zeros()),
            Attach::Body(h) => {
                let b = h.index();
                let r = Vector3::new(q[7 * b], q[7 * b + 1], q[7 * b + 2]);
                let p = nalgebra::Vector4::new(q[7 * b + 3], q[7 * b + 4], q[7 * b + 5], q[7 * b + 6]);
                let a = super::rotation::rotation(&p);
                let v = Vector3::new(w[6 * b], w[6 * b + 1], w[6 * b + 2]);
                let om = Vector3::new(w[6 * b + 3], w[6 * b + 4], w[6 * b + 5]);
                (
                    r + a * mk.frame.origin,
                    a * mk.frame.axes,
                    v + a * om.cross(&mk.frame.origin),
                )
            }
        }
    }

    /// Reaction of every joint on its side-j body (at the joint origin, base frame), from the
    /// multipliers `lambda` at (q, t).
    pub fn reactions(&mut self, t: f64, q: &[f64], lambda: &[f64]) -> Vec<Reaction> {
        let zeros = vec![0.0; 6 * self.ev.layout.nb];
        self.ev.set_state(q, &zeros);
        self.ev.eval_constraints(t);
        let model = self.ev.model.clone();
        let mut out = Vec::with_capacity(model.joints.len());
        let mut k = 0;
        for j in &model.joints {
            let n: usize = j.primitives().iter().map(|p| p.len()).sum();
            let (mut f, mut tq) = (Vector3::zeros(), Vector3::zeros());
            if let Attach::Body(h) = j.body_j {
                let a = self.ev.poses[h.0].a;
                for kk in k..k + n {
                    let (bt, br) = self.ev.b_row(kk, false, h.0);
                    f -= bt * lambda[kk];
                    tq -= a * (br * lambda[kk]);
                }
                // Move the torque from the centre of mass to the joint origin.
                let arm = a * j.frame_j.origin;
                tq -= arm.cross(&f);
            }
            out.push(Reaction {
                force: [f.x, f.y, f.z],
                torque: [tq.x, tq.y, tq.z],
            });
            k += n;
        }
        out
    }
}
