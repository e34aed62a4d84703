//! The library of candidate physics. Each candidate is a parameterised extension of the
//! nominal model that vanishes at zero; in equation-error form it adds regressor columns to
//! the torque residual, exactly for effects linear in their parameters and to first order in
//! the others (model-parameter perturbations, delay):
//!
//! | effect | torque term on joint j |
//! |---|---|
//! | viscous friction | b·q̇_j |
//! | Coulomb friction | c·tanh(q̇_j/v_c) |
//! | Stribeck friction | s·tanh(q̇_j/v_c)·exp(−(q̇_j/v_s)²) for each v_s of the grid |
//! | direction-asymmetric friction | c₊·max(tanh(q̇_j/v_c), 0) + c₋·min(tanh(q̇_j/v_c), 0) (nests Coulomb) |
//! | reflected rotor inertia | J·q̈_j, plus the coupling of a drive carried by a moving link (model-specific) |
//! | torque-sensor offset | o |
//! | torque-sensor scale | (k − 1)·τ_j,nominal |
//! | torque-sensor delay | −d·dτ_j,nominal/dt |
//! | model parameter θ_k (link length, centre of mass, mass, inertia, base tilt, payload) | Δθ_k·∂τ/∂θ_k (all joints) |

use super::data::MotionData;
use super::model::{InverseDynamicsModel, ParameterFamily};
use super::signal::derivative;
use serde::Serialize;

/// Every tunable of the candidate library.
#[derive(Debug, Clone, PartialEq)]
pub struct LibraryOptions {
    /// Velocity scale of the smooth sign in the friction laws, rad/s.
    pub coulomb_velocity: f64,
    /// Stribeck velocities tried, rad/s (one candidate each).
    pub stribeck_velocities: Vec<f64>,
}

impl Default for LibraryOptions {
    /// v_c = 0.05 rad/s (well above the rate noise of encoder-differentiated velocities,
    /// well below typical motion); Stribeck velocities 0.1, 0.3 and 1 rad/s.
    fn default() -> Self {
        Self {
            coulomb_velocity: 0.05,
            stribeck_velocities: vec![0.1, 0.3, 1.0],
        }
    }
}

/// What kind of physics a candidate is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Effect {
    /// Viscous joint friction, N·m·s/rad.
    Viscous,
    /// Coulomb joint friction, N·m.
    Coulomb,
    /// Stribeck friction (extra static friction decaying with speed), N·m, at velocity v_s.
    Stribeck {
        /// Stribeck velocity, rad/s.
        v_s: f64,
    },
    /// Direction-asymmetric Coulomb friction (two levels), N·m.
    AsymmetricFriction,
    /// Reflected rotor inertia of the drive, kg·m².
    RotorInertia,
    /// Torque-sensor offset, N·m.
    TorqueOffset,
    /// Torque-sensor scale error (k − 1), dimensionless.
    TorqueScale,
    /// Torque-sensor delay, s.
    TorqueDelay,
    /// Error of a nominal model parameter (index into the model's parameters).
    Parameter {
        /// Index.
        index: usize,
        /// Family.
        family: ParameterFamily,
    },
}

/// One candidate: an effect, where it acts, and its parameter names/units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// Name for reports, e.g. "Coulomb friction in joint 2 (elbow)".
    pub name: String,
    /// The effect.
    pub effect: Effect,
    /// Joint it acts in (None: all joints, as model parameters do).
    pub joint: Option<usize>,
    /// Parameter names with units, one per regressor column.
    pub parameters: Vec<String>,
    /// Hyper-parameters chosen from a grid (counted in the information criterion).
    pub grid_parameters: usize,
    /// Physically plausible range of each parameter (friction and inertia are not negative,
    /// a torque sensor is not off by more than 50 %, a part is not off by more than half
    /// its size); a fit outside it is rejected as implausible.
    pub bounds: Vec<(f64, f64)>,
}

/// Builds the candidate library for a model.
pub fn library(model: &dyn InverseDynamicsModel, opts: &LibraryOptions) -> Vec<Candidate> {
    let mut out = vec![];
    for j in 0..model.joints() {
        let jn = model.joint_name(j);
        let inf = f64::INFINITY;
        let mk = |name: &str, effect, params: &[&str], grid, bounds: &[(f64, f64)]| Candidate {
            name: format!("{name} in {jn}"),
            effect,
            joint: Some(j),
            parameters: params.iter().map(|s| s.to_string()).collect(),
            grid_parameters: grid,
            bounds: bounds.to_vec(),
        };
        let pos = (0.0, inf);
        out.push(mk(
            "viscous friction",
            Effect::Viscous,
            &["b [N m s/rad]"],
            0,
            &[pos],
        ));
        out.push(mk("Coulomb friction", Effect::Coulomb, &["c [N m]"], 0, &[pos]));
        for &v_s in &opts.stribeck_velocities {
            out.push(mk(
                &format!("Stribeck friction (v_s = {v_s} rad/s)"),
                Effect::Stribeck { v_s },
                &["s [N m]"],
                1,
                &[pos],
            ));
        }
        out.push(mk(
            "direction-asymmetric friction",
            Effect::AsymmetricFriction,
            &["c+ [N m]", "c- [N m]"],
            0,
            &[pos, pos],
        ));
        out.push(mk(
            "reflected rotor inertia",
            Effect::RotorInertia,
            &["J [kg m^2]"],
            0,
            &[pos],
        ));
        out.push(mk(
            "torque-sensor offset",
            Effect::TorqueOffset,
            &["o [N m]"],
            0,
            &[(-inf, inf)],
        ));
        out.push(mk(
            "torque-sensor scale error",
            Effect::TorqueScale,
            &["k-1 [-]"],
            0,
            &[(-0.5, 0.5)],
        ));
        out.push(mk(
            "torque-sensor delay",
            Effect::TorqueDelay,
            &["d [s]"],
            0,
            &[(-0.05, 0.05)],
        ));
    }
    for (k, p) in model.parameters().iter().enumerate() {
        out.push(Candidate {
            name: format!("error in {}", p.name),
            effect: Effect::Parameter {
                index: k,
                family: p.family,
            },
            joint: None,
            parameters: vec![format!("delta [{}]", p.unit)],
            grid_parameters: 0,
            bounds: vec![match p.family {
                ParameterFamily::LinkGeometry => (-0.1 * p.scale, 0.1 * p.scale),
                ParameterFamily::MassProperties => (-0.5 * p.scale, 0.5 * p.scale),
                ParameterFamily::Payload => (0.0, p.scale),
                ParameterFamily::BaseTilt => (-0.2, 0.2),
            }],
        });
    }
    out
}

