//! Clearance design: which clearances keep a mechanism within a required positioning
//! accuracy (the purpose the reference paper states and stops short of).
//!
//! | file | concern |
//! |---|---|
//! | `allowable.rs` | the largest uniform clearance that meets an accuracy at given poses: first-order estimate ([`crate::contact::play_bound`]) and verification by the nonlinear static equilibria ([`crate::multibody::static_equilibrium`]) |

pub mod allowable;

pub use allowable::{allowable_along, allowable_uniform, Accuracy, AllowablePoint, CurvePoint, DesignError};
