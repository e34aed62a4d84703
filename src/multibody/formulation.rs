//! The equations of motion in GGL-stabilised index-2 form (Gear, Gupta & Leimkuhler 1985)
//! on the `dae` residual form.
//!
//! Unknowns: per body q = (r, p) (7) and w = (v, ω') (6); per constraint the multipliers λ
//! (forces) and μ (position stabilisation); per body ν (Euler-parameter normalisation).
//!
//! ```text
//! r' − v + Φ_rᵀμ                      = 0      (3 per body)
//! p' − ½L(p)ᵀω' + Φ_pᵀμ + 2pν         = 0      (4 per body)
//! m·v' − f − m·g + Φ_rᵀλ              = 0      (3 per body)
//! J'ω̇' + ω'×J'ω' − n' + Φ_π'ᵀλ        = 0      (3 per body)
//! Φ(q, t)                             = 0      (m)
//! Φ_r·v + Φ_π'·ω' + Φ_t               = 0      (m)
//! pᵀp − 1                             = 0      (1 per body)
//! ```
//! with Φ_π' = ½·Φ_p·L(p)ᵀ. Both constraint levels hold at every step, so drift stays at the
//! Newton tolerance; μ and ν vanish on the exact solution. λ, μ, ν are algebraic and left out
//! of the error test. The sparse pattern follows the topology: a body's rows couple only to
//! bodies sharing a joint or force element with it.

use super::constraints::{Hess14, Pose};
use super::error::ModelError;
use super::evaluator::Evaluator;
use super::forces::{BodyLoad, BodyState};
pub use super::layout::Layout;
use super::model::Mechanism;
use super::rotation::{l_matrix, skew};
use crate::dae::{DaeSystem, EvalError, JacobianSource, VarKind};
use crate::sparse::{CscPattern, SlotIndex};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, Vector3, Vector4};
use std::sync::Arc;

/// Tunables of the equations of motion ([`MultibodyDae`]); part of
/// [`SimulationOptions`](super::SimulationOptions), whose module documents every default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormulationOptions {
    /// Use the analytic Jacobian (default `true`) or lash's coloured finite differences.
    pub analytic_jacobian: bool,
    /// Measure velocity errors as index-2 variables (scaled by the step) in the error test,
    /// as for very stiff mechanical systems (see `DaeSystem::error_index`). Default `false`.
    pub velocities_index2: bool,
    /// Relative central-difference increment for the Jacobians of force elements that do
    /// not provide exact derivatives ([`ForceElement::load_jacobian`](super::ForceElement::load_jacobian)).
    /// Default 1e-9.
    pub force_fd_step: f64,
}

impl Default for FormulationOptions {
    fn default() -> Self {
        Self {
            analytic_jacobian: true,
            velocities_index2: false,
            force_fd_step: 1e-9,
        }
    }
}

/// Adds Jacobian entries into the values of a pattern, remembering the first entry outside
/// it (a bug of the formulation, reported as an error rather than a panic).
struct Scatter<'a> {
    slots: &'a SlotIndex,
    values: &'a mut [f64],
    outside: Option<(usize, usize)>,
}

impl Scatter<'_> {
    /// Adds `v` to entry (r, c).
    #[inline]
    fn add(&mut self, r: usize, c: usize, v: f64) {
        if v != 0.0 {
            match self.slots.get(r, c) {
                Some(k) => self.values[k] += v,
                None => {
                    self.outside.get_or_insert((r, c));
                }
            }
        }
    }
}

