//! Quasi-static equilibrium of a mechanism: the configuration at which the applied loads
//! (gravity, force elements — contact in clearance joints included) balance the constraint
//! reactions with the drivers held at time t, found without integrating any motion.
//!
//! The unknowns are positions and constraint forces only — per body its position r and its
//! rotation θ from the starting orientation, and the multipliers λ — and the equations are
//! the momentum rows of the equations of motion ([`MultibodyDae`]) at rest with the position
//! constraints: 6 unknowns per body and one per constraint, where the DAE has 14 and 2 (its
//! velocities, stabilisation and normalisation multipliers all vanish at rest). They are
//! solved by pseudo-transient continuation ([`crate::dae::steady_state`]) on an overdamped
//! pseudo-motion ζ·M·ẋ = (net load): backward-Euler steps of growing length, Newton's method
//! in the limit. A body that floats inside a clearance (no load pushes it against either
//! side) keeps a regularising term ζ·M/τ and stays where the iteration leaves it, as a real
//! body would stay where it came to rest; any configuration the loads do push converges to
//! the tolerance of [`StaticsOptions::steady`].
//!
//! Drivers are evaluated at the given time: for an equilibrium their laws must be at rest
//! there (constant laws, or a time at which the prescribed motion is stationary).

use super::analysis::{Analysis, AssemblyOptions};
use super::data::MechanismData;
use super::error::ModelError;
use super::formulation::{FormulationOptions, MultibodyDae};
use super::model::Mechanism;
use super::rotation::{l_matrix, skew};
use super::simulation::Sample;
use crate::dae::{
    AbsTol, DaeSystem, EvalError, JacobianSource, SteadyOptions, SteadySolver, SteadyStats, VarKind,
};
use crate::sparse::CscPattern;
use nalgebra::{Matrix3, Matrix4x3, Vector3, Vector4};
use std::sync::Arc;

/// [`SteadyOptions::reject_factor`] of [`StaticsOptions::default`]: a pseudo-step may raise
/// the residual up to 10⁴ times the smallest so far. A body crossing its clearance meets
/// the far wall with a large penetration that the next steps resolve; rejecting such steps
/// (the generic default, 100) throws away their factorisations. Measured on the static
/// Table 3 (117 equilibria): accepted pseudo-steps 1 736 → 1 492, CPU time −18 %; 10⁵ is
/// slower again.
pub const STATICS_REJECT_FACTOR: f64 = 1e4;

/// Every tunable of [`static_equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct StaticsOptions {
    /// The pseudo-transient continuation. Defaults: [`SteadyOptions::default`] with
    /// rtol 1e-8 and atol 1e-11 (m, rad: a hundredth of a micrometre), τ_0 = 10 ms, settling
    /// time 1000 s, at most 500 pseudo-steps, reject factor [`STATICS_REJECT_FACTOR`]. A scalar atol gives the rotation unknowns
    /// (which start at zero) rtol + atol, as unit Euler parameters would be weighed; a
    /// vector atol has one entry per unknown of the equilibrium equations (per body x, y, z,
    /// θx', θy', θz', then the multipliers).
    pub steady: SteadyOptions,
    /// Position assembly of the starting configuration.
    pub assembly: AssemblyOptions,
    /// The equations of motion (analytic Jacobian by default).
    pub formulation: FormulationOptions,
    /// Rate ζ of the pseudo-motion, 1/s: each body moves as ζ·m·ṙ = f and ζ·J'·θ̇' = n' under
    /// its net load (f, n') while the iteration moves it — overdamped, so it does not bounce
    /// between contacts. It vanishes at rest and does not change the equilibrium; with τ it
    /// sets how far a first step moves a body that nothing holds yet (ζ·m/τ is the
    /// regularising stiffness). Default 20 (measured on the MR2120's static Table 3, all 117
    /// equilibria: 1 736 pseudo-steps; 2 → 1 903, 200 → 1 814; `lash bench statics`).
    pub relaxation_rate: f64,
}