/// Regressor columns of every candidate on one recording: `cols[c][k]` is column k of
/// candidate c, stacked joint by joint (joint 0's samples, then joint 1's, ...).
pub fn columns(
    cands: &[Candidate],
    d: &MotionData,
    model: &dyn InverseDynamicsModel,
    opts: &LibraryOptions,
) -> Vec<Vec<Vec<f64>>> {
    let nj = model.joints();
    let n = d.len();
    let params = model.parameters();
    let theta0: Vec<f64> = params.iter().map(|p| p.nominal).collect();
    let tau_nom = d.model_torques(model, &theta0);
    let sgn = |v: f64| (v / opts.coulomb_velocity).tanh();
    let per_joint = |j: usize, f: &dyn Fn(usize) -> f64| {
        let mut c = vec![0.0; nj * n];
        for i in 0..n {
            c[j * n + i] = f(i);
        }
        c
    };
    cands
        .iter()
        .map(|c| match (c.effect, c.joint) {
            (Effect::Parameter { index, .. }, _) => {
                let h = 1e-6 * params[index].scale.max(1e-12);
                let (mut tp, mut tm) = (theta0.clone(), theta0.clone());
                tp[index] += h;
                tm[index] -= h;
                let (a, b) = (d.model_torques(model, &tp), d.model_torques(model, &tm));
                let mut col = vec![0.0; nj * n];
                for j in 0..nj {
                    for i in 0..n {
                        col[j * n + i] = (a[j][i] - b[j][i]) / (2.0 * h);
                    }
                }
                vec![col]
            }
            (e, Some(j)) => {
                let qd = &d.qd[j];
                match e {
                    Effect::Viscous => vec![per_joint(j, &|i| qd[i])],
                    Effect::Coulomb => vec![per_joint(j, &|i| sgn(qd[i]))],
                    Effect::Stribeck { v_s } => {
                        vec![per_joint(j, &|i| sgn(qd[i]) * (-(qd[i] / v_s).powi(2)).exp())]
                    }
                    Effect::AsymmetricFriction => vec![
                        per_joint(j, &|i| sgn(qd[i]).max(0.0)),
                        per_joint(j, &|i| sgn(qd[i]).min(0.0)),
                    ],
                    Effect::RotorInertia => {
                        let mut col = vec![0.0; nj * n];
                        let (mut a, mut out) = (vec![0.0; nj], vec![0.0; nj]);
                        for i in 0..n {
                            for k in 0..nj {
                                a[k] = d.qdd[k][i];
                            }
                            model.rotor_regressor(j, &a, &mut out);
                            for k in 0..nj {
                                col[k * n + i] = out[k];
                            }
                        }
                        vec![col]
                    }
                    Effect::TorqueOffset => vec![per_joint(j, &|_| 1.0)],
                    Effect::TorqueScale => vec![per_joint(j, &|i| tau_nom[j][i])],
                    Effect::TorqueDelay => {
                        let dt = derivative(&d.t, &tau_nom[j], 2);
                        vec![per_joint(j, &|i| -dt[i])]
                    }
                    Effect::Parameter { .. } => unreachable!("handled above"),
                }
            }
            (_, None) => vec![vec![0.0; nj * n]],
        })
        .collect()
}

/// The recording that would separate two candidates the data cannot tell apart.
pub fn separating_experiment(a: &Candidate, b: &Candidate) -> String {
    use Effect::*;
    let joint = |c: &Candidate| {
        c.joint
            .map(|j| format!("joint {}", j + 1))
            .unwrap_or("the joints".into())
    };
    let friction = |e: Effect| matches!(e, Viscous | Coulomb | Stribeck { .. } | AsymmetricFriction);
    match (a.effect, b.effect) {
        (x, y) if friction(x) && friction(y) => format!(
            "a run holding {} at several constant speeds, slow and fast, in both directions (friction against speed)",
            joint(a)
        ),
        (RotorInertia, Parameter { .. }) | (Parameter { .. }, RotorInertia) => format!(
            "a run accelerating {} hard while the other joints stay still (rotor inertia acts on that joint alone)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (x, TorqueOffset) | (TorqueOffset, x) if friction(x) => format!(
            "a motion that reverses {} under a load that does not (friction flips sign with the velocity, an offset does not)",
            joint(a)
        ),
        (Parameter { .. }, Parameter { .. }) => {
            "poses spanning the whole range of both joints, held still (gravity torques separate masses, lengths and tilt)"
                .into()
        }
        (TorqueScale, _) | (_, TorqueScale) => {
            "a run with a known external load (a calibrated weight) to calibrate the torque sensor".into()
        }
        _ => format!(
            "a motion that reverses the load in {} and in {} at different times",
            joint(a),
            joint(b)
        ),
    }
}