/// A mechanism's equations of motion as a [`DaeSystem`].
#[derive(Debug)]
pub struct MultibodyDae {
    model: Arc<Mechanism>,
    pub(crate) ev: Evaluator,
    names: Vec<String>,
    pattern: Option<CscPattern>,
    /// Entry lookup on `pattern` for the analytic Jacobian.
    slots: Option<SlotIndex>,
    /// Where each force element's load-derivative blocks go in the values ([`LoadSlots`]).
    load_slots: LoadSlots,
    /// Each force element's bodies ([`ForceElement::bodies`](super::ForceElement::bodies)),
    /// asked once: the Jacobian reads them on every evaluation.
    force_bodies: Vec<Vec<super::BodyHandle>>,
    /// The buffer the force elements' load-derivative blocks are written into, reused so the
    /// Jacobian allocates nothing.
    load_blocks: Vec<super::forces::LoadDerivative>,
    /// The buffer of a constraint block's Hessians, reused likewise.
    hessians: Vec<Hess14>,
    /// The states and the two load buffers of the force elements' central differences
    /// (made at the first element without exact derivatives, reused likewise).
    fd_scratch: Option<FdScratch>,
    /// Tunables.
    pub options: FormulationOptions,
    /// Jacobians at rest only (static equilibria): the Jacobian fills just the momentum
    /// rows' position and multiplier columns and the position-constraint rows; the other
    /// entries (kinematic, velocity-constraint, stabilisation and normalisation rows,
    /// velocity columns) are left zero.
    pub(crate) at_rest: bool,
}

/// The value positions of the force elements' load-derivative blocks, found once: for a
/// (loaded body, body differentiated by) pair, momentum row r (6) and state column c (13:
/// positions, velocities) sit at `table[6·c + r]` (column-major, as `LoadDerivative::d`). Indexed per loaded body (the Jacobian
/// looks up every block of every element on each evaluation; a body has a few partners).
#[derive(Debug, Clone, Default)]
struct LoadSlots {
    /// Per loaded body, (body differentiated by, table) of each pair.
    pairs: Vec<Vec<(usize, usize)>>,
    /// Per pair, the value position of each entry of its 6 × 13 block, column-major (the
    /// order of `LoadDerivative::d`'s storage): entry (r, c) at 6·c + r.
    tables: Vec<[usize; 78]>,
}

impl LoadSlots {
    /// The table of the pair (`loaded`, `wrt`), if all its positions are in the pattern.
    fn get(&self, loaded: usize, wrt: usize) -> Option<&[usize; 78]> {
        let &(_, k) = self.pairs.get(loaded)?.iter().find(|(w, _)| *w == wrt)?;
        self.tables.get(k)
    }
}

/// Scratch states and the loads at +h and −h of the force elements' central differences.
type FdScratch = (Vec<BodyState>, Vec<BodyLoad>, Vec<BodyLoad>);

/// ∂(L(p)·d)/∂p for a fixed 4-vector d: [d_v | −d_0·I + d̃_v] (3 × 4).
fn l_times_d_derivative(d: &Vector4<f64>) -> Matrix3x4<f64> {
    let dv = Vector3::new(d[1], d[2], d[3]);
    let mut m = Matrix3x4::zeros();
    m.set_column(0, &dv);
    m.fixed_view_mut::<3, 3>(0, 1)
        .copy_from(&(-d[0] * Matrix3::identity() + skew(&dv)));
    m
}

/// ∂(L(p)ᵀ·ω)/∂p = W(ω) = [[0, −ωᵀ], [ω, −ω̃]] (4 × 4).
fn lt_omega_derivative(om: &Vector3<f64>) -> Matrix4<f64> {
    let mut w = Matrix4::zeros();
    for k in 0..3 {
        w[(0, k + 1)] = -om[k];
        w[(k + 1, 0)] = om[k];
    }
    w.fixed_view_mut::<3, 3>(1, 1).copy_from(&(-skew(om)));
    w
}

impl MultibodyDae {
    /// Checks the model and builds its DAE with the default [`FormulationOptions`].
    pub fn new(model: Arc<Mechanism>) -> Result<Self, ModelError> {
        Self::with_options(model, FormulationOptions::default())
    }

    /// Checks the model ([`Mechanism::validate`]: e.g. a force element naming a body the
    /// model does not have) and builds its DAE.
    pub fn with_options(model: Arc<Mechanism>, options: FormulationOptions) -> Result<Self, ModelError> {
        model.validate()?;
        let ev = Evaluator::new(&model);
        let names = ev.blocks.iter().flat_map(|b| b.names.clone()).collect();
        let mut s = Self {
            model,
            ev,
            names,
            pattern: None,
            slots: None,
            load_slots: LoadSlots::default(),
            force_bodies: Vec::new(),
            load_blocks: Vec::new(),
            hessians: Vec::new(),
            fd_scratch: None,
            options,
            at_rest: false,
        };
        s.force_bodies = s.model.forces().map(|(_, f)| f.bodies()).collect();
        s.pattern = Some(s.build_pattern());
        s.slots = s.pattern.as_ref().map(SlotIndex::new);
        s.load_slots = s.load_block_slots();
        Ok(s)
    }

