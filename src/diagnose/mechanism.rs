//! Any mechanism built with the multibody API as a nominal model for the diagnosis
//! (equation error): the drive torques at each measured sample come from the multibody
//! inverse dynamics — assembly, velocity and acceleration analysis with the drivers set to
//! the measured joint positions, rates and accelerations — and the driver multipliers.
//!
//! The user supplies a builder that makes the mechanism for given parameter values and
//! attaches its drivers with the motion laws it is handed (one per measured joint, in the
//! order of the torque channels: the j-th driver added serves channel j); the parameters are
//! named, with units, nominal values and scales, so the candidate library can perturb them.
//! [`MechanismModel::new`] builds the mechanism once with the nominal values and refuses a
//! builder that fails or attaches a wrong number of drivers.
//! At each sample the measured motion is prescribed to the drivers in the mechanism's
//! [`MechanismData`] ([`MechanismData::prescribe_driver`]), and the torques are the drivers'
//! efforts ([`MechanismData::driver_effort`]).
//!
//! ```
//! use lash::diagnose::mechanism::MechanismModel;
//! use lash::diagnose::model::{InverseDynamicsModel, ModelParameter, ParameterFamily};
//! use lash::multibody::{Attach, Mechanism, MotionLaw, RigidBody};
//! use nalgebra::{Matrix3, Vector3};
//! use std::sync::Arc;
//!
//! // A pendulum of mass m (the parameter) on a driven revolute joint about y.
//! let model = MechanismModel::new(
//!     "pendulum",
//!     vec!["joint 1".into()],
//!     vec![ModelParameter {
//!         name: "bob mass".into(),
//!         unit: "kg".into(),
//!         nominal: 1.0,
//!         scale: 1.0,
//!         family: ParameterFamily::MassProperties,
//!     }],
//!     Arc::new(|theta: &[f64], laws: &[MotionLaw]| {
//!         let mut m = Mechanism::new();
//!         let bob = m.add_body(
//!             RigidBody::new("bob", theta[0], Matrix3::identity() * 1e-3).at(Vector3::new(0.0, 0.0, -0.5)),
//!         );
//!         let j = m.revolute_at("pivot", Attach::Ground, bob, Vector3::zeros(), Vector3::y());
//!         m.drive("q1", j, laws[0].clone(), 0.0)?;
//!         Ok(m)
//!     }),
//! )?;
//! let mut tau = [0.0];
//! // Held at 90° the drive carries the weight: m g r = 1 · 9.81 · 0.5 N·m.
//! model.torques(&[1.0], &[std::f64::consts::FRAC_PI_2], &[0.0], &[0.0], &mut tau);
//! assert!((tau[0].abs() - 9.81 * 0.5).abs() < 1e-6);
//! # Ok::<(), lash::diagnose::DiagnoseError>(())
//! ```

use super::error::DiagnoseError;
use super::model::{InverseDynamicsModel, ModelParameter};
use crate::multibody::{Analysis, DriverHandle, Mechanism, MechanismData, ModelError, MotionLaw};
use std::cell::RefCell;
use std::sync::Arc;

/// Builds the mechanism for parameter values `theta`, attaching one driver per measured
/// joint with the laws given (in channel order).
pub type MechanismBuilder = Arc<dyn Fn(&[f64], &[MotionLaw]) -> Result<Mechanism, ModelError> + Send + Sync>;

struct Built {
    theta: Vec<f64>,
    model: Mechanism,
    data: MechanismData,
    analysis: Analysis,
    /// The drivers, in channel order.
    drivers: Vec<DriverHandle>,
    q: Vec<f64>,
    w: Vec<f64>,
    /// Joint positions of the last assembled configuration.
    last: Vec<f64>,
}

/// Largest joint-position change (rad or m) assembled in one Newton solve; larger jumps
/// between samples are walked in steps (continuation), so assembly stays on its branch.
pub const CONTINUATION_STEP: f64 = 0.1;

/// A mechanism built with the multibody API, seen by the diagnosis.
pub struct MechanismModel {
    name: String,
    joints: Vec<String>,
    parameters: Vec<ModelParameter>,
    builder: MechanismBuilder,
    /// The mechanism built for the last parameter values, with its data (a cache: the
    /// diagnosis asks for torques through `&self`).
    built: RefCell<Option<Built>>,
}

impl std::fmt::Debug for MechanismModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MechanismModel")
            .field("name", &self.name)
            .field("joints", &self.joints)
            .field("parameters", &self.parameters)
            .finish_non_exhaustive()
    }
}

