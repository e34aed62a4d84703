//! Rigid multibody systems in absolute coordinates on the `dae` layer.
//!
//! | file | concern |
//! |---|---|
//! | `rotation.rs` | Euler parameters, rotation matrices and their derivatives |
//! | `body.rs` | rigid bodies, the body set and handles |
//! | `error.rs` | model errors naming bodies and joints |

pub mod body;
pub mod error;
pub mod rotation;

pub use body::{Attach, BodyHandle, BodySet, RigidBody};
pub use error::ModelError;