    /// The index layout.
    pub fn layout(&self) -> Layout {
        self.ev.layout.clone()
    }

    /// The model.
    pub fn model(&self) -> &Mechanism {
        &self.model
    }
}

impl DaeSystem for MultibodyDae {
    fn dim(&self) -> usize {
        self.ev.layout.dim()
    }

    fn residual(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        res: &mut [f64],
    ) -> Result<(), EvalError> {
        let lay = self.ev.layout.clone();
        let nb = lay.bodies();
        let (q, w) = (&y[..7 * nb], &y[7 * nb..13 * nb]);
        self.ev.set_state(q, w);
        self.ev.eval_constraints(t);
        self.ev.eval_loads(&self.model, t);
        res.iter_mut().for_each(|v| *v = 0.0);
        for b in 0..nb {
            let (qo, wo) = (lay.q(b), lay.w(b));
            let st = self.ev.states[b];
            let pdot = 0.5 * l_matrix(&st.p).transpose() * st.omega;
            let nu = y[lay.nu() + b];
            for k in 0..3 {
                res[qo + k] = yp[qo + k] - st.v[k];
            }
            for k in 0..4 {
                res[qo + 3 + k] = yp[qo + 3 + k] - pdot[k] + 2.0 * st.p[k] * nu;
            }
            let body = &self.model.bodies().bodies[b];
            let jw = body.inertia * st.omega;
            let wdot = Vector3::new(yp[wo + 3], yp[wo + 4], yp[wo + 5]);
            let lin = body.mass * Vector3::new(yp[wo], yp[wo + 1], yp[wo + 2]) - self.ev.loads[b].force;
            let rot = body.inertia * wdot + st.omega.cross(&jw) - self.ev.loads[b].torque;
            for k in 0..3 {
                res[wo + k] = lin[k];
                res[wo + 3 + k] = rot[k];
            }
            res[lay.nu() + b] = 0.5 * (st.p.norm_squared() - 1.0);
        }
        for (k, &(si, sj)) in self.ev.row_sides().iter().enumerate() {
            let lam = y[lay.lambda() + k];
            let mu = y[lay.mu() + k];
            let row = self.ev.rows[k];
            let mut vel = row.phi_t;
            for (side_i, b) in [(true, si), (false, sj)] {
                let Some(b) = b else { continue };
                let (dr, dp) = if side_i {
                    (row.d_ri, row.d_pi)
                } else {
                    (row.d_rj, row.d_pj)
                };
                let (bt, br) = self.ev.b_row(k, side_i, b);
                let (qo, wo) = (lay.q(b), lay.w(b));
                for c in 0..3 {
                    res[qo + c] += dr[c] * mu;
                    res[wo + c] += bt[c] * lam;
                    res[wo + 3 + c] += br[c] * lam;
                }
                for c in 0..4 {
                    res[qo + 3 + c] += dp[c] * mu;
                }
                let st = &self.ev.states[b];
                vel += bt.dot(&st.v) + br.dot(&st.omega);
            }
            res[lay.lambda() + k] = row.phi;
            res[lay.mu() + k] = vel;
        }
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        self.pattern.clone().unwrap_or_else(|| self.build_pattern())
    }

    fn jacobian_source(&self) -> JacobianSource {
        if self.options.analytic_jacobian {
            JacobianSource::Analytic
        } else {
            JacobianSource::FiniteDifference
        }
    }

    fn jacobian(
        &mut self,
        t: f64,
        y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        self.analytic_jacobian_values(t, y, alpha, values)
    }

    /// Per body its positions (r, p) with its normalisation multiplier ν: the kinematic and
    /// normalisation rows' block (α·I plus ½∂(L(p)ᵀω')/∂p and the normalisation's 2p) is
    /// invertible for α > 0, and it couples to other bodies only through the stabiliser's
    /// Hessian Σ μ·∇²Φ, which vanishes with μ on the solution. Eliminating these blocks
    /// leaves velocities and multipliers: 218 → 114 unknowns for the 63-DOF MR2120.
    fn eliminable_blocks(&self) -> Vec<Vec<usize>> {
        let lay = &self.ev.layout;
        (0..lay.bodies())
            .map(|b| (lay.q(b)..lay.q(b) + 7).chain([lay.nu() + b]).collect())
            .collect()
    }

