//! Contact laws and joints with clearance.
//!
//! A pair with clearance is not a kinematic constraint but a "shape connection": its links
//! touch through contact forces, so the mechanism gains the degrees of freedom the play
//! allows and the dynamics decide where the links sit (Bałchanowski's paper, §3).
//!
//! | file | concern |
//! |---|---|
//! | `laws.rs` | normal force laws (Hertz, Hunt–Crossley, Lankarani–Nikravesh, Flores), regularised Coulomb friction |
//! | `stiffness.rs` | Hertz stiffness from geometry and materials (ball in bore, ball on flat, ball in socket) |
//! | `bearing.rs` | a ball end in a cylindrical socket with radial and axial clearance (force element) |
//! | `joints.rs` | clearance pairs: universal (cross + four bearings), revolute, spherical |
//! | `play.rs` | the quasi-static play of a clearance joint: where the load pushes it within its clearance |
//! | `play_bound.rs` | the first-order pose error of a body from every joint's play (the clearance-design study's linearised bound) |
//!
//! All quantities SI: N, m, Pa, s.
//!
//! ## Contact onset and loss: smoothing, not events (decided by measurement)
//! * Every normal law is C¹ at δ = 0 (force and stiffness vanish there, `laws.rs`), so the
//!   BDF steps through onset and loss without event location; its error test sizes the steps.
//!   Event location was not adopted: with 24 bearings and thousands of onsets per second of
//!   rattle, each event would restart the BDF at order 1 (argued, not measured).
//! * The iteration matrix must not straddle onset: with element Jacobians by differences, a
//!   1e-7 increment made the L3 settling run take 33.6 s, 1e-9 took 1.0 s. The bearings now
//!   give exact derivatives (`dual.rs`, `ForceElement::load_jacobian`).
//! * Velocity errors are tested as index-2 quantities (scaled by the step) for the clearance
//!   runs: the settling rattle at M1 took 26 000 steps with index-1 velocities, 1 500 with
//!   index 2.
//! * What remains: on the benchmark trajectory (`lash bench mr2120`, rtol 1e-4) 2 657 of 9 920
//!   attempted steps are rejected, mostly Newton divergences at onset.

pub mod bearing;
mod dual;
pub mod joints;
pub mod laws;
pub mod play;
pub mod play_bound;
pub mod stiffness;

pub use bearing::{BallInSocket, ClearanceBearing};
pub use joints::{
    revolute_with_clearance, spherical_with_clearance, universal_with_clearance, BearingDesign,
    ClearanceUniversal, Damping,
};
pub use laws::{Friction, NormalLaw};
pub use stiffness::Material;

use thiserror::Error;

/// Invalid contact or clearance data, naming the quantity.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    /// A clearance is negative or not finite.
    #[error("{what} must be a finite clearance ≥ 0 m, got {value} m")]
    NegativeClearance {
        /// Which clearance.
        what: String,
        /// Its value.
        value: f64,
    },
    /// A modulus, radius, length or coefficient that must be positive is not.
    #[error("{what} must be positive, got {value}")]
    NonPositive {
        /// Which quantity.
        what: String,
        /// Its value.
        value: f64,
    },
    /// A ball does not fit its socket.
    #[error("the ball (radius {ball} m) is larger than its socket (radius {socket} m)")]
    BallLargerThanSocket {
        /// Ball radius, m.
        ball: f64,
        /// Socket radius, m.
        socket: f64,
    },
    /// A body handle that is not in the mechanism.
    #[error("body handle {0} is not in the mechanism")]
    UnknownBody(usize),
    /// A coefficient outside its range.
    #[error("{what} must lie in {range}, got {value}")]
    OutOfRange {
        /// Which quantity.
        what: String,
        /// Allowed range.
        range: String,
        /// Its value.
        value: f64,
    },
}

pub(crate) fn positive(what: &str, v: f64) -> Result<f64, ContactError> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(ContactError::NonPositive {
            what: what.into(),
            value: v,
        })
    }
}

pub(crate) fn clearance(what: &str, v: f64) -> Result<f64, ContactError> {
    if v >= 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(ContactError::NegativeClearance {
            what: what.into(),
            value: v,
        })
    }
}
