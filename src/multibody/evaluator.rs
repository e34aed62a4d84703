//! Scratch of one evaluation of a mechanism's kinematics, constraints and loads, shared by the
//! DAE residual, the explicit ODE and the analyses.

use super::body::Attach;
use super::constraints::{Pose, Row, SideMotion};
use super::forces::{BodyLoad, BodyState};
use super::layout::Layout;
use super::model::{ConstraintBlock, Mechanism};
use super::rotation::l_matrix;
use nalgebra::{Vector3, Vector4};

/// Scratch of one evaluation of kinematics, constraints and loads: shared by the DAE
/// residual, the explicit ODE and the analyses (through [`MechanismData`](super::MechanismData)).
/// Holds the model's constraint blocks (compiled when the scratch is made), never the model.
#[derive(Debug, Clone)]
pub(crate) struct Evaluator {
    pub blocks: Vec<ConstraintBlock>,
    /// Index of the first driver block in `blocks`.
    pub driver_block0: usize,
    pub layout: Layout,
    pub rows: Vec<Row>,
    pub poses: Vec<Pose>,
    pub states: Vec<BodyState>,
    pub loads: Vec<BodyLoad>,
    /// Per constraint row, the offset ε(t) = x + v·(t − t0) + ½a·(t − t0)² that Φ_k holds
    /// instead of 0, as [x, v, a] (empty: none). Set through
    /// [`MechanismData::set_constraint_offset`](super::MechanismData::set_constraint_offset).
    pub offsets: Vec<[f64; 3]>,
    /// The time t0 of the offsets' quadratics, s.
    pub offset_t0: f64,
    /// The sides (body indices) of each scalar constraint row, fixed when the scratch is made
    /// (only a driver's motion law changes afterwards, never its bodies or its rows).
    sides: Vec<(Option<usize>, Option<usize>)>,
    /// Per body, the motion [`gamma`](Self::gamma) last used (scratch).
    motions: Vec<SideMotion>,
}

impl Evaluator {
    pub(crate) fn new(model: &Mechanism) -> Self {
        let blocks = model.constraint_blocks();
        let layout = model.layout().clone();
        let nb = layout.bodies();
        let driver_block0 = blocks.len() - layout.drivers();
        let sides = blocks
            .iter()
            .flat_map(|blk| std::iter::repeat_n((Self::side(blk.i), Self::side(blk.j)), blk.prim.len()))
            .collect();
        Self {
            sides,
            motions: Vec::with_capacity(nb),
            rows: vec![Row::default(); layout.constraints()],
            poses: vec![Pose::ground(); nb],
            states: vec![BodyState::ground(); nb],
            loads: vec![BodyLoad::default(); nb],
            offsets: vec![],
            offset_t0: 0.0,
            blocks,
            driver_block0,
            layout,
        }
    }

    pub(crate) fn side(a: Attach) -> Option<usize> {
        match a {
            Attach::Ground => None,
            Attach::Body(h) => Some(h.0),
        }
    }

    /// Sets poses and velocities from q = (r, p) per body and w = (v, ω') per body.
    pub(crate) fn set_state(&mut self, q: &[f64], w: &[f64]) {
        for b in 0..self.layout.bodies() {
            let r = Vector3::new(q[7 * b], q[7 * b + 1], q[7 * b + 2]);
            let p = Vector4::new(q[7 * b + 3], q[7 * b + 4], q[7 * b + 5], q[7 * b + 6]);
            self.poses[b] = Pose::new(r, p);
            let v = Vector3::new(w[6 * b], w[6 * b + 1], w[6 * b + 2]);
            let om = Vector3::new(w[6 * b + 3], w[6 * b + 4], w[6 * b + 5]);
            self.states[b] = BodyState {
                r,
                p,
                a: self.poses[b].a,
                v,
                omega: om,
            };
        }
    }

    /// B·w + Φ_t per constraint row (`out`, one entry per row) at the rows and the bodies'
    /// velocities last set ([`set_state`](Self::set_state), [`eval_constraints`](Self::eval_constraints)):
    /// row by row, a row touching at most two bodies.
    pub(crate) fn velocity_constraints(&self, out: &mut [f64]) {
        for (k, &(si, sj)) in self.sides.iter().enumerate() {
            let mut c = self.rows[k].phi_t;
            for (side_i, b) in [(true, si), (false, sj)] {
                if let Some(b) = b {
                    let (bt, br) = self.b_row(k, side_i, b);
                    let st = &self.states[b];
                    c += bt.dot(&st.v) + br.dot(&st.omega);
                }
            }
            out[k] = c;
        }
    }