    fn var_kinds(&self) -> Vec<VarKind> {
        let lay = self.ev.layout.clone();
        (0..lay.dim())
            .map(|i| {
                if i < 13 * lay.bodies() {
                    VarKind::Differential
                } else {
                    VarKind::Algebraic
                }
            })
            .collect()
    }

    fn component_name(&self, i: usize) -> String {
        self.name_of(i)
    }

    fn error_index(&self) -> Vec<u8> {
        let lay = self.ev.layout.clone();
        (0..lay.dim())
            .map(|i| {
                if self.options.velocities_index2 && (7 * lay.bodies()..13 * lay.bodies()).contains(&i) {
                    2
                } else {
                    1
                }
            })
            .collect()
    }
}

impl MultibodyDae {
    fn build_pattern(&self) -> CscPattern {
        let lay = self.ev.layout.clone();
        let nb = lay.bodies();
        // Which columns a body's dynamics rows (w rows) depend on, per other body: a constraint
        // between two bodies couples them through its Hessian (G(q)ᵀλ: positions only); a force
        // element through its load, which may depend on positions and velocities. A body's
        // kinematic rows (q' = T(p)·w + G(q)ᵀμ) depend on its own velocities only, and on
        // another body's positions only through a constraint's Hessian (G(q)ᵀμ), never
        // through a force element. Declaring no more than this keeps the LU fill down and the
        // matrix small (`tests/integration/multibody_jacobian.rs` checks that the pattern
        // covers every nonzero derivative).
        #[derive(Clone, Copy, PartialEq)]
        enum Coupling {
            Positions,
            Full,
        }
        // (other body, how its columns enter the dynamics rows, whether a constraint joins
        // the two: then its positions enter the kinematic rows too).
        let mut coupled: Vec<Vec<(usize, Coupling, bool)>> =
            (0..nb).map(|b| vec![(b, Coupling::Full, true)]).collect();
        let mut link = |a: usize, b: usize, kind: Coupling| match coupled[a].iter_mut().find(|e| e.0 == b) {
            Some(e) => {
                if kind == Coupling::Full {
                    e.1 = Coupling::Full;
                } else {
                    e.2 = true;
                }
            }
            None => coupled[a].push((b, kind, kind == Coupling::Positions)),
        };
        for &(si, sj) in self.ev.row_sides() {
            if let (Some(a), Some(b)) = (si, sj) {
                link(a, b, Coupling::Positions);
                link(b, a, Coupling::Positions);
            }
        }
        for bs in &self.force_bodies {
            for a in bs {
                for b in bs {
                    link(a.0, b.0, Coupling::Full);
                }
            }
        }
        let mut e = Vec::new();
        let body_cols = |b: usize| (lay.q(b)..lay.q(b) + 7).chain(lay.w(b)..lay.w(b) + 6);
        for b in 0..nb {
            for col in body_cols(b) {
                for row in lay.q(b)..lay.q(b) + 7 {
                    e.push((row, col));
                }
            }
            for &(c, kind, constrained) in &coupled[b] {
                // Positions of a coupled body enter the kinematic rows through the stabiliser
                // term G(q)ᵀμ (a constraint only) and the dynamics rows through G(q)ᵀλ and the
                // loads.
                for col in lay.q(c)..lay.q(c) + 7 {
                    if constrained {
                        for row in lay.q(b)..lay.q(b) + 7 {
                            e.push((row, col));
                        }
                    }
                    for row in lay.w(b)..lay.w(b) + 6 {
                        e.push((row, col));
                    }
                }
                if kind == Coupling::Full {
                    for col in lay.w(c)..lay.w(c) + 6 {
                        for row in lay.w(b)..lay.w(b) + 6 {
                            e.push((row, col));
                        }
                    }
                }
            }
            for k in 0..4 {
                e.push((lay.q(b) + 3 + k, lay.nu() + b));
                e.push((lay.nu() + b, lay.q(b) + 3 + k));
            }
        }
        for (k, &(si, sj)) in self.ev.row_sides().iter().enumerate() {
            for b in [si, sj].into_iter().flatten() {
                for col in body_cols(b) {
                    e.push((lay.lambda() + k, col));
                    e.push((lay.mu() + k, col));
                }
                for row in lay.q(b)..lay.q(b) + 7 {
                    e.push((row, lay.mu() + k));
                }
                for row in lay.w(b)..lay.w(b) + 6 {
                    e.push((row, lay.lambda() + k));
                }
            }
            // Keep the diagonal in the pattern (structurally zero for multipliers).
            e.push((lay.lambda() + k, lay.lambda() + k));
            e.push((lay.mu() + k, lay.mu() + k));
        }
        for b in 0..nb {
            e.push((lay.nu() + b, lay.nu() + b));
        }
        CscPattern::from_entries(lay.dim(), lay.dim(), e).expect("pattern indices are in range")
    }