impl Default for StaticsOptions {
    fn default() -> Self {
        Self {
            steady: SteadyOptions {
                rtol: 1e-8,
                atol: AbsTol::Scalar(1e-11),
                tau0: 1e-2,
                settle_time: 1e3,
                max_iterations: 500,
                reject_factor: STATICS_REJECT_FACTOR,
                ..SteadyOptions::default()
            },
            assembly: AssemblyOptions::default(),
            formulation: FormulationOptions::default(),
            relaxation_rate: 20.0,
        }
    }
}

/// A static equilibrium: the configuration (as a [`Sample`] with zero velocities, so every
/// typed accessor of a sample reads it) and the work it took.
#[derive(Debug, Clone)]
pub struct Equilibrium {
    /// Positions, zero velocities and the constraint reactions (multipliers) at equilibrium.
    pub sample: Sample,
    /// Work of the pseudo-transient continuation.
    pub stats: SteadyStats,
}

/// The static equilibrium of `model` at time `t` (drivers evaluated there), starting from
/// `start` (positions per body, as in [`Sample::q`]; a previous equilibrium is a good warm
/// start) or, when `None`, from the model's initial poses assembled onto the constraints.
/// One solve of a [`Statics`] set up for the model; set one up and keep it to solve many
/// load cases of one model.
///
/// Errors: [`ModelError::Statics`] naming the components (bodies' coordinates) still moving
/// when the iteration budget is spent; [`ModelError::AssemblyFailed`] when the starting
/// configuration cannot be assembled; [`ModelError::BadElement`]/[`ModelError::BadBody`] for
/// an invalid model; a `start` of the wrong length is [`ModelError::BadBody`] on the model.
pub fn static_equilibrium(
    model: &Arc<Mechanism>,
    t: f64,
    start: Option<&[f64]>,
    opts: &StaticsOptions,
) -> Result<Equilibrium, ModelError> {
    Statics::new(model, opts)?.solve(t, start)
}

/// The static-equilibrium solver of one model, set up once (its equations, their Jacobian
/// pattern and its symbolic factorisation, the assembly analysis) and used for many solves:
/// other times, other starts, or other values of loads the model reads between solves (a
/// force element whose load the caller sets, as the load cases of a pose share one model).
/// The model itself is constant: a solver of another model is set up anew.
#[derive(Debug)]
pub struct Statics {
    model: Arc<Mechanism>,
    analysis: Analysis,
    data: MechanismData,
    equations: Balance,
    solver: SteadySolver,
}

impl Statics {
    /// Sets up the solver for `model`. Errors: [`ModelError::BadElement`]/
    /// [`ModelError::BadBody`] for an invalid model, [`ModelError::Statics`] for bad options.
    pub fn new(model: &Arc<Mechanism>, opts: &StaticsOptions) -> Result<Self, ModelError> {
        if !(opts.relaxation_rate > 0.0 && opts.relaxation_rate.is_finite()) {
            return Err(ModelError::Statics(crate::dae::DaeError::InvalidInput(format!(
                "relaxation_rate must be > 0 and finite (it regularises bodies nothing holds), got {}",
                opts.relaxation_rate
            ))));
        }
        let lay = model.layout();
        let analysis = Analysis::with_options(model, opts.assembly)?;
        let data = MechanismData::new(model);
        let equations = Balance::new(
            MultibodyDae::with_options(model.clone(), opts.formulation)?,
            model,
            opts.relaxation_rate,
        );
        let mut steady = opts.steady.clone();
        if let AbsTol::Scalar(a) = steady.atol {
            // Rotations from the start are near zero: weigh them as the DAE weighs unit Euler
            // parameters (rtol·1 + atol), not by atol alone.
            let nb = lay.bodies();
            steady.atol = AbsTol::Vector(
                (0..equations.dim())
                    .map(|i| {
                        if i < 6 * nb && i % 6 >= 3 {
                            steady.rtol + a
                        } else {
                            a
                        }
                    })
                    .collect(),
            );
        }
        let solver = SteadySolver::new(&equations, &steady).map_err(ModelError::Statics)?;
        Ok(Self {
            model: model.clone(),
            analysis,
            data,
            equations,
            solver,
        })
    }

