//! Errors of the multibody layer, naming the bodies and joints involved.

use crate::dae::DaeError;
use thiserror::Error;

/// A model that cannot be built or simulated, with the offending parts named.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// A body's mass properties or initial state are invalid.
    #[error("body '{body}': {reason}")]
    BadBody {
        /// Body name.
        body: String,
        /// What is wrong.
        reason: String,
    },
    /// A joint, driver or force element is invalid.
    #[error("{kind} '{name}': {reason}")]
    BadElement {
        /// "joint", "driver" or "force".
        kind: &'static str,
        /// Element name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// Position assembly did not satisfy the constraints.
    #[error("the mechanism cannot assemble: {}", describe_residuals(.residuals))]
    AssemblyFailed {
        /// (constraint name, residual) of the unsatisfied constraints, worst first.
        residuals: Vec<(String, f64)>,
    },
    /// The constraint Jacobian lost rank (a singular configuration).
    #[error("singular configuration at t = {t:e} s: smallest normalised singular value of the constraint Jacobian {measure:.3e}{}", if .detail.is_empty() { String::new() } else { format!(" ({})", .detail) })]
    Singular {
        /// Time, s.
        t: f64,
        /// The measure.
        measure: f64,
        /// Context.
        detail: String,
    },
    /// A [`MechanismData`](super::MechanismData) used with a model other than the one (or
    /// the version of it) it was made for.
    #[error("data made for a different version of the model (bodies, joints, drivers or force elements changed since); make a new MechanismData")]
    StaleData,
    /// The integrator failed.
    #[error("integration failed: {0}")]
    Integration(#[from] DaeError),
    /// No static equilibrium was found ([`static_equilibrium`](super::statics::static_equilibrium)).
    #[error("static equilibrium: {0}")]
    Statics(DaeError),
    /// Output could not be written.
    #[error("output: {0}")]
    Output(String),
}

fn describe_residuals(r: &[(String, f64)]) -> String {
    let list: Vec<String> = r
        .iter()
        .take(6)
        .map(|(n, v)| format!("{n} (residual {v:.3e})"))
        .collect();
    format!("unsatisfied {}", list.join(", "))
}
