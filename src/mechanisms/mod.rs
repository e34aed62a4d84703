//! Concrete mechanisms built on lash's layers.
//!
//! * [`chain`] — N links joined by universal joints with clearance (the scaling benchmark).
//! * [`double_pendulum`] — the DFKI two-link pendulum's nominal rigid model (real recordings
//!   for the diagnosis).
//! * [`mr2120`] — the WUT MR2120 3-RUU translational parallel mechanism of Bałchanowski's
//!   paper: geometry, closed-form inverse and numerical forward kinematics, Jacobians,
//!   singularity measures, and the paper's published values.

pub mod chain;
pub mod double_pendulum;
pub mod mr2120;
