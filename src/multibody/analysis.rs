//! Kinematic and static analyses on the model: position assembly, velocity and acceleration
//! analysis (with the constraint forces, i.e. inverse dynamics of driven mechanisms), joint
//! reactions, and the singularity measure of the constraint Jacobian.
//!
//! Every analysis borrows the model (`&Mechanism`) and works in a [`MechanismData`] (state
//! and scratch); [`Analysis`] holds settings only.
//!
//! These use dense linear algebra (LU for square, regular systems; SVD for minimum-norm
//! corrections, which tolerates redundant constraints and singular configurations); they
//! run once per output point, not in the integrator's loop.

use super::body::Attach;
use super::body::BodyHandle;
use super::constraints::{Pose, Row};
use super::data::{MechanismData, VelocityLu};
use super::error::ModelError;
use super::evaluator::Evaluator;
use super::joints::Joint;
#[cfg(doc)]
use super::layout::Layout;
use super::model::Mechanism;
use super::rotation::{d_rot, l_matrix, position_rates};
use crate::sparse::DenseLu;
use nalgebra::{DMatrix, DVector, Vector3};
use serde::Serialize;

/// Largest relative backward error (residual over ‖A‖·‖x‖ + ‖b‖, ∞-norms) at which a
/// square system's LU solution is accepted; above it (a singular or nearly singular
/// configuration) the analyses take the minimum-norm SVD solution. Partial-pivoting LU
/// reaches about n·1e-16 on a regular system.
pub const LU_BACKWARD_ERROR: f64 = 1e-10;

/// A chord step (with an earlier iterate's factorised Jacobian) in position assembly is
/// accepted when it shrinks the constraint residual at least by this factor; otherwise the
/// Jacobian is factorised afresh.
pub const CHORD_CONTRACTION: f64 = 0.25;

/// The contraction a chord step on the previous assembly's factorisation must reach
/// ([`Analysis::assemble`] starts with them): else the Jacobian is factorised afresh.
pub const INHERITED_CHORD_CONTRACTION: f64 = 0.01;

/// A consistent state of the mechanism at time t. Typed access by handle:
/// [`body_position`](Self::body_position), [`body_velocity`](Self::body_velocity),
/// [`reaction`](Self::reaction), [`driver_effort`](Self::driver_effort), …
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Snapshot {
    /// Time, s.
    pub t: f64,
    /// Positions (r, p) per body (see [`Layout::body_q`]).
    pub q: Vec<f64>,
    /// Velocities (v, ω') per body (see [`Layout::body_w`]).
    pub w: Vec<f64>,
    /// Accelerations (v̇, ω̇') per body (see [`Layout::body_w`]).
    pub wdot: Vec<f64>,
    /// Constraint multipliers λ (joints, then drivers; see [`Layout::joint_lambda`]).
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

/// Tunables of position assembly; part of [`SimulationOptions`](super::SimulationOptions),
/// whose module documents every default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssemblyOptions {
    /// Largest number of Gauss–Newton iterations in position assembly (default 50).
    pub max_iterations: usize,
    /// Constraint residual accepted by assembly (m, or dimensionless for orientations;
    /// default 1e-12).
    pub tolerance: f64,
}

impl Default for AssemblyOptions {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            tolerance: 1e-12,
        }
    }
}

/// Analyses on a mechanism: settings only. Every analysis borrows the model
/// (`&Mechanism`, constant) and works in a [`MechanismData`] (state and scratch), so one model
/// can serve several data sets at once.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// Assembly settings.
    pub options: AssemblyOptions,
    /// Length scale of the model (mean distance of joint origins from body centres of mass),
    /// m: converts angular to linear velocities in the singularity measure.
    pub length_scale: f64,
}

impl Analysis {
    /// Checks the model and prepares the analyses with the default [`AssemblyOptions`].
    pub fn new(model: &Mechanism) -> Result<Self, ModelError> {
        Self::with_options(model, AssemblyOptions::default())
    }

    /// Checks the model and prepares the analyses.
    pub fn with_options(model: &Mechanism, options: AssemblyOptions) -> Result<Self, ModelError> {
        model.validate()?;
        let mut sum = 0.0;
        let mut n = 0usize;
        for (_, j) in model.joints() {
            for (side, f) in [(j.body_i, &j.frame_i), (j.body_j, &j.frame_j)] {
                if let Attach::Body(_) = side {
                    sum += f.origin.norm();
                    n += 1;
                }
            }
        }
        let length_scale = if n > 0 && sum > 0.0 { sum / n as f64 } else { 1.0 };
        Ok(Self {
            options,
            length_scale,
        })
    }

    /// Φ and [Φ; normalisation] Jacobian (dense) at (q, t).
    fn position_system(ev: &mut Evaluator, t: f64, q: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let f = Self::position_residual(ev, t, q);
        (f, Self::position_jacobian(ev, q))
    }