    /// γ = −d/dt(B·w + Φ_t) at ẇ = 0 (`out`, one entry per constraint row) at positions `q`
    /// moving with `qd` (q̇ = H(q)·w, or with the Euler parameters' stabilisation) and
    /// velocities `w`, in closed form ([`Primitive::velocity_rate`](super::constraints::Primitive::velocity_rate)
    /// per row, the offsets' accelerations added). It replaced central differences of B·w + Φ_t
    /// along (q̇, 1) with Richardson extrapolation (four constraint evaluations, 16 % of a
    /// multibody diagnosis; their steps straddled the knots of sampled drives). Leaves the
    /// bodies' states at (q, w); the rows are not evaluated.
    pub(crate) fn gamma(&mut self, t: f64, q: &[f64], qd: &[f64], w: &[f64], out: &mut [f64]) {
        self.set_state(q, w);
        self.motions.clear();
        for b in 0..self.layout.bodies() {
            let st = &self.states[b];
            let pd = Vector4::new(qd[7 * b + 3], qd[7 * b + 4], qd[7 * b + 5], qd[7 * b + 6]);
            self.motions.push(SideMotion {
                pose: self.poses[b],
                v: st.v,
                rd: Vector3::new(qd[7 * b], qd[7 * b + 1], qd[7 * b + 2]),
                u: 0.5 * l_matrix(&st.p).transpose() * st.omega,
                pd,
                ud: 0.5 * l_matrix(&pd).transpose() * st.omega,
            });
        }
        let ground = SideMotion::ground();
        let mut k = 0;
        for blk in &self.blocks {
            let mi = Self::side(blk.i).map_or(ground, |b| self.motions[b]);
            let mj = Self::side(blk.j).map_or(ground, |b| self.motions[b]);
            let n = blk.prim.len();
            blk.prim.velocity_rate(&mi, &mj, t, &mut out[k..k + n]);
            k += n;
        }
        // Φ_k − ε_k(t) with ε = x + v·(t − t0) + ½a·(t − t0)²: Φ_tt gains −a.
        for (o, &[_, _, a]) in out.iter_mut().zip(&self.offsets) {
            *o -= a;
        }
        for o in out[..k].iter_mut() {
            *o = -*o;
        }
    }

    /// Evaluates all constraint rows at time t.
    pub(crate) fn eval_constraints(&mut self, t: f64) {
        let ground = Pose::ground();
        let mut k = 0;
        for blk in &self.blocks {
            let pi = Self::side(blk.i).map(|b| self.poses[b]).unwrap_or(ground);
            let pj = Self::side(blk.j).map(|b| self.poses[b]).unwrap_or(ground);
            let n = blk.prim.len();
            blk.prim.eval(&pi, &pj, t, &mut self.rows[k..k + n]);
            k += n;
        }
        let dt = t - self.offset_t0;
        for (row, &[x, v, a]) in self.rows.iter_mut().zip(&self.offsets) {
            row.phi -= x + v * dt + 0.5 * a * dt * dt;
            row.phi_t -= v + a * dt;
        }
    }

    /// The sides (body indices) of each scalar constraint row (found once: the analyses ask
    /// at every evaluation).
    pub(crate) fn row_sides(&self) -> &[(Option<usize>, Option<usize>)] {
        &self.sides
    }

    /// Applied loads (gravity and force elements of `model`) at time t.
    pub(crate) fn eval_loads(&mut self, model: &Mechanism, t: f64) {
        let g = model.gravity();
        for (b, body) in model.bodies().bodies.iter().enumerate() {
            self.loads[b] = BodyLoad {
                force: body.mass * g,
                torque: Vector3::zeros(),
            };
        }
        for (_, f) in model.forces() {
            f.apply(t, &self.states, &mut self.loads);
        }
    }

    /// Velocity-Jacobian row k restricted to body b: (translational, rotational) parts.
    pub(crate) fn b_row(&self, k: usize, side_i: bool, b: usize) -> (Vector3<f64>, Vector3<f64>) {
        let row = &self.rows[k];
        let l = l_matrix(&self.poses[b].p);
        if side_i {
            (row.d_ri, 0.5 * l * row.d_pi)
        } else {
            (row.d_rj, 0.5 * l * row.d_pj)
        }
    }
}
