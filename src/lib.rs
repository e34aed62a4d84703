//! # lash
//!
//! Mechanisms whose joints have play (clearance), simulated with an implicit stiff-DAE
//! integrator on sparse linear algebra — and an explanation of why a simulation disagrees
//! with measurements.
//!
//! The crate is layered, each layer depending only on the ones before it:
//!
//! 1. [`sparse`] — compressed-sparse-column patterns, column colouring, and the sparse LU
//!    (faer) that every implicit solve goes through. All sparse-matrix plumbing lives here.
//! 2. [`dae`] — a generic residual-form DAE integrator F(t, y, y', p) = 0: variable-order,
//!    variable-step BDF in the style of SUNDIALS IDA, consistent initial values, dense output,
//!    events; plus explicit baselines (Dormand–Prince 5(4), symplectic Euler). No mechanics.
//! 3. [`multibody`] — rigid bodies, joints, drivers, forces, the GGL equations of motion with
//!    an analytic sparse Jacobian, analyses and the simulation pipeline.
//! 4. [`contact`] — contact laws, Hertz stiffness, clearance bearings, joints with clearance.
//! 5. [`mechanisms`] — the WUT MR2120 (ideal and clearance models, the paper's studies), the
//!    DFKI pendulum, a clearance chain; [`model_file`] — any mechanism from a TOML model file
//!    (bodies, joints with or without clearance, drivers, forces, sensors, parameters).
//! 6. [`diagnose`] — where a model and recordings disagree, the missing physics, its fit and
//!    the held-out improvement; [`design`] — the allowable clearance for a required
//!    accuracy (first order and verified by the nonlinear equilibria).
//!
//! A multibody model is a constant [`multibody::Mechanism`] beside a
//! [`multibody::MechanismData`] (state and scratch), with typed access by handle and every
//! address from one [`multibody::Layout`]; a simulation's tunables are one
//! [`multibody::SimulationOptions`].
//!
//! [`validation`] holds published reference problems (Andrews' squeezer, the turning stiff
//! spring, Robertson, a GGL pendulum) with their reference values, run by `lash validate`
//! and by the test suite; its sources live in the top-level `validation/` folder.
//! `plot` (feature `plot`) draws PNG/SVG charts with a bundled font.
//!
//! Beside them: [`peers`] (diffsol's BDF as an independent cross-check) and [`mod@bench`]
//! (side-by-side benchmarks behind `lash bench`), which use the layers above.
//!
//! ## Features
//!
//! The solver and mechanics layers build with `default-features = false` and pull in none of
//! the command-line stack. Default features, all on:
//!
//! * `cli` — what the `lash` binary needs: clap (arguments) and indicatif (progress bars).
//!   The library itself has no CLI code; the binary requires all three features.
//! * `plot` — plotters: the `plot` module and every chart the library draws (the residual
//!   plots of [`diagnose::report`], the MR2120 trajectory charts of
//!   [`mechanisms::mr2120::output`], `bench::charts`). Without it the same reports and CSV
//!   files are written, without plots.
//! * `peers` — diffsol: [`peers`]' solvers and the diffsol rows of [`mod@bench`].
//!
//! ```toml
//! lash = { path = "../lash", default-features = false }
//! ```
//!
//! All quantities are SI unless a doc comment says otherwise.
#![warn(missing_docs)]

pub mod bench;
pub mod contact;
pub mod dae;
pub mod design;
pub mod diagnose;
pub mod mechanisms;
pub mod model_file;
pub mod multibody;
pub mod peers;
#[cfg(feature = "plot")]
pub mod plot;
pub mod sparse;

#[path = "../validation/mod.rs"]
pub mod validation;

/// The README's code blocks, compiled and run as doc tests.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