impl MechanismModel {
    /// A model named `name` with torque channels `joints` (names, one per driver), the
    /// perturbable `parameters` and the `builder`. Builds the mechanism with the nominal
    /// parameter values; fails ([`DiagnoseError::Model`], naming the cause) if the builder
    /// fails, the mechanism is invalid or it has not one driver per torque channel.
    pub fn new(
        name: &str,
        joints: Vec<String>,
        parameters: Vec<ModelParameter>,
        builder: MechanismBuilder,
    ) -> Result<Self, DiagnoseError> {
        let m = Self {
            name: name.into(),
            joints,
            parameters,
            builder,
            built: RefCell::new(None),
        };
        let nominal: Vec<f64> = m.parameters.iter().map(|p| p.nominal).collect();
        m.ensure(&nominal).map_err(|message| DiagnoseError::Model {
            model: m.name.clone(),
            message: format!("with the nominal parameters: {message}"),
        })?;
        Ok(m)
    }

    /// Builds (or reuses) the mechanism for `theta`; the error names the cause.
    fn ensure(&self, theta: &[f64]) -> Result<(), String> {
        let mut b = self.built.borrow_mut();
        if b.as_ref().is_some_and(|x| x.theta == theta) {
            return Ok(());
        }
        // Placeholder laws: every analysis below prescribes the drivers' motion in the data.
        let laws = vec![MotionLaw::Constant(0.0); self.joints.len()];
        let model = (self.builder)(theta, &laws).map_err(|e| format!("the builder failed: {e}"))?;
        let analysis = Analysis::new(&model).map_err(|e| format!("invalid mechanism: {e}"))?;
        let drivers: Vec<DriverHandle> = model.drivers().map(|(h, _)| h).collect();
        if drivers.len() != self.joints.len() {
            return Err(format!(
                "the builder attached {} drivers for {} torque channels (one driver per measured joint, in channel order)",
                drivers.len(),
                self.joints.len()
            ));
        }
        let (q, w) = model.initial_guess();
        let data = MechanismData::new(&model);
        *b = Some(Built {
            theta: theta.to_vec(),
            model,
            data,
            analysis,
            drivers,
            q,
            w,
            last: vec![0.0; self.joints.len()],
        });
        Ok(())
    }
}

impl InverseDynamicsModel for MechanismModel {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn joints(&self) -> usize {
        self.joints.len()
    }
    fn joint_name(&self, j: usize) -> String {
        self.joints
            .get(j)
            .cloned()
            .unwrap_or_else(|| format!("joint {}", j + 1))
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        self.parameters.clone()
    }
    /// Driver torques (N·m, or N for a prismatic drive) at the sample; NaN where the
    /// mechanism cannot be assembled, its inverse dynamics is singular or the builder fails
    /// for perturbed parameter values (the nominal ones are checked by
    /// [`MechanismModel::new`]).
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        let n = self.joints.len();
        tau[..n].iter_mut().for_each(|v| *v = f64::NAN);
        if self.ensure(theta).is_err() {
            return;
        }
        let mut b = self.built.borrow_mut();
        let Some(built) = b.as_mut() else { return };
        // Walk large jumps (the first sample, or a new recording) from the last assembled
        // configuration (the built one at first: drive coordinates 0).
        let jump = (0..n).map(|j| (q[j] - built.last[j]).abs()).fold(0.0, f64::max);
        let steps = (jump / CONTINUATION_STEP).ceil().min(1000.0) as usize;
        for k in 1..steps {
            let f = k as f64 / steps as f64;
            for j in 0..n {
                let x = built.last[j] + f * (q[j] - built.last[j]);
                // The sample's motion as a local quadratic in time about t = 0 (the analyses
                // differentiate driver laws in time).
                let _ = built.data.prescribe_driver(built.drivers[j], 0.0, [x, 0.0, 0.0]);
            }
            match built
                .analysis
                .assemble(&built.model, &mut built.data, 0.0, &built.q)
            {
                Ok(x) => built.q = x,
                Err(_) => break,
            }
        }
        for j in 0..n {
            let _ = built
                .data
                .prescribe_driver(built.drivers[j], 0.0, [q[j], qd[j], qdd[j]]);
        }
        // Continue from the previous sample (samples come in time order); fall back to the
        // built configuration if that fails.
        let Built {
            model,
            data,
            analysis,
            ..
        } = built;
        let snap = match analysis.state_at(model, data, 0.0, &built.q, &built.w) {
            Ok(s) => Ok(s),
            Err(_) => {
                let (q0, w0) = model.initial_guess();
                analysis.state_at(model, data, 0.0, &q0, &w0)
            }
        };
        if let Ok(s) = snap {
            for j in 0..n {
                tau[j] = data.driver_effort(built.drivers[j]).unwrap_or(f64::NAN);
            }
            built.q = s.q;
            built.w = s.w;
            built.last = q[..n].to_vec();
        }
    }
}
