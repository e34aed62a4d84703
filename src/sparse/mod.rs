//! Sparse-matrix plumbing: every sparse structure and factorisation in lash goes through here.
//!
//! * [`CscPattern`] — a validated compressed-sparse-column pattern, declared once per problem.
//! * [`SlotIndex`] — (row, column) → value position, for assembling values entry by entry.
//! * [`CscMatrix`] — values on a shared pattern (the pattern is reference-counted, so a
//!   Jacobian and its copies never duplicate the index arrays).
//! * [`SparseLu`] — faer's sparse LU with the symbolic analysis done once per pattern and the
//!   numeric factorisation redone in place.
//! * [`RefactorLu`] — a sparse LU that reuses the pivot sequence of its last pivoting
//!   factorisation (faer's) while the pivots stay acceptable: the numbers only, no search.
//! * [`BlockSchurLu`] — small diagonal blocks eliminated densely first, the sparse LU on the
//!   Schur complement of what remains.
//! * [`DenseLu`] — dense LU with partial pivoting for the multibody analyses' small
//!   systems, solving with A and Aᵀ from one factorisation.
//! * [`column_colouring`] — a greedy colouring of the columns so a finite-difference Jacobian
//!   needs one residual evaluation per colour rather than per column.

mod colouring;
mod dense;
mod lu;
mod pattern;
mod refactor;
mod schur;

pub use colouring::column_colouring;
pub use dense::DenseLu;
pub use lu::{LinearSolveError, SparseLu, SUPERNODAL_THRESHOLD};
pub use pattern::{CscMatrix, CscPattern, PatternError, SlotIndex};
pub use refactor::{RefactorLu, REUSE_PIVOT_THRESHOLD};
pub use schur::{BlockSchurLu, MAX_GROUP};