    /// [Φ; normalisation] at (q, t), the rows left evaluated there (for
    /// [`position_jacobian`](Self::position_jacobian) at the same point): a trial step of
    /// assembly needs no Jacobian unless it is factorised.
    fn position_residual(ev: &mut Evaluator, t: f64, q: &[f64]) -> DVector<f64> {
        let lay = &ev.layout;
        let (nc, nb) = (lay.constraints(), lay.bodies());
        let zeros = vec![0.0; 6 * nb];
        ev.set_state(q, &zeros);
        ev.eval_constraints(t);
        let mut f = DVector::zeros(nc + nb);
        for (k, row) in ev.rows.iter().enumerate() {
            f[k] = row.phi;
        }
        for b in 0..nb {
            let p = &q[7 * b + 3..7 * b + 7];
            f[nc + b] = 0.5 * (p.iter().map(|v| v * v).sum::<f64>() - 1.0);
        }
        f
    }

    /// The [Φ; normalisation] Jacobian (dense) at `q`, from the rows
    /// [`position_residual`](Self::position_residual) last evaluated there.
    fn position_jacobian(ev: &Evaluator, q: &[f64]) -> DMatrix<f64> {
        let lay = &ev.layout;
        let sides = ev.row_sides();
        let n_eq = lay.constraints() + lay.bodies();
        let mut j = DMatrix::zeros(n_eq, 7 * lay.bodies());
        for (k, &(si, sj)) in sides.iter().enumerate() {
            let row = &ev.rows[k];
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
        for b in 0..lay.bodies() {
            for c in 0..4 {
                j[(lay.constraints() + b, 7 * b + 3 + c)] = q[7 * b + 3 + c];
            }
        }
        j
    }

    /// The minimum-norm least-squares solution by SVD; an error for a non-finite system.
    fn min_norm(a: DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>, ModelError> {
        if !(a.iter().all(|v| v.is_finite()) && b.iter().all(|v| v.is_finite())) {
            // (nalgebra's SVD does not return on non-finite input.)
            return Err(ModelError::Output(
                "non-finite linear system in an analysis".into(),
            ));
        }
        a.svd(true, true)
            .solve(b, 1e-12)
            .map_err(|e| ModelError::Output(e.to_string()))
    }

    /// Whether `x` is finite and solves A·x = b to [`LU_BACKWARD_ERROR`] of ‖A‖·‖x‖ + ‖b‖.
    fn backward_stable(a: &DMatrix<f64>, x: &DVector<f64>, b: &DVector<f64>) -> bool {
        if !x.iter().all(|v| v.is_finite()) {
            return false;
        }
        // A·x and the rows' absolute sums in one pass down A's columns (column-major).
        let m = a.nrows();
        if x.len() != a.ncols() || b.len() != m {
            return false;
        }
        let mut acc = vec![0.0; 2 * m];
        let (ax, rows) = acc.split_at_mut(m);
        for (col, &xj) in a.as_slice().chunks_exact(m.max(1)).zip(x.iter()) {
            for ((v, s), r) in col.iter().zip(ax.iter_mut()).zip(rows.iter_mut()) {
                *s += v * xj;
                *r += v.abs();
            }
        }
        let res = ax
            .iter()
            .zip(b.iter())
            .fold(0.0f64, |m, (s, bi)| m.max((s - bi).abs()));
        let a_norm = rows.iter().fold(0.0f64, |m, v| m.max(*v));
        res <= LU_BACKWARD_ERROR * (a_norm * x.amax() + b.amax()).max(1e-300)
    }

    /// Velocity Jacobian B (m × 6nb) and Φ_t at the state last set.
    fn velocity_system(ev: &Evaluator) -> (DMatrix<f64>, DVector<f64>) {
        let lay = &ev.layout;
        let sides = ev.row_sides();
        let mut bm = DMatrix::zeros(lay.constraints(), 6 * lay.bodies());
        let mut phit = DVector::zeros(lay.constraints());
        for (k, &(si, sj)) in sides.iter().enumerate() {
            phit[k] = ev.rows[k].phi_t;
            for (side_i, b) in [(true, si), (false, sj)] {
                let Some(b) = b else { continue };
                let (bt, br) = ev.b_row(k, side_i, b);
                for c in 0..3 {
                    bm[(k, 6 * b + c)] += bt[c];
                    bm[(k, 6 * b + 3 + c)] += br[c];
                }
            }
        }
        (bm, phit)
    }

    fn constraint_name(model: &Mechanism, data: &MechanismData, k: usize) -> String {
        let lay = &data.ev.layout;
        if k < lay.constraints() {
            let mut i = 0;
            for blk in &data.ev.blocks {
                if k < i + blk.prim.len() {
                    return blk.names[k - i].clone();
                }
                i += blk.prim.len();
            }
        }
        format!(
            "normalisation of body '{}'",
            model.bodies().bodies[k - lay.constraints()].name
        )
    }

    /// Largest |Φ_k(q, t)| over the constraints and Euler-parameter normalisations (drift).
    /// Read-only: evaluates in a scratch copy of `data`'s (an allocation per call, as the
    /// dense Jacobian built here is anyway). Fails for data made for another model.
    pub fn constraint_residual(
        &self,
        model: &Mechanism,
        data: &MechanismData,
        t: f64,
        q: &[f64],
    ) -> Result<f64, ModelError> {
        model.check_data(data)?;
        Ok(Self::residual_in(&mut data.ev.clone(), t, q))
    }

    /// [`constraint_residual`](Self::constraint_residual) in the given scratch.
    pub(crate) fn residual_in(ev: &mut Evaluator, t: f64, q: &[f64]) -> f64 {
        Self::position_residual(ev, t, q).amax()
    }

    /// Position assembly: Gauss–Newton with minimum-norm steps on Φ(q, t) = 0 and the
    /// normalisations, from `guess`. On failure the error names the unsatisfied constraints.
    pub fn assemble(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        guess: &[f64],
    ) -> Result<Vec<f64>, ModelError> {
        model.check_data(data)?;
        let lay = data.ev.layout.clone();
        if guess.len() != 7 * lay.bodies() || guess.iter().any(|v| !v.is_finite()) {
            return Err(ModelError::Output(format!(
                "assembly guess must have {} finite values",
                7 * lay.bodies()
            )));
        }
        let mut q = guess.to_vec();
        if lay.constraints() == 0 {
            // No constraints: only the Euler parameters need normalising.
            for b in 0..lay.bodies() {
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
        // Chord steps: the factorisation of a square Jacobian is kept while the steps it
        // gives contract the residual by CHORD_CONTRACTION or better (near a solution, where
        // assembly usually starts along a trajectory, one factorisation serves every
        // iteration, and the last assembly's serves the next: its first step is a chord
        // step on it); otherwise the Jacobian is factorised afresh.
        let n_eq = lay.constraints() + lay.bodies();
        let mut chord: Option<DenseLu> = data
            .position_lu
            .take()
            .filter(|lu| lu.order() == n_eq && n_eq == 7 * lay.bodies());
        // (The last assembly's factors must contract the residual faster: they were made at
        // another configuration, and a slow chord costs more evaluations than it saves.)
        let mut inherited = chord.is_some();
        // The residual at q; its Jacobian only when it is factorised (a chord step or a
        // damped trial that is kept needs none): built from the rows evaluated at q, or
        // evaluated again when a rejected trial left them elsewhere.
        let mut f = Self::position_residual(&mut data.ev, t, &q);
        let mut rows_at_q = true;
        for _ in 0..self.options.max_iterations {
            let norm = f.amax();
            if norm <= self.options.tolerance {
                data.position_lu = chord;
                return Ok(q);
            }
            if let Some(lu) = &chord {
                if let Some(step) = lu.solve(&f) {
                    let trial: Vec<f64> = q.iter().zip(step.iter()).map(|(a, b)| a - b).collect();
                    let ft = Self::position_residual(&mut data.ev, t, &trial);
                    let contraction = if inherited {
                        INHERITED_CHORD_CONTRACTION
                    } else {
                        CHORD_CONTRACTION
                    };
                    if ft.amax() <= contraction * norm {
                        (q, f, rows_at_q) = (trial, ft, true);
                        last = norm;
                        continue;
                    }
                    rows_at_q = false;
                }
                chord = None;
                inherited = false;
            }
            if !rows_at_q {
                Self::position_residual(&mut data.ev, t, &q);
            }
            let j = Self::position_jacobian(&data.ev, &q);
            let step = if let Some(lu) = DenseLu::new(&j) {
                match lu.solve(&f) {
                    Some(x) if Self::backward_stable(&j, &x, &f) => {
                        chord = Some(lu);
                        x
                    }
                    _ => Self::min_norm(j.clone(), &f)?,
                }
            } else {
                Self::min_norm(j.clone(), &f)?
            };
            let mut alpha = 1.0;
            // Damped step: halve while the residual grows a lot (far from the solution).
            rows_at_q = false;
            for _ in 0..10 {
                let trial: Vec<f64> = q.iter().zip(step.iter()).map(|(a, b)| a - alpha * b).collect();
                let ft = Self::position_residual(&mut data.ev, t, &trial);
                if ft.amax() < norm.max(1e-300) * 1.5 || alpha < 1e-3 {
                    (q, f, rows_at_q) = (trial, ft, true);
                    break;
                }
                alpha *= 0.5;
            }
            if alpha < 1.0 {
                chord = None;
            }
            if (last - norm).abs() < 1e-16 && norm > self.options.tolerance * 1e3 {
                break;
            }
            last = norm;
        }
        // `f` is the residual at q; the rows are evaluated there again only when a rejected
        // trial left them elsewhere (the evaluator is left at the returned configuration).
        if !rows_at_q {
            Self::position_residual(&mut data.ev, t, &q);
        }
        if f.amax() <= self.options.tolerance * 10.0 {
            data.position_lu = chord;
            return Ok(q);
        }
        let mut res: Vec<(String, f64)> = (0..f.len())
            .filter(|&k| f[k].abs() > self.options.tolerance * 10.0)
            .map(|k| (Self::constraint_name(model, data, k), f[k]))
            .collect();
        res.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        Err(ModelError::AssemblyFailed { residuals: res })
    }

    /// Velocity analysis: the velocities closest to `guess` (minimum change) that satisfy
    /// B·w + Φ_t = 0 at (q, t).
    pub fn velocities(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        guess: &[f64],
    ) -> Result<Vec<f64>, ModelError> {
        let (w, lu) = self.velocities_factorised(model, data, t, q, guess)?;
        // (Kept for a later analysis at the same positions, as `state_at` keeps it.)
        data.velocity_lu = lu.map(|lu| VelocityLu { t, q: q.to_vec(), lu });
        Ok(w)
    }

    /// [`velocities`](Self::velocities), and the LU of the velocity Jacobian B(q, t) where it
    /// is square and gave a backward-stable solution: the acceleration analysis at the same
    /// positions solves with B and Bᵀ again ([`Self::state_at`]). A square, regular B is
    /// solved by LU, used only when finite and backward stable (residual below
    /// [`LU_BACKWARD_ERROR`] of ‖B‖·‖x‖ + ‖r‖; a test against ‖r‖ alone refused every Newton
    /// step near convergence, where r is tiny, and sent it to the SVD: three quarters of a
    /// diagnosis's time); otherwise (redundant constraints, a singular configuration) the
    /// minimum-norm least-squares solution by SVD.
    fn velocities_factorised(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        guess: &[f64],
    ) -> Result<(Vec<f64>, Option<DenseLu>), ModelError> {
        model.check_data(data)?;
        if data.ev.layout.constraints() == 0 {
            return Ok((guess.to_vec(), None));
        }
        data.ev.set_state(q, guess);
        data.ev.eval_constraints(t);
        let (bm, phit) = Self::velocity_system(&data.ev);
        let w0 = DVector::from_column_slice(guess);
        let r = &bm * &w0 + phit;
        // B depends on the positions alone (a driver's or an offset constraint's motion moves
        // Φ_t, not B): the factors the last analysis made at these very (t, q) are the ones a
        // new factorisation would give, bit for bit (a position-level sensitivity's rate
        // differences solve at one configuration many times).
        let stored = data
            .velocity_lu
            .take()
            .filter(|f| f.t == t && f.q == q)
            .map(|f| f.lu);
        if let Some(lu) = stored.or_else(|| DenseLu::new(&bm)) {
            if let Some(dw) = lu.solve(&r).filter(|dw| Self::backward_stable(&bm, dw, &r)) {
                return Ok(((w0 - dw).iter().copied().collect(), Some(lu)));
            }
        }
        let dw = Self::min_norm(bm, &r)?;
        Ok(((w0 - dw).iter().copied().collect(), None))
    }

    /// q̇ = H(q)·w.
    fn qdot(data: &MechanismData, q: &[f64], w: &[f64]) -> Vec<f64> {
        let mut qd = vec![0.0; 7 * data.ev.layout.bodies()];
        position_rates(q, w, 0.0, &mut qd);
        qd
    }

    /// γ = −d/dt(B·w + Φ_t) at ẇ = 0 ([`Evaluator::gamma`]).
    fn gamma(data: &mut MechanismData, t: f64, q: &[f64], w: &[f64]) -> DVector<f64> {
        let qd = Self::qdot(data, q, w);
        let mut g = DVector::zeros(data.ev.layout.constraints());
        data.ev.gamma(t, q, &qd, w, g.as_mut_slice());
        g
    }

    /// The bodies' mass matrix in the velocity coordinates (per body: its mass on the three
    /// translations, its inertia on the three rotations), kg and kg·m².
    fn mass_matrix(model: &Mechanism) -> DMatrix<f64> {
        let bodies = &model.bodies().bodies;
        let mut m = DMatrix::zeros(6 * bodies.len(), 6 * bodies.len());
        for (b, body) in bodies.iter().enumerate() {
            for c in 0..3 {
                m[(6 * b + c, 6 * b + c)] = body.mass;
            }
            m.view_mut((6 * b + 3, 6 * b + 3), (3, 3))
                .copy_from(&body.inertia);
        }
        m
    }

    /// Acceleration analysis: solves [M Bᵀ; B 0]·[ẇ; λ] = [Q; γ] at (q, w, t). Returns
    /// (ẇ, λ). With a driven mechanism (no free degrees of freedom) λ of the drivers are the
    /// actuator loads: inverse dynamics.
    pub fn accelerations(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        w: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>), ModelError> {
        self.accelerations_factorised(model, data, t, q, w, None)
    }

    /// [`accelerations`](Self::accelerations) with the velocity Jacobian B at `q` already
    /// factorised (`b_lu`, from [`Self::velocities_factorised`] at the same positions and time).
    fn accelerations_factorised(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        w: &[f64],
        b_lu: Option<&DenseLu>,
    ) -> Result<(Vec<f64>, Vec<f64>), ModelError> {
        model.check_data(data)?;
        let lay = data.ev.layout.clone();
        if lay.constraints() == 0 {
            // Free bodies: Newton–Euler per body, no global system.
            data.ev.set_state(q, w);
            data.ev.eval_loads(model, t);
            let mut wdot = vec![0.0; 6 * lay.bodies()];
            for (b, body) in model.bodies().bodies.iter().enumerate() {
                let st = &data.ev.states[b];
                let ld = &data.ev.loads[b];
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
        // (γ leaves the bodies' states at (q, w).)
        let gamma = Self::gamma(data, t, q, w);
        data.ev.eval_constraints(t);
        data.ev.eval_loads(model, t);
        let n = 6 * lay.bodies();
        let mut rhs = DVector::zeros(n + lay.constraints());
        for (b, body) in model.bodies().bodies.iter().enumerate() {
            let st = &data.ev.states[b];
            let gyro = st.omega.cross(&(body.inertia * st.omega));
            let ld = &data.ev.loads[b];
            for c in 0..3 {
                rhs[6 * b + c] = ld.force[c];
                rhs[6 * b + 3 + c] = ld.torque[c] - gyro[c];
            }
        }
        // A driven mechanism without free degrees of freedom has a square, regular B: then
        // B·ẇ = γ and λ = B⁻ᵀ(Q − M·ẇ) from one LU of B, solved with B and with Bᵀ (a
        // fraction of the work of the augmented system below).
        if lay.constraints() == n {
            let own;
            let lu = match b_lu {
                Some(lu) => Some(lu),
                None => {
                    own = DenseLu::new(&Self::velocity_system(&data.ev).0);
                    own.as_ref()
                }
            };
            if let Some((lu, wdot)) = lu.and_then(|lu| lu.solve(&gamma).map(|x| (lu, x))) {
                // r = Q − M·ẇ, M block diagonal: the mass on translations, the inertia on
                // rotations.
                let mut r: DVector<f64> = rhs.rows(0, n).into_owned();
                for (b, body) in model.bodies().bodies.iter().enumerate() {
                    let al = Vector3::new(wdot[6 * b + 3], wdot[6 * b + 4], wdot[6 * b + 5]);
                    let ia = body.inertia * al;
                    for c in 0..3 {
                        r[6 * b + c] -= body.mass * wdot[6 * b + c];
                        r[6 * b + 3 + c] -= ia[c];
                    }
                }
                if let Some(lambda) = lu.solve_transpose(&r) {
                    if wdot.iter().chain(lambda.iter()).all(|v| v.is_finite()) {
                        return Ok((wdot.iter().copied().collect(), lambda.iter().copied().collect()));
                    }
                }
            }
        }
        // The augmented system (redundant constraints, free degrees of freedom, or B singular
        // here).
        let (bm, _) = Self::velocity_system(&data.ev);
        let mut k = DMatrix::zeros(n + lay.constraints(), n + lay.constraints());
        k.view_mut((0, 0), (n, n)).copy_from(&Self::mass_matrix(model));
        k.view_mut((0, n), (n, lay.constraints()))
            .copy_from(&bm.transpose());
        k.view_mut((n, 0), (lay.constraints(), n)).copy_from(&bm);
        rhs.rows_mut(n, lay.constraints()).copy_from(&gamma);
        let finite = k.iter().chain(rhs.iter()).all(|v| v.is_finite());
        let sol = match DenseLu::new(&k).and_then(|lu| lu.solve(&rhs)) {
            Some(s) => s,
            // (nalgebra's SVD does not return on non-finite input.)
            _ if !finite => {
                return Err(ModelError::Output(format!(
                    "non-finite acceleration system at t = {t} s"
                )))
            }
            _ => k
                .svd(true, true)
                .solve(&rhs, 1e-12)
                .map_err(|e| ModelError::Output(e.to_string()))?,
        };
        Ok((
            sol.rows(0, n).iter().copied().collect(),
            sol.rows(n, lay.constraints()).iter().copied().collect(),
        ))
    }

    /// How the constraint multipliers λ move when the acceleration-level equation of each
    /// of `rows` (indices into the constraint vector) is offset by a unit: Φ̈_k = 1 instead of
    /// 0 — a constraint acceleration offset ([`MechanismData::set_constraint_offset`] with
    /// `[0, 0, 1]`) or, for a driver's row ([`Layout::driver_lambda`]), a unit more of the
    /// driver's prescribed acceleration. One column dλ per row. The acceleration analysis
    /// ([`accelerations`](Self::accelerations)) is linear in these right-hand sides, so this
    /// is exact, and one factorisation serves every row: for a driven mechanism (square B)
    /// dλ = −B⁻ᵀ·M·B⁻¹·e_k, else from the augmented system. The state (q, w) at `t` must be
    /// assembled.
    pub fn acceleration_offset_sensitivity(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        w: &[f64],
        rows: &[usize],
    ) -> Result<Vec<Vec<f64>>, ModelError> {
        model.check_data(data)?;
        let lay = data.ev.layout.clone();
        let nc = lay.constraints();
        if let Some(&k) = rows.iter().find(|&&k| k >= nc) {
            return Err(ModelError::Output(format!(
                "constraint row {k} out of range ({nc} constraint equations)"
            )));
        }
        data.ev.set_state(q, w);
        data.ev.eval_constraints(t);
        let (bm, _) = Self::velocity_system(&data.ev);
        let n = 6 * lay.bodies();
        let mass = Self::mass_matrix(model);
        let singular = || ModelError::Output(format!("singular acceleration system at t = {t} s"));
        if nc == n {
            // (The factors of B the last analysis made at these positions, if it did.)
            let kept = data.velocity_lu.as_ref().filter(|f| f.t == t && f.q == q);
            let made;
            let lu = match kept {
                Some(f) => &f.lu,
                None => {
                    made = DenseLu::new(&bm).ok_or_else(singular)?;
                    &made
                }
            };
            return rows
                .iter()
                .map(|&k| {
                    let mut e = DVector::zeros(n);
                    e[k] = 1.0;
                    let dw = lu.solve(&e).ok_or_else(singular)?;
                    let dl = lu.solve_transpose(&(-(&mass * dw))).ok_or_else(singular)?;
                    Ok(dl.iter().copied().collect())
                })
                .collect();
        }
        let mut k = DMatrix::zeros(n + nc, n + nc);
        k.view_mut((0, 0), (n, n)).copy_from(&mass);
        k.view_mut((0, n), (n, nc)).copy_from(&bm.transpose());
        k.view_mut((n, 0), (nc, n)).copy_from(&bm);
        let lu = DenseLu::new(&k).ok_or_else(singular)?;
        rows.iter()
            .map(|&r| {
                let mut e = DVector::zeros(n + nc);
                e[n + r] = 1.0;
                let sol = lu.solve(&e).ok_or_else(singular)?;
                Ok(sol.rows(n, nc).iter().copied().collect())
            })
            .collect()
    }

    /// The consistent initial state at `t0` from the model's initial poses and velocities;
    /// also stored in `data`.
    pub fn initial_state(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t0: f64,
    ) -> Result<Snapshot, ModelError> {
        let (q0, w0) = model.initial_guess();
        self.state_at(model, data, t0, &q0, &w0)
    }

    /// A consistent snapshot at `t` from approximate positions and velocities (assembly,
    /// velocity and acceleration analysis); also stored in `data`.
    pub fn state_at(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q_guess: &[f64],
        w_guess: &[f64],
    ) -> Result<Snapshot, ModelError> {
        let q = self.assemble(model, data, t, q_guess)?;
        // One factorisation of B(q, t) for the velocities, the accelerations and λ.
        let (w, b_lu) = self.velocities_factorised(model, data, t, &q, w_guess)?;
        let (wdot, lambda) = self.accelerations_factorised(model, data, t, &q, &w, b_lu.as_ref())?;
        data.velocity_lu = b_lu.map(|lu| VelocityLu { t, q: q.clone(), lu });
        let s = Snapshot {
            t,
            q,
            w,
            wdot,
            lambda,
        };
        data.store(&s);
        Ok(s)
    }

    /// How the assembled configuration `q` (at time `t`) of a mechanism without free degrees
    /// of freedom moves when constraint equations are offset: for each row k of `rows`
    /// (indices into the constraint vector, e.g. from [`Layout::joint_lambda`]), the change
    /// dq/dε of the positions when Φ_k(q, t) = 0 becomes Φ_k(q, t) = ε — to first order, from
    /// one LU of the assembly Jacobian. For a joint's point constraint (rows 0–2 of a
    /// spherical, universal or revolute joint) ε is a displacement of the side-j point from
    /// the side-i point along base x, y, z (m); for a universal joint's perpendicularity row
    /// (row 3) ε = −φ, φ a rotation of side j about z_i × z_j (rad). Fails if the
    /// mechanism has free degrees of freedom or is singular at `q` (the configuration is not
    /// determined by its constraints).
    pub fn constraint_offset_sensitivity(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        t: f64,
        q: &[f64],
        rows: &[usize],
    ) -> Result<Vec<Vec<f64>>, ModelError> {
        model.check_data(data)?;
        let (_, j) = Self::position_system(&mut data.ev, t, q);
        if !j.is_square() {
            return Err(ModelError::Output(format!(
                "constraint-offset sensitivity needs a mechanism without free degrees of freedom ({} equations for {} coordinates)",
                j.nrows(),
                j.ncols()
            )));
        }
        let nc = data.ev.layout.constraints();
        if let Some(&k) = rows.iter().find(|&&k| k >= nc) {
            return Err(ModelError::Output(format!(
                "constraint row {k} out of range ({nc} constraint equations)"
            )));
        }
        let n = j.nrows();
        let lu = DenseLu::new(&j);
        rows.iter()
            .map(|&k| {
                let mut e = DVector::zeros(n);
                e[k] = 1.0;
                match lu.as_ref().and_then(|lu| lu.solve(&e)) {
                    Some(x) => Ok(x.iter().copied().collect()),
                    _ => Err(ModelError::Output(format!(
                        "the assembly Jacobian is singular at t = {t} s: the configuration does not determine how constraint '{}' moves the mechanism",
                        Self::constraint_name(model, data, k)
                    ))),
                }
            })
            .collect()
    }

    /// The mass matrix of a driven mechanism without free degrees of freedom in its driver
    /// coordinates, at the state stored in `data` (kg·m² for revolute drivers): M_d = Vᵀ·M·V,
    /// V the body velocities per unit rate of each driver (from the velocity Jacobian). It is
    /// the inertia the drivers feel when their coordinates accelerate; rows and columns in
    /// driver order.
    pub fn driver_mass_matrix(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
    ) -> Result<DMatrix<f64>, ModelError> {
        model.check_data(data)?;
        let lay = data.ev.layout.clone();
        let n = 6 * lay.bodies();
        if lay.constraints() != n {
            return Err(ModelError::Output(format!(
                "the driver mass matrix needs a mechanism without free degrees of freedom ({} constraints for {n} velocities)",
                lay.constraints()
            )));
        }
        // B at the stored state: the LU the last state analysis made there, else afresh.
        let stored = data.velocity_lu.take().filter(|f| f.t == data.t && f.q == data.q);
        let lu = match stored {
            Some(f) => f.lu,
            None => {
                let (q, w) = (data.q.clone(), data.w.clone());
                data.ev.set_state(&q, &w);
                data.ev.eval_constraints(data.t);
                let (bm, _) = Self::velocity_system(&data.ev);
                DenseLu::new(&bm).ok_or_else(|| {
                    ModelError::Output(format!("singular velocity Jacobian at t = {} s", data.t))
                })?
            }
        };
        let rows: Vec<usize> = model
            .drivers()
            .filter_map(|(h, _)| lay.driver_lambda(h))
            .collect();
        let mut v = DMatrix::zeros(n, rows.len());
        for (c, &r) in rows.iter().enumerate() {
            let mut e = DVector::zeros(n);
            e[r] = 1.0;
            let x = lu.solve(&e).ok_or_else(|| {
                ModelError::Output(format!("singular velocity Jacobian at t = {} s", data.t))
            })?;
            v.set_column(c, &x);
        }
        let mut mv = DMatrix::zeros(n, rows.len());
        for (b, body) in model.bodies().bodies.iter().enumerate() {
            for c in 0..rows.len() {
                for k in 0..3 {
                    mv[(6 * b + k, c)] = body.mass * v[(6 * b + k, c)];
                }
                let om = Vector3::new(v[(6 * b + 3, c)], v[(6 * b + 4, c)], v[(6 * b + 5, c)]);
                let h = body.inertia * om;
                for k in 0..3 {
                    mv[(6 * b + 3 + k, c)] = h[k];
                }
            }
        }
        let m = v.transpose() * mv;
        data.velocity_lu = Some(VelocityLu {
            t: data.t,
            q: data.q.clone(),
            lu,
        });
        Ok(m)
    }

    /// First-order displacement (m, base frame) of the point `s` (body frame, m) of body
    /// `body` when the positions `q` change by `dq` (e.g. a column of
    /// [`constraint_offset_sensitivity`](Self::constraint_offset_sensitivity)).
    pub fn point_variation(
        model: &Mechanism,
        q: &[f64],
        dq: &[f64],
        body: BodyHandle,
        s: &Vector3<f64>,
    ) -> Vector3<f64> {
        let r = model.layout().body_q(body);
        let p = nalgebra::Vector4::new(q[r.start + 3], q[r.start + 4], q[r.start + 5], q[r.start + 6]);
        let dp = nalgebra::Vector4::new(dq[r.start + 3], dq[r.start + 4], dq[r.start + 5], dq[r.start + 6]);
        Vector3::new(dq[r.start], dq[r.start + 1], dq[r.start + 2]) + d_rot(&p, s) * dp
    }

    /// Kinematic analysis of a driven mechanism over `times`: positions by assembly
    /// (continuing from the previous point), velocities, accelerations and constraint forces.
    pub fn kinematics(
        &self,
        model: &Mechanism,
        data: &mut MechanismData,
        times: &[f64],
    ) -> Result<Vec<Snapshot>, ModelError> {
        let (mut q, w0) = model.initial_guess();
        let mut w = w0;
        let mut out = Vec::with_capacity(times.len());
        for &t in times {
            let s = self.state_at(model, data, t, &q, &w)?;
            q.clone_from(&s.q);
            w.clone_from(&s.w);
            out.push(s);
        }
        Ok(out)
    }

    /// Smallest singular value of the row-normalised velocity Jacobian B at (q, t), divided by
    /// the largest: 1 for a well-conditioned constraint set, 0 at a singular configuration.
    /// Read-only: evaluates in a scratch copy of `data`'s (an allocation per call, as the
    /// SVD here is anyway). Fails for data made for another model.
    pub fn singularity_measure(
        &self,
        model: &Mechanism,
        data: &MechanismData,
        t: f64,
        q: &[f64],
    ) -> Result<f64, ModelError> {
        model.check_data(data)?;
        Ok(self.singularity_in(&mut data.ev.clone(), t, q))
    }

    /// [`singularity_measure`](Self::singularity_measure) in the given scratch (the
    /// simulation's own, without a copy per output sample).
    pub(crate) fn singularity_in(&self, ev: &mut Evaluator, t: f64, q: &[f64]) -> f64 {
        if ev.layout.constraints() == 0 {
            return 1.0;
        }
        let zeros = vec![0.0; 6 * ev.layout.bodies()];
        ev.set_state(q, &zeros);
        ev.eval_constraints(t);
        let (mut bm, _) = Self::velocity_system(ev);
        // Angular-velocity columns in units of a velocity at the model's length scale.
        for b in 0..ev.layout.bodies() {
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
        if !bm.iter().all(|v| v.is_finite()) {
            return f64::NAN;
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

    /// Reaction of every joint present (in insertion order) on its side-j body (at the
    /// joint origin, base frame), from the multipliers `lambda` at (q, t). Read-only: see
    /// also [`Snapshot::reaction`] and [`MechanismData::reaction`] for one joint by handle.
    pub fn reactions(&self, model: &Mechanism, t: f64, q: &[f64], lambda: &[f64]) -> Vec<Reaction> {
        let mut out = Vec::new();
        let mut k = 0;
        for (_, j) in model.joints() {
            let (r, n) = joint_reaction(j, k, t, q, lambda);
            out.push(r);
            k += n;
        }
        out
    }
}

/// The reaction of joint `j`, whose multipliers start at `k0` in `lambda`, and its number of
/// multipliers.
pub(crate) fn joint_reaction(j: &Joint, k0: usize, t: f64, q: &[f64], lambda: &[f64]) -> (Reaction, usize) {
    let pose = |a: Attach| match a {
        Attach::Ground => Pose::ground(),
        Attach::Body(h) => {
            let b = h.index();
            Pose::new(
                Vector3::new(q[7 * b], q[7 * b + 1], q[7 * b + 2]),
                nalgebra::Vector4::new(q[7 * b + 3], q[7 * b + 4], q[7 * b + 5], q[7 * b + 6]),
            )
        }
    };
    let prims = j.primitives();
    let n: usize = prims.iter().map(|p| p.len()).sum();
    let (mut f, mut tq) = (Vector3::zeros(), Vector3::zeros());
    if let Attach::Body(_) = j.body_j {
        let (pi, pj) = (pose(j.body_i), pose(j.body_j));
        let mut rows = vec![Row::default(); n];
        let mut k = 0;
        for prim in &prims {
            let len = prim.len();
            prim.eval(&pi, &pj, t, &mut rows[k..k + len]);
            k += len;
        }
        let a = pj.a;
        let l = l_matrix(&pj.p);
        for (kk, row) in rows.iter().enumerate() {
            let (bt, br) = (row.d_rj, 0.5 * l * row.d_pj);
            f -= bt * lambda[k0 + kk];
            tq -= a * (br * lambda[k0 + kk]);
        }
        // Move the torque from the centre of mass to the joint origin.
        let arm = a * j.frame_j.origin;
        tq -= arm.cross(&f);
    }
    (
        Reaction {
            force: [f.x, f.y, f.z],
            torque: [tq.x, tq.y, tq.z],
        },
        n,
    )
}
