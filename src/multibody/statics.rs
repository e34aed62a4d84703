//! Quasi-static equilibrium of a mechanism: the configuration at which the applied loads
//! (gravity, force elements — contact in clearance joints included) balance the constraint
//! reactions with the drivers held at time t, found without integrating any motion.
//!
//! The equilibrium is the steady state of the GGL equations of motion ([`MultibodyDae`]) with
//! all time derivatives zero, solved by pseudo-transient continuation
//! ([`crate::dae::steady_state`]): backward-Euler steps of growing length on the mechanism's own
//! mass matrix, Newton's method in the limit. A body that floats inside a clearance (no load
//! pushes it against either side) keeps a regularising inertia term and stays where the
//! iteration leaves it, as a real body would stay where it came to rest; any configuration
//! the loads do push converges to the tolerance of [`StaticsOptions::steady`].
//!
//! Drivers are evaluated at the given time: for an equilibrium their laws must be at rest
//! there (constant laws, or a time at which the prescribed motion is stationary).

use super::analysis::{Analysis, AssemblyOptions};
use super::data::MechanismData;
use super::error::ModelError;
use super::formulation::{FormulationOptions, MultibodyDae};
use super::model::Mechanism;
use super::simulation::Sample;
use crate::dae::{
    steady_state, AbsTol, DaeSystem, EvalError, JacobianSource, SteadyOptions, SteadyStats, VarKind,
};
use crate::sparse::CscPattern;
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

/// Every tunable of [`static_equilibrium`].
#[derive(Debug, Clone, PartialEq)]
pub struct StaticsOptions {
    /// The pseudo-transient continuation. Defaults: [`SteadyOptions::default`] with
    /// rtol 1e-8 and atol 1e-11 (m, rad: a hundredth of a micrometre), τ_0 = 10 ms, settling
    /// time 1000 s, at most 500 pseudo-steps.
    pub steady: SteadyOptions,
    /// Position assembly of the starting configuration.
    pub assembly: AssemblyOptions,
    /// The equations of motion (analytic Jacobian by default).
    pub formulation: FormulationOptions,
    /// Rate ζ of the mass-proportional damping of the pseudo-motion, 1/s: each body feels
    /// −ζ·m·v and −ζ·J'·ω' while the iteration moves it. It vanishes at rest, so it does not
    /// change the equilibrium; it keeps the pseudo-motion from bouncing between contacts in
    /// large clearances. Default 20 (measured on the MR2120's static Table 3: fewer pseudo-steps
    /// than 200, and robust where 0 or 2000 fail; `lash bench statics`).
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
    let lay = model.layout();
    let analysis = Analysis::with_options(model, opts.assembly)?;
    let mut data = MechanismData::new(model);
    let q0 = match start {
        Some(q) if q.len() == lay.y_q().len() => q.to_vec(),
        Some(q) => {
            return Err(ModelError::BadBody {
                body: "(start configuration)".into(),
                reason: format!(
                    "{} position coordinates given, the model has {}",
                    q.len(),
                    lay.y_q().len()
                ),
            })
        }
        None => analysis.assemble(model, &mut data, t, &model.initial_guess().0)?,
    };
    if !(opts.relaxation_rate >= 0.0 && opts.relaxation_rate.is_finite()) {
        return Err(ModelError::Statics(crate::dae::DaeError::InvalidInput(format!(
            "relaxation_rate must be ≥ 0 and finite, got {}",
            opts.relaxation_rate
        ))));
    }
    let mut dae = Relaxed::new(
        MultibodyDae::with_options(model.clone(), opts.formulation)?,
        model,
        opts.relaxation_rate,
    );
    let mut y = vec![0.0; lay.dim()];
    y[lay.y_q()].copy_from_slice(&q0);
    let stats = steady_state(&mut dae, t, &mut y, &[], &opts.steady).map_err(ModelError::Statics)?;
    let q = y[lay.y_q()].to_vec();
    let singularity = analysis.singularity_in(&mut data.ev, t, &q);
    Ok(Equilibrium {
        sample: Sample {
            t,
            q,
            w: y[lay.y_w()].to_vec(),
            lambda: y[lay.y_lambda()].to_vec(),
            singularity,
        },
        stats,
    })
}

