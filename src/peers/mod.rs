//! Independent peer solvers, used as cross-checks of lash's answers and as benchmark peers.
//! Compiled with the `peers` feature (on by default).
//!
//! * `diffsol_bdf` (and `diffsol_bdf_sampled`, `diffsol_dae`) — diffsol's variable-order BDF
//!   (NDF variant), pinned to diffsol 0.18.0, for problems in the form M·y' = f(t, y) with a
//!   constant diagonal M (index ≤ 1);
//!   `with_diffsol_bdf` lends it out as a stepping [`Integrator`](crate::dae::Integrator).

#[cfg(feature = "peers")]
mod diffsol_bdf;
#[cfg(feature = "peers")]
pub use diffsol_bdf::{diffsol_bdf, diffsol_bdf_sampled, diffsol_dae, with_diffsol_bdf, PeerRun};