    /// The equilibrium at time `t` from `start` (as [`static_equilibrium`]).
    pub fn solve(&mut self, t: f64, start: Option<&[f64]>) -> Result<Equilibrium, ModelError> {
        let lay = self.model.layout();
        let q0 = match start {
            Some(q) if q.len() == lay.q_len() => q.to_vec(),
            Some(q) => {
                return Err(ModelError::BadBody {
                    body: "(start configuration)".into(),
                    reason: format!(
                        "{} position coordinates given, the model has {}",
                        q.len(),
                        lay.q_len()
                    ),
                })
            }
            None => self
                .analysis
                .assemble(&self.model, &mut self.data, t, &self.model.initial_guess().0)?,
        };
        let mut x = self.equations.start(&q0);
        let stats = self
            .solver
            .solve(&mut self.equations, t, &mut x, &[])
            .map_err(ModelError::Statics)?;
        let q = self.equations.positions(&x);
        let singularity = self.analysis.singularity_in(&mut self.data.ev, t, &q);
        Ok(Equilibrium {
            sample: Sample {
                t,
                q,
                w: vec![0.0; lay.w_len()],
                lambda: x[6 * lay.bodies()..].to_vec(),
                singularity,
            },
            stats,
        })
    }
}

/// The equilibrium equations in positions and multipliers only, with a first-order
/// pseudo-motion ζ·M·ẋ + R(x) = 0: the unknowns x of [`static_equilibrium`].
///
/// x = (r_b, θ_b per body, λ): θ_b is body b's rotation (rad, body frame) from its starting
/// orientation p_b⁰, p_b = p_b⁰ ⊗ exp(θ_b/2), so there is no normalisation constraint. The
/// rows are the momentum rows of [`MultibodyDae`] at rest (−f − m·g + Φ_rᵀλ, −n' + Φ_π'ᵀλ)
/// and the position constraints Φ(q, t): the DAE's own residual and analytic Jacobian
/// evaluated at zero velocities, its position columns carried to θ by ∂p/∂θ = ½·L(p)ᵀ·J_r(θ)
/// (J_r the right Jacobian of the rotation group). Velocities, the stabilisation
/// multipliers μ and the normalisation multipliers ν are zero at rest and drop out: the
/// system has 6 unknowns per body and one per constraint, against 14 and 2 of the DAE.
#[derive(Debug)]
struct Balance {
    inner: MultibodyDae,
    rate: f64,
    /// Per body: mass and body-frame inertia (the pseudo-motion's metric).
    bodies: Vec<(f64, Matrix3<f64>)>,
    /// Per body: the starting orientation p⁰.
    p_ref: Vec<Vector4<f64>>,
    /// Constraint equations.
    m: usize,
    /// The reduced pattern.
    pattern: CscPattern,
    /// Per entry of the DAE's pattern that the reduced system keeps: its slot there and
    /// where it goes.
    entries: Vec<(usize, Target)>,
    /// Per body: the slots of the pseudo-motion's metric (3 translational, 3 × 3 rotational).
    metric: Vec<[usize; 12]>,
    /// Work vectors of the DAE's size: unknowns, zero derivatives, residual, Jacobian values.
    y: Vec<f64>,
    zero: Vec<f64>,
    r: Vec<f64>,
    values: Vec<f64>,
}

/// Where an entry of the DAE's Jacobian goes in the reduced one.
#[derive(Debug, Clone, Copy)]
enum Target {
    /// Unchanged, to this slot.
    Direct(usize),
    /// A derivative by Euler parameter `c` of body `body`: times ∂p_c/∂θ_k to slot k.
    Rotation {
        body: usize,
        c: usize,
        slots: [usize; 3],
    },
}

