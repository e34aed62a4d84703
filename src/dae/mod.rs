//! Generic differential-algebraic equation solvers — no mechanics in here.
//!
//! * [`DaeSystem`] — the problem form F(t, y, y', p) = 0 with explicit parameters p, a
//!   sparse iteration-matrix pattern declared once, analytic or finite-difference (coloured)
//!   Jacobian, differential/algebraic marks, event functions.
//! * [`BdfSolver`] — variable-order variable-step BDF (IDA's fixed-leading-coefficient
//!   form) on a pluggable linear solver ([`LinearSolver`]; faer's sparse LU by default).
//! * [`explicit`] — baselines for ODEs y' = f(t, y): adaptive Dormand–Prince 5(4) and the
//!   fixed-step symplectic Euler of game-style contact engines.
//! * [`steady_state`] — the steady state F(t, y, 0) = 0 of a damped system by
//!   pseudo-transient continuation (backward-Euler steps of growing length, Newton in the
//!   limit), on the BDF's matrix machinery.
//! * [`Integrator`] — the one interface over all of them (and the diffsol peer in
//!   [`crate::peers`]): advance to a time, time and state, work counters.
//!
//! One concern per file, in the manner of SUNDIALS IDA:
//!
//! | file | concern |
//! |---|---|
//! | `problem.rs` | the problem interface [`DaeSystem`], [`EvalError`], [`JacobianSource`] |
//! | `options.rs` | every tunable ([`BdfOptions`]) and the run statistics ([`Statistics`], [`PhaseTimes`]) |
//! | `error.rs` | [`DaeError`] and the named [`Culprit`]s of a failure |
//! | `integrator.rs` | the [`Integrator`] trait, its common [`WorkStats`], and its implementations |
//! | `linear_solver.rs` | the linear-solver seam: [`LinearSolver`], [`SparseLu`](crate::sparse::SparseLu) and [`DenseLu`], [`LinearSolverKind`] |
//! | `steady.rs` | steady states by pseudo-transient continuation ([`steady_state`], [`SteadyOptions`]) |
//! | `bdf/mod.rs` | the BDF state struct, construction, norms, accessors |
//! | `bdf/step.rs` | the step loop body: coefficients, predictor, error test, order/step selection |
//! | `bdf/output.rs` | the output-time driver, dense output, stop times, events, restarts |
//! | `bdf/ic.rs` | initial conditions: the consistency check and consistent values of index-1 problems |
//! | `bdf/newton.rs` | the Newton iteration with Jacobian/LU reuse and refresh |
//! | `bdf/linsys.rs` | the one set-up path of every factorised matrix (Newton and initial conditions): Jacobian (analytic or coloured differences), assembly into the pattern, factorisation, counters |
//! | `bdf/estimate.rs` | filtering of the local error estimates in stiff directions |
//! | `explicit/` | Dormand–Prince 5(4) and symplectic Euler for ODEs |

pub mod bdf;
mod error;
pub mod explicit;
mod integrator;
mod linear_solver;
mod options;
mod problem;
mod steady;

pub use bdf::{BdfSolver, Outcome, MAX_ORDER};
pub use error::{Culprit, DaeError};
pub use integrator::{Integrator, IntegratorError, WorkStats};
pub use linear_solver::{DenseLu, LinearSolver, LinearSolverKind};
pub use options::{AbsTol, BdfOptions, PhaseTimes, Statistics};
pub use problem::{DaeSystem, EvalError, JacobianSource, VarKind};
pub use steady::{steady_state, SteadyOptions, SteadySolver, SteadyStats};