    /// The value positions of every force element's load-derivative blocks (see
    /// `load_slots`); a pair with an entry outside the pattern is left out (its entries then
    /// go through the general path, which reports them).
    fn load_block_slots(&self) -> LoadSlots {
        let lay = &self.ev.layout;
        let nb = lay.bodies();
        let mut out = LoadSlots {
            pairs: vec![Vec::new(); nb],
            tables: Vec::new(),
        };
        let Some(slots) = self.slots.as_ref() else {
            return out;
        };
        for bs in &self.force_bodies {
            for br in bs {
                for bc in bs {
                    if out.get(br.0, bc.0).is_some() {
                        continue;
                    }
                    let mut tab = [0usize; 78];
                    let mut complete = true;
                    for r in 0..6 {
                        for c in 0..13 {
                            let gc = if c < 7 {
                                lay.q(bc.0) + c
                            } else {
                                lay.w(bc.0) + c - 7
                            };
                            match slots.get(lay.w(br.0) + r, gc) {
                                Some(k) => tab[6 * c + r] = k,
                                None => complete = false,
                            }
                        }
                    }
                    if complete {
                        let k = out.tables.len();
                        if let Some(p) = out.pairs.get_mut(br.0) {
                            p.push((bc.0, k));
                            out.tables.push(tab);
                        }
                    }
                }
            }
        }
        out
    }

    fn name_of(&self, i: usize) -> String {
        let lay = self.ev.layout.clone();
        let body = |b: usize| self.model.bodies().bodies[b].name.clone();
        if i < 7 * lay.bodies() {
            let c = ["x", "y", "z", "e0", "e1", "e2", "e3"][i % 7];
            format!("body '{}' {c}", body(i / 7))
        } else if i < 13 * lay.bodies() {
            let j = i - 7 * lay.bodies();
            let c = ["vx", "vy", "vz", "wx'", "wy'", "wz'"][j % 6];
            format!("body '{}' {c}", body(j / 6))
        } else if i < lay.mu() {
            format!("force of {}", self.names[i - lay.lambda()])
        } else if i < lay.nu() {
            format!("stabiliser of {}", self.names[i - lay.mu()])
        } else {
            format!("normalisation of body '{}'", body(i - lay.nu()))
        }
    }