/// p ⊗ q (Hamilton product): A(p ⊗ q) = A(p)·A(q).
fn compose(p: &Vector4<f64>, q: &Vector4<f64>) -> Vector4<f64> {
    let (a0, a) = (p[0], Vector3::new(p[1], p[2], p[3]));
    let (b0, b) = (q[0], Vector3::new(q[1], q[2], q[3]));
    let v = a0 * b + b0 * a + a.cross(&b);
    Vector4::new(a0 * b0 - a.dot(&b), v.x, v.y, v.z)
}

/// Euler parameters of the rotation vector θ (rad): exp(θ/2).
fn exp_rotation(th: &Vector3<f64>) -> Vector4<f64> {
    let phi = th.norm();
    let (c, s) = if phi < 1e-4 {
        (1.0 - phi * phi / 8.0, 0.5 - phi * phi / 48.0)
    } else {
        ((0.5 * phi).cos(), (0.5 * phi).sin() / phi)
    };
    Vector4::new(c, s * th.x, s * th.y, s * th.z)
}

/// The right Jacobian of the rotation group at θ: the body angular velocity of
/// p⁰ ⊗ exp(θ/2) is J_r(θ)·θ̇.
fn right_jacobian(th: &Vector3<f64>) -> Matrix3<f64> {
    let phi = th.norm();
    let (a, b) = if phi < 1e-4 {
        (0.5 - phi * phi / 24.0, 1.0 / 6.0 - phi * phi / 120.0)
    } else {
        (
            (1.0 - phi.cos()) / (phi * phi),
            (phi - phi.sin()) / (phi * phi * phi),
        )
    };
    let k = skew(th);
    Matrix3::identity() - a * k + b * k * k
}

impl Balance {
    fn new(mut inner: MultibodyDae, model: &Mechanism, rate: f64) -> Self {
        inner.at_rest = true;
        let lay = model.layout();
        let nb = lay.bodies();
        let m = lay.constraints();
        let full = inner.jacobian_pattern();
        let n = 6 * nb + m;
        // Reduced row and column of each of the DAE's rows and columns.
        let mut row = vec![None; full.nrows()];
        for b in 0..nb {
            for k in 0..6 {
                row[lay.w(b) + k] = Some(6 * b + k);
            }
        }
        for k in 0..m {
            row[lay.lambda() + k] = Some(6 * nb + k);
        }
        enum Col {
            Direct(usize),
            Euler(usize, usize),
        }
        let mut col: Vec<Option<Col>> = (0..full.ncols()).map(|_| None).collect();
        for b in 0..nb {
            for k in 0..3 {
                col[lay.q(b) + k] = Some(Col::Direct(6 * b + k));
            }
            for c in 0..4 {
                col[lay.q(b) + 3 + c] = Some(Col::Euler(b, c));
            }
        }
        for k in 0..m {
            col[lay.lambda() + k] = Some(Col::Direct(6 * nb + k));
        }
        let mut e = vec![];
        for c in 0..full.ncols() {
            for &r in full.col_rows(c) {
                match (row[r], &col[c]) {
                    (Some(i), Some(Col::Direct(j))) => e.push((i, *j)),
                    (Some(i), Some(Col::Euler(b, _))) => e.extend((0..3).map(|k| (i, 6 * b + 3 + k))),
                    _ => {}
                }
            }
        }
        for b in 0..nb {
            for i in 0..6 {
                for j in 0..6 {
                    if (i < 3 && i == j) || (i >= 3 && j >= 3) {
                        e.push((6 * b + i, 6 * b + j));
                    }
                }
            }
        }
        // Keep the diagonal (structurally zero for multipliers).
        e.extend((0..m).map(|k| (6 * nb + k, 6 * nb + k)));
        let pattern = CscPattern::from_entries(n, n, e).expect("reduced pattern indices are in range");
        let slot = |r: usize, c: usize| pattern.find(r, c).expect("entry declared above");
        let mut entries = vec![];
        for c in 0..full.ncols() {
            for k in full.col_range(c) {
                let r = full.row_idx()[k];
                match (row[r], &col[c]) {
                    (Some(i), Some(Col::Direct(j))) => entries.push((k, Target::Direct(slot(i, *j)))),
                    (Some(i), Some(Col::Euler(b, cc))) => entries.push((
                        k,
                        Target::Rotation {
                            body: *b,
                            c: *cc,
                            slots: [0, 1, 2].map(|kk| slot(i, 6 * b + 3 + kk)),
                        },
                    )),
                    _ => {}
                }
            }
        }
        let metric = (0..nb)
            .map(|b| {
                let mut s = [0; 12];
                for k in 0..3 {
                    s[k] = slot(6 * b + k, 6 * b + k);
                }
                for r in 0..3 {
                    for c in 0..3 {
                        s[3 + 3 * r + c] = slot(6 * b + 3 + r, 6 * b + 3 + c);
                    }
                }
                s
            })
            .collect();
        let bodies = model.bodies().iter().map(|(_, b)| (b.mass, b.inertia)).collect();
        let p_ref = vec![Vector4::new(1.0, 0.0, 0.0, 0.0); nb];
        let dim = inner.dim();
        let nnz = full.nnz();
        Self {
            inner,
            rate,
            bodies,
            p_ref,
            m,
            pattern,
            entries,
            metric,
            y: vec![0.0; dim],
            zero: vec![0.0; dim],
            r: vec![0.0; dim],
            values: vec![0.0; nnz],
        }
    }

