//! Generic differential-algebraic equation solvers — no mechanics in here.
//!
//! * [`DaeSystem`] — the problem form F(t, y, y', p) = 0 with explicit parameters p, a
//!   sparse iteration-matrix pattern declared once, analytic or finite-difference (coloured)
//!   Jacobian, differential/algebraic marks, event functions.
//! * [`BdfSolver`] — variable-order variable-step BDF (IDA's fixed-leading-coefficient
//!   form) on the sparse LU of [`crate::sparse`]; see its module table for the file layout.
//! * [`explicit`] — baselines for ODEs y' = f(t, y): adaptive Dormand–Prince 5(4) and the
//!   fixed-step symplectic Euler of game-style contact engines.

pub mod bdf;
mod error;
pub mod explicit;
mod options;
mod problem;

pub use bdf::{BdfSolver, Outcome, MAX_ORDER};
pub use error::{Culprit, DaeError};
pub use options::{AbsTol, BdfOptions, PhaseTimes, Statistics};
pub use problem::{DaeSystem, EvalError, JacobianSource, VarKind};