    /// Fills the analytic iteration matrix dF/dy + α·dF/dy' on the pattern.
    fn analytic_jacobian_values(
        &mut self,
        t: f64,
        y: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let lay = self.ev.layout.clone();
        let nb = lay.bodies();
        self.ev.set_state(&y[..7 * nb], &y[7 * nb..13 * nb]);
        self.ev.eval_constraints(t);
        values.iter_mut().for_each(|v| *v = 0.0);
        // The force elements' blocks and the constraints' Hessians go into reused buffers
        // (put back at the end; an evaluation that fails drops them, the next makes them anew).
        let mut blocks = std::mem::take(&mut self.load_blocks);
        let mut hs = std::mem::take(&mut self.hessians);
        let Some(slots) = self.slots.as_ref() else {
            return Err(EvalError::Fatal("the Jacobian pattern was not built".into()));
        };
        // First entry outside the declared pattern (a bug of the formulation, reported as an
        // error rather than a panic).
        let mut sc = Scatter {
            slots,
            values,
            outside: None,
        };
        let rest = self.at_rest;
        // Per body: kinematics, inertia, normalisation.
        for b in (0..nb).filter(|_| !rest) {
            let (qo, wo) = (lay.q(b), lay.w(b));
            let st = self.ev.states[b];
            let body = &self.model.bodies().bodies[b];
            let nu = y[lay.nu() + b];
            for k in 0..3 {
                sc.add(qo + k, qo + k, alpha);
                sc.add(qo + k, wo + k, -1.0);
                sc.add(wo + k, wo + k, alpha * body.mass);
            }
            let w = lt_omega_derivative(&st.omega);
            let lt = l_matrix(&st.p).transpose();
            for r in 0..4 {
                for c in 0..4 {
                    let diag = if r == c { alpha + 2.0 * nu } else { 0.0 };
                    sc.add(qo + 3 + r, qo + 3 + c, diag - 0.5 * w[(r, c)]);
                }
                for c in 0..3 {
                    sc.add(qo + 3 + r, wo + 3 + c, -0.5 * lt[(r, c)]);
                }
                sc.add(qo + 3 + r, lay.nu() + b, 2.0 * st.p[r]);
                sc.add(lay.nu() + b, qo + 3 + r, st.p[r]);
            }
            let jw = body.inertia * st.omega;
            let gyro = skew(&st.omega) * body.inertia - skew(&jw);
            for r in 0..3 {
                for c in 0..3 {
                    sc.add(
                        wo + 3 + r,
                        wo + 3 + c,
                        alpha * body.inertia[(r, c)] + gyro[(r, c)],
                    );
                }
            }
        }
        // Per constraint block: gradients, Hessians.
        let ground = Pose::ground();
        let mut k0 = 0;
        for blk in &self.ev.blocks {
            let n = blk.prim.len();
            let (si, sj) = (Evaluator::side(blk.i), Evaluator::side(blk.j));
            let pi = si.map(|b| self.ev.poses[b]).unwrap_or(ground);
            let pj = sj.map(|b| self.ev.poses[b]).unwrap_or(ground);
            hs.resize(n, Hess14::zeros());
            blk.prim.hessians(&pi, &pj, t, &mut hs);
            let gt = blk.prim.phi_t_gradient(&pi, &pj, t);
            // Global column of each of the 14 local coordinates (None for the ground).
            let mut col = [None; 14];
            let mut qdot = [0.0; 14];
            for (side, off) in [(si, 0usize), (sj, 7usize)] {
                if let Some(b) = side {
                    let st = &self.ev.states[b];
                    let pd = 0.5 * l_matrix(&st.p).transpose() * st.omega;
                    for c in 0..7 {
                        col[off + c] = Some(lay.q(b) + c);
                    }
                    qdot[off..off + 3].copy_from_slice(st.v.as_slice());
                    qdot[off + 3..off + 7].copy_from_slice(pd.as_slice());
                }
            }
            let mut h_mu = Hess14::zeros();
            let mut h_lam = Hess14::zeros();
            let mut dp_lam = [Vector4::zeros(); 2];
            for e in 0..n {
                let k = k0 + e;
                let row = self.ev.rows[k];
                let (lam, mu) = (y[lay.lambda() + k], y[lay.mu() + k]);
                // h_μ += μ·∇²Φ_e and h_λ += λ·∇²Φ_e in one pass over the slices (nalgebra's
                // `h += H·μ` makes a 14 × 14 temporary per product).
                for ((m, l), &h) in h_mu
                    .as_mut_slice()
                    .iter_mut()
                    .zip(h_lam.as_mut_slice().iter_mut())
                    .zip(hs[e].as_slice())
                {
                    *m += h * mu;
                    *l += h * lam;
                }
                dp_lam[0] += row.d_pi * lam;
                dp_lam[1] += row.d_pj * lam;
                let mut g = [0.0; 14];
                g[0..3].copy_from_slice(row.d_ri.as_slice());
                g[3..7].copy_from_slice(row.d_pi.as_slice());
                g[7..10].copy_from_slice(row.d_rj.as_slice());
                g[10..14].copy_from_slice(row.d_pj.as_slice());
                // Position constraint row and the μ, λ columns.
                for c in 0..14 {
                    if let Some(gc) = col[c] {
                        sc.add(lay.lambda() + k, gc, g[c]);
                        if !rest {
                            sc.add(gc, lay.mu() + k, g[c]);
                        }
                    }
                }
                if rest {
                    // The momentum rows' λ columns only.
                    for (side, off, dp) in [(si, 0usize, row.d_pi), (sj, 7usize, row.d_pj)] {
                        let Some(b) = side else { continue };
                        let br = 0.5 * l_matrix(&self.ev.states[b].p) * dp;
                        for c in 0..3 {
                            sc.add(lay.w(b) + c, lay.lambda() + k, g[off + c]);
                            sc.add(lay.w(b) + 3 + c, lay.lambda() + k, br[c]);
                        }
                    }
                    continue;
                }
                // Velocity constraint row: d/dw and d/dq.
                let hq = hs[e] * nalgebra::SVector::<f64, 14>::from_row_slice(&qdot);
                for (side, off, dp) in [(si, 0usize, row.d_pi), (sj, 7usize, row.d_pj)] {
                    let Some(b) = side else { continue };
                    let st = &self.ev.states[b];
                    let l = l_matrix(&st.p);
                    let br = 0.5 * l * dp;
                    let dr = Vector3::new(g[off], g[off + 1], g[off + 2]);
                    let mdp = 0.5 * l_times_d_derivative(&dp).transpose() * st.omega;
                    for c in 0..3 {
                        sc.add(lay.mu() + k, lay.w(b) + c, dr[c]);
                        sc.add(lay.mu() + k, lay.w(b) + 3 + c, br[c]);
                        sc.add(lay.w(b) + c, lay.lambda() + k, dr[c]);
                        sc.add(lay.w(b) + 3 + c, lay.lambda() + k, br[c]);
                    }
                    for c in 0..4 {
                        sc.add(lay.mu() + k, lay.q(b) + 3 + c, mdp[c]);
                    }
                }
                for c in 0..14 {
                    if let Some(gc) = col[c] {
                        let extra = gt.map(|v| v[c]).unwrap_or(0.0);
                        sc.add(lay.mu() + k, gc, hq[c] + extra);
                    }
                }
            }
            // Stabilisation rows: ∂(Φ_qᵀμ)/∂q = Σ μ_e ∇²Φ_e.
            for r in (0..14).filter(|_| !rest) {
                let Some(gr) = col[r] else { continue };
                for c in 0..14 {
                    if let Some(gc) = col[c] {
                        sc.add(gr, gc, h_mu[(r, c)]);
                    }
                }
            }
            // Force rows: ∂(Bᵀλ)/∂q.
            for (side, off, si_idx) in [(si, 0usize, 0usize), (sj, 7usize, 1usize)] {
                let Some(b) = side else { continue };
                let l = l_matrix(&self.ev.states[b].p);
                for c in 0..14 {
                    let Some(gc) = col[c] else { continue };
                    let hp = Vector4::new(
                        h_lam[(off + 3, c)],
                        h_lam[(off + 4, c)],
                        h_lam[(off + 5, c)],
                        h_lam[(off + 6, c)],
                    );
                    let rot = 0.5 * l * hp;
                    for r in 0..3 {
                        sc.add(lay.w(b) + r, gc, h_lam[(off + r, c)]);
                        sc.add(lay.w(b) + 3 + r, gc, rot[r]);
                    }
                }
                let m = 0.5 * l_times_d_derivative(&dp_lam[si_idx]);
                for r in 0..3 {
                    for c in 0..4 {
                        sc.add(lay.w(b) + 3 + r, lay.q(b) + 3 + c, m[(r, c)]);
                    }
                }
            }
            k0 += n;
        }
        // Force elements: their exact load Jacobians, else central differences of their
        // loads over their bodies' states (one scratch copy of the states and two load
        // buffers, made on first use and kept between evaluations).
        let model = &self.model;
        let mut scratch = self.fd_scratch.take();
        // The scratch states are this evaluation's (copied at the first element differenced).
        let mut scratch_current = false;
        for ((_, f), declared) in model.forces().zip(&self.force_bodies) {
            blocks.clear();
            let exact = if rest {
                f.load_jacobian_at_rest(t, &self.ev.states, &mut blocks)
            } else {
                f.load_jacobian(t, &self.ev.states, &mut blocks)
            };
            // Columns differentiated: positions and velocities, or positions only at rest.
            let columns = if rest { 7 } else { 13 };
            if exact {
                for blk in &blocks {
                    if let Some(h) = [blk.loaded, blk.wrt].into_iter().find(|h| !declared.contains(h)) {
                        let body = model
                            .body(h)
                            .map(|b| format!("body '{}'", b.name))
                            .unwrap_or_else(|| format!("body handle {}", h.index()));
                        return Err(EvalError::Fatal(format!(
                            "force element '{}': its load Jacobian names {body}, which its bodies() does not list",
                            f.name()
                        )));
                    }
                }
                for blk in &blocks {
                    let (br, bc) = (blk.loaded.0, blk.wrt.0);
                    if let Some(tab) = self.load_slots.get(br, bc) {
                        // The block's place in the values, found once (`load_slots`), in
                        // the block's own column-major order.
                        for (&k, &d) in tab[..6 * columns].iter().zip(blk.d.as_slice()) {
                            sc.values[k] -= d;
                        }
                        continue;
                    }
                    for c in 0..columns {
                        let gc = if c < 7 { lay.q(bc) + c } else { lay.w(bc) + c - 7 };
                        for r in 0..3 {
                            sc.add(lay.w(br) + r, gc, -blk.d[(r, c)]);
                            sc.add(lay.w(br) + 3 + r, gc, -blk.d[(3 + r, c)]);
                        }
                    }
                }
                continue;
            }
            let (states, loads_p, loads_m) = scratch.get_or_insert_with(|| {
                (
                    self.ev.states.clone(),
                    vec![BodyLoad::default(); nb],
                    vec![BodyLoad::default(); nb],
                )
            });
            if !scratch_current {
                states.copy_from_slice(&self.ev.states);
                scratch_current = true;
            }
            for &bc in declared {
                let saved = states[bc.0];
                for c in 0..columns {
                    // Increments far below contact penetrations (~1e-8..1e-6 m): a larger one
                    // would straddle contact onset and corrupt the derivative.
                    let h = self.options.force_fd_step
                        * (1.0
                            + if c < 7 {
                                y[lay.q(bc.0) + c].abs()
                            } else {
                                y[lay.w(bc.0) + c - 7].abs()
                            });
                    for (sign, loads) in [(1.0, &mut *loads_p), (-1.0, &mut *loads_m)] {
                        for &b in declared {
                            loads[b.0] = BodyLoad::default();
                        }
                        let st = &mut states[bc.0];
                        *st = saved;
                        match c {
                            0..=2 => st.r[c] += sign * h,
                            3..=6 => {
                                st.p[c - 3] += sign * h;
                                st.a = super::rotation::rotation(&st.p);
                            }
                            7..=9 => st.v[c - 7] += sign * h,
                            _ => st.omega[c - 10] += sign * h,
                        }
                        f.apply(t, states, loads);
                    }
                    states[bc.0] = saved;
                    let gc = if c < 7 {
                        lay.q(bc.0) + c
                    } else {
                        lay.w(bc.0) + c - 7
                    };
                    for &br in declared {
                        let df = (loads_p[br.0].force - loads_m[br.0].force) / (2.0 * h);
                        let dn = (loads_p[br.0].torque - loads_m[br.0].torque) / (2.0 * h);
                        for r in 0..3 {
                            sc.add(lay.w(br.0) + r, gc, -df[r]);
                            sc.add(lay.w(br.0) + 3 + r, gc, -dn[r]);
                        }
                    }
                }
            }
        }
        let outside = sc.outside;
        self.load_blocks = blocks;
        self.hessians = hs;
        self.fd_scratch = scratch;
        match outside {
            Some((r, c)) => Err(EvalError::Fatal(format!(
                "Jacobian entry ({}, {}) outside the declared pattern",
                self.name_of(r),
                self.name_of(c)
            ))),
            None => Ok(()),
        }
    }
}