    /// The starting unknowns: positions `q0` (θ = 0: the orientations of `q0` become the
    /// reference p⁰), multipliers zero.
    fn start(&mut self, q0: &[f64]) -> Vec<f64> {
        let nb = self.bodies.len();
        let mut x = vec![0.0; 6 * nb + self.m];
        for b in 0..nb {
            x[6 * b..6 * b + 3].copy_from_slice(&q0[7 * b..7 * b + 3]);
            let o = 7 * b + 3;
            self.p_ref[b] = Vector4::new(q0[o], q0[o + 1], q0[o + 2], q0[o + 3]).normalize();
        }
        x
    }

    /// Body b's Euler parameters at x.
    fn orientation(&self, x: &[f64], b: usize) -> Vector4<f64> {
        let th = Vector3::new(x[6 * b + 3], x[6 * b + 4], x[6 * b + 5]);
        compose(&self.p_ref[b], &exp_rotation(&th))
    }

    /// Positions (per body r, p) at x.
    fn positions(&self, x: &[f64]) -> Vec<f64> {
        let nb = self.bodies.len();
        let mut q = vec![0.0; 7 * nb];
        for b in 0..nb {
            q[7 * b..7 * b + 3].copy_from_slice(&x[6 * b..6 * b + 3]);
            q[7 * b + 3..7 * b + 7].copy_from_slice(self.orientation(x, b).as_slice());
        }
        q
    }

    /// Fills the DAE's unknowns from x: positions, λ; velocities, μ and ν zero.
    fn expand(&mut self, x: &[f64]) {
        let lay = self.inner.layout();
        let nb = self.bodies.len();
        self.y.iter_mut().for_each(|v| *v = 0.0);
        let q = self.positions(x);
        self.y[..7 * nb].copy_from_slice(&q);
        self.y[lay.y_lambda()].copy_from_slice(&x[6 * nb..]);
    }
}