/// The equations of motion with mass-proportional damping ζ·m·v, ζ·J'·ω' added to each
/// body's momentum rows: the pseudo-motion of [`static_equilibrium`].
struct Relaxed {
    inner: MultibodyDae,
    rate: f64,
    /// Per body: first momentum row (= first velocity unknown in y), mass, and the
    /// body-frame inertia restricted to the entries the Jacobian pattern holds.
    bodies: Vec<(usize, f64, Matrix3<f64>)>,
    /// Per body: the slots of the damping entries (3 translational, 3 × 3 rotational) in the
    /// Jacobian's values, `None` where the pattern has no entry (that inertia entry is then
    /// left out of the damping, so residual and Jacobian agree).
    slots: Vec<[Option<usize>; 12]>,
}

impl Relaxed {
    fn new(inner: MultibodyDae, model: &Mechanism, rate: f64) -> Self {
        let lay = model.layout();
        let pattern = inner.jacobian_pattern();
        let mut bodies = vec![];
        let mut slots = vec![];
        for (h, b) in model.bodies().iter() {
            let wo = lay.w(h.index());
            let mut s = [None; 12];
            for k in 0..3 {
                s[k] = pattern.find(wo + k, wo + k);
            }
            let mut j = b.inertia;
            for r in 0..3 {
                for c in 0..3 {
                    s[3 + 3 * r + c] = pattern.find(wo + 3 + r, wo + 3 + c);
                    if s[3 + 3 * r + c].is_none() {
                        j[(r, c)] = 0.0;
                    }
                }
            }
            let m = if s[..3].iter().all(Option::is_some) {
                b.mass
            } else {
                0.0
            };
            bodies.push((wo, m, j));
            slots.push(s);
        }
        Self {
            inner,
            rate,
            bodies,
            slots,
        }
    }
}

impl DaeSystem for Relaxed {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn residual(&mut self, t: f64, y: &[f64], yp: &[f64], p: &[f64], r: &mut [f64]) -> Result<(), EvalError> {
        self.inner.residual(t, y, yp, p, r)?;
        for &(wo, m, j) in &self.bodies {
            let om = Vector3::new(y[wo + 3], y[wo + 4], y[wo + 5]);
            let jw = j * om;
            for k in 0..3 {
                r[wo + k] += self.rate * m * y[wo + k];
                r[wo + 3 + k] += self.rate * jw[k];
            }
        }
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        self.inner.jacobian_pattern()
    }
    fn jacobian_source(&self) -> JacobianSource {
        self.inner.jacobian_source()
    }
    fn jacobian(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        self.inner.jacobian(t, y, yp, p, alpha, values)?;
        for (&(_, m, j), s) in self.bodies.iter().zip(&self.slots) {
            for slot in s[..3].iter().flatten() {
                values[*slot] += self.rate * m;
            }
            for r in 0..3 {
                for c in 0..3 {
                    if let Some(slot) = s[3 + 3 * r + c] {
                        values[slot] += self.rate * j[(r, c)];
                    }
                }
            }
        }
        Ok(())
    }
    fn var_kinds(&self) -> Vec<VarKind> {
        self.inner.var_kinds()
    }
    fn component_name(&self, i: usize) -> String {
        self.inner.component_name(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::{Attach, RigidBody, SpringDamper, STANDARD_GRAVITY};
    use nalgebra::{Matrix3, Vector3};

    /// A bob on a spring hung from the ground, started 2 cm to the side and unstretched:
    /// it comes to rest under the anchor with the spring stretched by m·g/k.
    #[test]
    fn a_bob_on_a_spring_hangs_below_its_anchor_stretched_by_mg_over_k() {
        let mut m = Mechanism::new();
        let (mass, k, l0) = (0.5, 200.0, 0.1);
        let b = m.add_body(
            RigidBody::new("bob", mass, Matrix3::identity() * 1e-4).at(Vector3::new(0.02, 0.0, -l0)),
        );
        m.add_force(Box::new(SpringDamper {
            name: "spring".into(),
            i: (Attach::Ground, Vector3::zeros()),
            j: (Attach::Body(b), Vector3::zeros()),
            stiffness: k,
            damping: 0.0,
            free_length: l0,
        }));
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
}
