//! The nominal model as the diagnosis sees it in equation-error mode: joint torques from
//! measured motion (inverse dynamics), with named physical parameters the candidate library
//! may perturb.

use crate::mechanisms::double_pendulum::DoublePendulumParams;
use serde::Serialize;

/// What a model parameter stands for (names the candidate and the experiment that
/// separates it from others).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ParameterFamily {
    /// A link length or joint location.
    LinkGeometry,
    /// A link's mass, centre of mass or inertia.
    MassProperties,
    /// A payload.
    Payload,
    /// Tilt of the base (gravity direction).
    BaseTilt,
}

/// One perturbable parameter of a nominal model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelParameter {
    /// Name for reports, e.g. "link 1 length l1".
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Nominal value (SI).
    pub nominal: f64,
    /// Typical scale, for difference steps and reporting (SI).
    pub scale: f64,
    /// Family.
    pub family: ParameterFamily,
}

/// A nominal model in equation-error form: τ = ID(θ; q, q̇, q̈).
pub trait InverseDynamicsModel {
    /// Model name for reports.
    fn name(&self) -> String;
    /// Number of joints (torque channels).
    fn joints(&self) -> usize;
    /// Name of joint j (0-based), e.g. "joint 2 (elbow)".
    fn joint_name(&self, j: usize) -> String;
    /// Parameters the candidate library may perturb (nominal values included).
    fn parameters(&self) -> Vec<ModelParameter>;
    /// Joint torques (N·m) with parameter values `theta` (same order as
    /// [`parameters`](Self::parameters)) at joint positions, rates and accelerations.
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]);
    /// Torques per unit reflected rotor inertia J_j (kg·m², rotor inertia × gear ratio²) of
    /// drive j. Default: a drive fixed to the base, τ_j += J_j·q̈_j. A drive carried by a
    /// moving link also couples into the joints that carry it.
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        out[j] = qdd[j];
    }
}

/// The DFKI double pendulum's nominal model ([`DoublePendulumParams`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumModel {
    /// Nominal parameters.
    pub params: DoublePendulumParams,
}

impl DoublePendulumModel {
    fn with(&self, theta: &[f64]) -> DoublePendulumParams {
        let mut p = self.params;
        p.l1 = theta[0];
        p.r1 = theta[1];
        p.r2 = theta[2];
        p.m2 = theta[3];
        p.i1 = theta[4];
        p.i2 = theta[5];
        p.tilt = theta[6];
        p.payload = theta[7];
        p
    }
}

impl InverseDynamicsModel for DoublePendulumModel {
    fn name(&self) -> String {
        "DFKI double pendulum (nominal rigid model of its README)".into()
    }
    fn joints(&self) -> usize {
        2
    }
    fn joint_name(&self, j: usize) -> String {
        ["joint 1 (shoulder)", "joint 2 (elbow)"][j.min(1)].into()
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        let p = &self.params;
        let mk = |name: &str, unit: &str, nominal: f64, scale: f64, family| ModelParameter {
            name: name.into(),
            unit: unit.into(),
            nominal,
            scale,
            family,
        };
        use ParameterFamily::*;
        vec![
            mk(
                "link 1 length l1 (joint-2 location)",
                "m",
                p.l1,
                p.l1,
                LinkGeometry,
            ),
            mk("link 1 centre of mass r1", "m", p.r1, p.l1, MassProperties),
            mk("link 2 centre of mass r2", "m", p.r2, p.l2, MassProperties),
            mk("link 2 mass m2", "kg", p.m2, p.m2, MassProperties),
            mk("link 1 inertia I1", "kg m^2", p.i1, p.i1, MassProperties),
            mk("link 2 inertia I2", "kg m^2", p.i2, p.i2, MassProperties),
            mk("base tilt", "rad", 0.0, 0.1, BaseTilt),
            mk("payload at the link-2 tip", "kg", 0.0, p.m2, Payload),
        ]
    }
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        let t = self
            .with(theta)
            .torques([q[0], q[1]], [qd[0], qd[1]], [qdd[0], qdd[1]]);
        tau[..2].copy_from_slice(&t);
    }
    /// Drive 1 sits on the base. Drive 2 sits on link 1 at the elbow: its rotor turns at
    /// q̇1 + N·q̇2 (N the gear ratio), so with J = I_rotor·N² it adds J/N² to M11, J/N to M12
    /// and J to M22.
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        match (j, self.params.gear_ratio) {
            (1, Some(n)) if n > 0.0 => {
                out[0] = qdd[0] / (n * n) + qdd[1] / n;
                out[1] = qdd[0] / n + qdd[1];
            }
            _ => {
                out.iter_mut().for_each(|v| *v = 0.0);
                out[j] = qdd[j];
            }
        }
    }
}