impl DaeSystem for Balance {
    fn dim(&self) -> usize {
        6 * self.bodies.len() + self.m
    }
    fn residual(&mut self, t: f64, x: &[f64], xp: &[f64], p: &[f64], r: &mut [f64]) -> Result<(), EvalError> {
        self.expand(x);
        self.inner.residual(t, &self.y, &self.zero, p, &mut self.r)?;
        let lay = self.inner.layout();
        let nb = self.bodies.len();
        for (b, &(mass, j)) in self.bodies.iter().enumerate() {
            let o = 6 * b;
            let jw = j * Vector3::new(xp[o + 3], xp[o + 4], xp[o + 5]);
            for k in 0..3 {
                r[o + k] = self.r[lay.w(b) + k] + self.rate * mass * xp[o + k];
                r[o + 3 + k] = self.r[lay.w(b) + 3 + k] + self.rate * jw[k];
            }
        }
        r[6 * nb..].copy_from_slice(&self.r[lay.lambda()..lay.lambda() + self.m]);
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        self.pattern.clone()
    }
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::Analytic
    }
    fn jacobian(
        &mut self,
        t: f64,
        x: &[f64],
        _xp: &[f64],
        p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        self.expand(x);
        self.inner
            .jacobian(t, &self.y, &self.zero, p, 0.0, &mut self.values)?;
        // ∂p/∂θ = ½·L(p)ᵀ·J_r(θ) per body.
        let dp: Vec<Matrix4x3<f64>> = (0..self.bodies.len())
            .map(|b| {
                let th = Vector3::new(x[6 * b + 3], x[6 * b + 4], x[6 * b + 5]);
                0.5 * l_matrix(&self.orientation(x, b)).transpose() * right_jacobian(&th)
            })
            .collect();
        values.iter_mut().for_each(|v| *v = 0.0);
        for &(k, target) in &self.entries {
            let v = self.values[k];
            if v == 0.0 {
                continue;
            }
            match target {
                Target::Direct(s) => values[s] += v,
                Target::Rotation { body, c, slots } => {
                    for (kk, s) in slots.into_iter().enumerate() {
                        values[s] += v * dp[body][(c, kk)];
                    }
                }
            }
        }
        for (&(mass, j), s) in self.bodies.iter().zip(&self.metric) {
            for slot in &s[..3] {
                values[*slot] += alpha * self.rate * mass;
            }
            for r in 0..3 {
                for c in 0..3 {
                    values[s[3 + 3 * r + c]] += alpha * self.rate * j[(r, c)];
                }
            }
        }
        Ok(())
    }
    fn var_kinds(&self) -> Vec<VarKind> {
        (0..self.dim())
            .map(|i| {
                if i < 6 * self.bodies.len() {
                    VarKind::Differential
                } else {
                    VarKind::Algebraic
                }
            })
            .collect()
    }
    fn component_name(&self, i: usize) -> String {
        let nb = self.bodies.len();
        let lay = self.inner.layout();
        if i < 6 * nb {
            let (b, k) = (i / 6, i % 6);
            let name = self.inner.component_name(lay.q(b));
            let body = name.rsplit_once(' ').map_or(name.as_str(), |(h, _)| h);
            format!("{body} {}", ["x", "y", "z", "θx'", "θy'", "θz'"][k])
        } else {
            self.inner.component_name(lay.lambda() + i - 6 * nb)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::{
        Attach, BodyHandle, BodyLoad, BodyState, ForceElement, RigidBody, SpringDamper, STANDARD_GRAVITY,
    };
    use nalgebra::{Matrix3, Vector3};

    /// The rotation unknowns: p⁰ ⊗ exp(θ/2) composes rotation matrices in body-frame order,
    /// and ∂p/∂θ = ½·L(p)ᵀ·J_r(θ) matches central differences at a finite θ.
    #[test]
    fn rotation_unknowns_compose_and_differentiate() {
        use crate::multibody::rotation::{from_axis_angle, rotation};
        let p0 = from_axis_angle(&Vector3::new(0.3, -1.0, 0.4), 0.7);
        let th = Vector3::new(0.2, -0.1, 0.35);
        let p = compose(&p0, &exp_rotation(&th));
        let expected = rotation(&p0) * rotation(&exp_rotation(&th));
        assert!((rotation(&p) - expected).norm() < 1e-14);
        let dp = 0.5 * l_matrix(&p).transpose() * right_jacobian(&th);
        let h = 1e-6;
        for k in 0..3 {
            let mut e = Vector3::zeros();
            e[k] = h;
            let fd =
                (compose(&p0, &exp_rotation(&(th + e))) - compose(&p0, &exp_rotation(&(th - e)))) / (2.0 * h);
            assert!(
                (fd - dp.column(k)).norm() < 1e-9,
                "column {k}: {fd} vs {}",
                dp.column(k)
            );
        }
        // The small-angle series agree with the closed forms at the switch.
        let small = Vector3::new(6e-5, -5e-5, 4e-5);
        let series = (exp_rotation(&small), right_jacobian(&small));
        let phi = small.norm();
        let closed = Vector4::new((0.5 * phi).cos(), 0.0, 0.0, 0.0)
            + Vector4::new(0.0, small.x, small.y, small.z) * ((0.5 * phi).sin() / phi);
        assert!((series.0 - closed).norm() < 1e-15);
        let k = skew(&small);
        let jr = Matrix3::identity() - (1.0 - phi.cos()) / (phi * phi) * k
            + (phi - phi.sin()) / (phi * phi * phi) * k * k;
        assert!((series.1 - jr).norm() < 1e-8);
    }

    /// A 0.5 kg bob on a 200 N/m spring of free length 0.1 m hung from the ground, started
    /// `x0` (m) to the side and unstretched; returns the model, the bob, (mass, k, l0).
    fn bob_on_a_spring(x0: f64) -> (Mechanism, BodyHandle, (f64, f64, f64)) {
        let mut m = Mechanism::new();
        let (mass, k, l0) = (0.5, 200.0, 0.1);
        let b = m
            .add_body(RigidBody::new("bob", mass, Matrix3::identity() * 1e-4).at(Vector3::new(x0, 0.0, -l0)));
        m.add_force(Box::new(SpringDamper {
            name: "spring".into(),
            i: (Attach::Ground, Vector3::zeros()),
            j: (Attach::Body(b), Vector3::zeros()),
            stiffness: k,
            damping: 0.0,
            free_length: l0,
        }));
        (m, b, (mass, k, l0))
    }

    /// A bob on a spring hung from the ground, started 2 cm to the side and unstretched:
    /// it comes to rest under the anchor with the spring stretched by m·g/k.
    #[test]
    fn a_bob_on_a_spring_hangs_below_its_anchor_stretched_by_mg_over_k() {
        let (m, b, (mass, k, l0)) = bob_on_a_spring(0.02);
        let model = Arc::new(m);
        let eq = static_equilibrium(&model, 0.0, None, &StaticsOptions::default()).unwrap();
        let r = eq.sample.body_position(b);
        let z = -l0 - mass * STANDARD_GRAVITY / k;
        assert!(r.x.abs() < 1e-9 && r.y.abs() < 1e-9, "{r}");
        assert!((r.z - z).abs() < 1e-9, "z = {}, expected {z}", r.z);
        assert!(eq.sample.body_velocity(b).norm() < 1e-9);
        // Warm start from the answer: converges at once.
        let again = static_equilibrium(&model, 0.0, Some(&eq.sample.q), &StaticsOptions::default()).unwrap();
        assert!(
            again.stats.steps <= eq.stats.steps,
            "{:?} vs {:?}",
            again.stats,
            eq.stats
        );
        // A start of the wrong length is an error, not a panic.
        assert!(static_equilibrium(&model, 0.0, Some(&[0.0; 3]), &StaticsOptions::default()).is_err());
    }

    /// A vertical pull on a body whose value the caller sets between solves.
    #[derive(Debug)]
    struct Pull {
        body: BodyHandle,
        force: Arc<std::sync::Mutex<f64>>,
    }

    impl ForceElement for Pull {
        fn name(&self) -> &str {
            "pull"
        }
        fn bodies(&self) -> Vec<BodyHandle> {
            vec![self.body]
        }
        fn apply(&self, _t: f64, _states: &[BodyState], loads: &mut [BodyLoad]) {
            loads[self.body.index()].force.z -= *self.force.lock().unwrap();
        }
    }

    /// One solver set up for a model solves its load cases in turn (the load read between
    /// solves), each equal to a fresh solve: the bob hangs by (m·g + F)/k.
    #[test]
    fn one_solver_solves_the_load_cases_of_a_model() {
        let (mut m, b, (mass, k, l0)) = bob_on_a_spring(0.0);
        let force = Arc::new(std::sync::Mutex::new(0.0));
        m.add_force(Box::new(Pull {
            body: b,
            force: force.clone(),
        }));
        let model = Arc::new(m);
        let opts = StaticsOptions::default();
        let mut statics = Statics::new(&model, &opts).unwrap();
        for pull in [0.0, 3.0, -1.0, 3.0] {
            *force.lock().unwrap() = pull;
            let eq = statics.solve(0.0, None).unwrap();
            let z = -l0 - (mass * STANDARD_GRAVITY + pull) / k;
            assert!((eq.sample.body_position(b).z - z).abs() < 1e-9, "pull {pull}");
            let fresh = static_equilibrium(&model, 0.0, None, &opts).unwrap();
            assert!((fresh.sample.body_position(b).z - z).abs() < 1e-9);
        }
        // Options the solver cannot run with are an error at set-up.
        let bad = StaticsOptions {
            relaxation_rate: 0.0,
            ..StaticsOptions::default()
        };
        assert!(Statics::new(&model, &bad).is_err());
    }

    /// The at-rest Jacobian of the equilibrium equations (constraint Hessians, λ columns,
    /// force elements, the rotation unknowns' chain rule) equals central differences of
    /// their residual, away from equilibrium and with arbitrary multipliers.
    #[test]
    fn the_equilibrium_jacobian_matches_differences_of_its_residual() {
        let mut m = Mechanism::new();
        let b = m.add_body(
            RigidBody::new(
                "arm",
                0.7,
                Matrix3::new(2e-3, 1e-4, 0.0, 1e-4, 3e-3, 0.0, 0.0, 0.0, 1e-3),
            )
            .at(Vector3::new(0.1, 0.0, 0.0)),
        );
        m.revolute_at("hinge", Attach::Ground, b, Vector3::zeros(), Vector3::y());
        m.add_force(Box::new(SpringDamper {
            name: "spring".into(),
            i: (Attach::Ground, Vector3::new(0.1, 0.02, 0.1)),
            j: (Attach::Body(b), Vector3::new(0.05, 0.01, 0.0)),
            stiffness: 300.0,
            damping: 2.0,
            free_length: 0.05,
        }));
        let model = Arc::new(m);
        let mut eq = Balance::new(MultibodyDae::new(model.clone()).unwrap(), &model, 20.0);
        let q0 = model.initial_guess().0;
        let mut x = eq.start(&q0);
        let n = eq.dim();
        x[0] += 1e-3;
        x[2] -= 2e-3;
        x[3..6].copy_from_slice(&[0.01, -0.02, 0.03]);
        for (k, v) in x[6..].iter_mut().enumerate() {
            *v = 3.0 - 1.3 * k as f64;
        }
        let pattern = eq.jacobian_pattern();
        let mut values = vec![0.0; pattern.nnz()];
        let zero = vec![0.0; n];
        eq.jacobian(0.0, &x, &zero, &[], 0.0, &mut values).unwrap();
        let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
        for c in 0..n {
            let h = 1e-7;
            let mut xp = x.clone();
            xp[c] += h;
            eq.residual(0.0, &xp, &zero, &[], &mut rp).unwrap();
            xp[c] -= 2.0 * h;
            eq.residual(0.0, &xp, &zero, &[], &mut rm).unwrap();
            for r in 0..n {
                let fd = (rp[r] - rm[r]) / (2.0 * h);
                let an = pattern.find(r, c).map_or(0.0, |k| values[k]);
                assert!(
                    (fd - an).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "({}, {}): differences {fd}, analytic {an}",
                    eq.component_name(r),
                    eq.component_name(c)
                );
            }
        }
    }
}
