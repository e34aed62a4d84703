//! Diagnosis: locate where simulation and recordings disagree, name the physics the model
//! leaves out, fit it, and show the improvement on data the fit never saw.
//!
//! | file | concern |
//! |---|---|
//! | `recording.rs` | CSV recordings, column mapping, errors with file and line |
//! | `columns.rs` | which column each role of a model reads by default; derivative-window grids |
//! | `signal.rs` | noise floor, derivatives on irregular grids, autocorrelation |
//! | `model.rs` | the nominal model (torques from measured motion, outputs such as a tracked platform position), its perturbable parameters; the DFKI pendulum and the MR2120 |
//! | `mechanism.rs` | any mechanism built with the multibody API as a nominal model: declared sensors (encoder placement, trackers), joints with play |
//! | `mr2120.rs` | the MR2120's multibody nominal model (the diagnosis' nominal for the MR2120) |
//! | `transmission.rs` | the drive transmissions' wind-up dynamics: one Newmark integrator for the nominal model's wind-up and the candidates' linear response to a joint-side torque |
//! | `model_file.rs` | a TOML model file as the nominal model (`lash diagnose --model FILE.toml`): its sensors make the channels |
//! | `play_dynamics/` | a reduced dynamic model of a universal joint's play along a recording (the drives' transmissions and the joint's play coordinates, linearised about the nominal, the trunnion balls' contact nonlinear): what the quasi-static play candidates leave out; the diagnosis' play-dynamics check refits its selection with it (files: the balls, the system at a sample, the static start, resolved and stiff substeps, small dense algebra) |
//! | `data.rs` | measured motion and torques of one recording, checked against the model |
//! | `candidates.rs` | the library of candidate physics and their regressors |
//! | `stats.rs` | least squares on Gram matrices, cross-validation folds, χ² tail |
//! | `locate.rs` | significant residual windows tied to the mechanism's state |
//! | `adequacy.rs` | after the selection: is what remains noise (noise ratio, whiteness, windows that stay significant, explained fraction per channel), uncertainties that include the misfit, unstable estimates; its module doc states the statistics |
//! | `run.rs` | the entry points [`diagnose`] and [`diagnose_recordings`]: noise floors, localisation, held-out check, the play-dynamics check |
//! | `options.rs` | [`DiagnoseOptions`], every tunable of the diagnosis |
//! | `outcome.rs` | [`Diagnosis`] and its parts (ranking, steps, estimates, confounded pairs, channel fits) |
//! | `error.rs` | [`DiagnoseError`]: why a diagnosis cannot run |
//! | `residuals.rs` | residual assembly for both residual modes: weighted residuals, candidate columns, Gram matrices |
//! | `selection.rs` | ranking, greedy selection by cross-validation and BIC (Occam tie-break), estimates, confounding; its module doc states the statistics (effective samples, tests, the rules for joining) |
//! | `series_joints.rs` | after the last pass, which of two joints in series a contact compliance the data cannot tell apart is named at: the joint whose play is selected |
//! | `play_size.rs` | the found radial play's size, searched with the reduced dynamic play model run at each size |
//! | `equivalents.rs` | selected effects read together (one joint's friction laws summed, Coulomb asymmetry with a sensor offset) |
//! | `relinearize.rs` | the Gauss–Newton re-linearisation around the first estimates |
//! | `verdict.rs` | the one-paragraph verdict in prose |
//! | `format.rs` | number formatting shared by the verdict, the findings and the reports |
//! | `report.rs` | the report folder (Markdown, JSON, plots) |
//! | `suite/` | the concealed-effects suite on synthetic MR2120 recordings and its scoreboard (`multibody.rs`: the proof, from multibody truths; `lumped.rs`: closed-form unit cases) |
//!
//! What was measured on the suite while this module was built — each change tried, kept or
//! dropped, with its run and numbers — is logged in `validation/diagnosis-log.md` (the
//! "diagnosis log" that doc comments here cite by section name).
//! Two residual modes share one selection. Equation error: measured motion → inverse
//! dynamics → compare the measured torques. Output error: the outputs the model predicts
//! from the recorded inputs (for the MR2120, a position-driven 3-DOF mechanism, simulating
//! with the recorded drive angles is its forward kinematics through the compliant drives) →
//! compare the measured outputs (a laser tracker's platform position). Neither needs a time
//! integration, so the parameter sensitivities are central differences of the model (exact
//! to first order, and one Gauss–Newton re-linearisation around the first estimates takes
//! care of effects that are not linear in their parameters).
//!
//! ```no_run
//! use lash::diagnose::{diagnose, data::MotionData, DiagnoseOptions};
//! use lash::diagnose::model::DoublePendulumModel;
//! use lash::diagnose::recording::read_csv;
//! use lash::mechanisms::double_pendulum::{DoublePendulumParams, DFKI_README};
//! use std::path::Path;
//!
//! let model = DoublePendulumModel { params: DoublePendulumParams::from_readme(Path::new(DFKI_README))? };
//! let map: Vec<(String, String)> = [("q1", "pos_filt1"), ("q2", "pos_filt2"), ("qd1", "vel_filt1"),
//!     ("qd2", "vel_filt2"), ("tau1", "tau_meas1"), ("tau2", "tau_meas2")]
//!     .iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
//! let load = |f: &str| -> Result<MotionData, Box<dyn std::error::Error>> {
//!     let rec = read_csv(Path::new(f), "time", &map)?;
//!     // Rates differentiated over ±5 samples; the 5 at each end, where the fit is
//!     // one-sided, left out (as `lash diagnose` leaves out its widest window's).
//!     Ok(MotionData::from_recording(&rec, 2, 5)?.without_ends(5, 0))
//! };
//! let dir = "../shared/data/dfki-double-pendulum/recordings";
//! let fit = vec![load(&format!("{dir}/trajectory_00.csv"))?, load(&format!("{dir}/trajectory_01.csv"))?];
//! let held = vec![load(&format!("{dir}/trajectory_12.csv"))?];
//! let d = diagnose(&model, &fit, &held, &DiagnoseOptions::default(), |_, _| {})?;
//! println!("{}", d.verdict);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod adequacy;
pub mod candidates;
pub mod columns;
pub mod data;
pub mod equivalents;
mod error;
pub mod format;
pub mod impulses;
pub mod locate;
pub mod mechanism;
pub mod model;
pub mod model_file;
pub mod mr2120;
mod options;
mod outcome;
pub mod play_dynamics;
mod play_size;
pub mod recording;
mod relinearize;
pub mod report;
mod residuals;
mod run;
mod selection;
mod series_joints;
pub mod signal;
pub mod stats;
pub mod suite;
pub mod transmission;
mod verdict;

pub use error::DiagnoseError;
pub use options::{DiagnoseOptions, BEARING_PLAY_LOAD_DAMPINGS};
pub use outcome::{
    claimed_name, ChannelFit, Confound, Diagnosis, Estimate, LinearizationStep, PlayProbe, Ranked,
    ResidualTrace, SeriesNaming, Step, UnresolvedPlay,
};
pub use play_size::{
    probe_play_sizes, search_constant_damping, search_load_damping, search_play_size, CONSTANT_DAMPING_STEPS,
    LOAD_DAMPING_STEPS, MAX_CONSTANT_DAMPINGS, MAX_LOAD_DAMPINGS, MAX_PLAY_SIZES, PLAY_SIZE_STEPS,
    PROBE_PLAY_SIZES, PROFILE_SIZES, PROFILE_STEPS,
};
pub use relinearize::{
    CONTINUED_STEP_GAIN, CONVERGED_STEP, MAX_RELINEARIZATIONS, MAX_RESIZES, RESIZE_FACTOR,
    SHIFT_LINEARITY_TOLERANCE,
};
pub use residuals::MAX_UNDEFINED_FRACTION;
pub use run::{diagnose, diagnose_recordings};
