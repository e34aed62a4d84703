//! The simulation pipeline (named stages, as in MuJoCo's): validate → assemble the initial
//! state (positions, velocities, accelerations and forces) → integrate the GGL equations with
//! the BDF → sample outputs, watching the constraint Jacobian for singular configurations.
//!
//! # Options
//! [`SimulationOptions`] reaches every tunable of a simulation; each has exactly one default,
//! listed here (`SimulationOptions::default()`). This table is the one place where the
//! multibody layer's defaults differ from the integrator's ([`BdfOptions::default`]); every
//! `bdf` field not listed keeps the integrator's default.
//!
//! | field | tunable | default | `BdfOptions::default()` |
//! |---|---|---|---|
//! | `bdf.rtol` | relative tolerance | 1e-8 | 1e-6 |
//! | `bdf.atol` | absolute tolerance (m, rad, m/s, rad/s alike) | 1e-9 (scalar) | 1e-6 |
//! | `bdf.suppress_algebraic` | leave λ, μ, ν out of the error test | `true` | `false` |
//! | `bdf.max_steps` | steps between two output samples | 200 000 | 500 000 |
//! | `bdf.max_newton_iters` | Newton iterations per step before retrying smaller | 8 | 4 |
//! | `bdf.max_jacobian_refreshes_in_solve` | matrix rebuilds within one step | 2 | 0 |
//! | `bdf.step_ceiling_after_newton_failure` | steps stay below this fraction of a grown step whose Newton iteration failed | 0.3 | none (∞) |
//! | `bdf.step_ceiling_relaxation` | the ceiling's rise per accepted step | 1.2 | 1.2 |
//! | `bdf.linear_solver` | how iteration matrices are factorised | block elimination of each body's positions and ν, then sparse LU (`BlockSchurLu`) | sparse LU |
//! | `assembly.max_iterations` | Gauss–Newton iterations of position assembly | 50 | – |
//! | `assembly.tolerance` | constraint residual accepted by assembly | 1e-12 | – |
//! | `formulation.analytic_jacobian` | analytic (or finite-difference) iteration matrix | `true` | – |
//! | `formulation.velocities_index2` | velocities as index-2 variables in the error test | `false` | – |
//! | `formulation.force_fd_step` | relative difference step for force elements without derivatives | 1e-9 | – |
//! | `singularity_warning` | singularity measure below which a warning is recorded | 1e-3 | – |
//! | `measure_singularity` | the singularity measure at every output sample (an SVD each) | `true` | – |
//!
//! Why they differ: positions are in metres and the effects studied (joint clearances) are
//! micrometres, so the tolerances are tighter than the integrator's generic 1e-6. The
//! multipliers λ, μ, ν are algebraic (index 2 and 3): their local error estimates do not
//! measure the accuracy of the motion and would only shrink the steps, so they stay out of
//! the error test. `max_steps` counts the steps of one call of the integrator (between two
//! output samples), so a run that crawls stops with an error sooner. 8 Newton iterations
//! (IDA: 4) and two matrix rebuilds within a step suit stiff contact: a contact that
//! switches on within the step makes the iteration crawl, and failing the step costs more
//! than a few iterations. Measured on the MR2120 clearance model (L1,
//! first 1.5 s, `lash bench mr2120`): 25–45 % less wall time at rtol 1e-4…1e-7 than 4
//! iterations without rebuilds.
//! Where contacts switch, the Newton iteration rather than the error test limits the step:
//! IDA's rule after a failed iteration (a quarter of the step, then doubling) grows straight
//! back into the next failure, so a step that had just grown and whose iteration failed sets
//! a ceiling of 0.3 of its size, rising 1.2× per accepted step; a failure at an unchanged or
//! smaller step sets none. Measured in one sweep (`lash bench mr2120`, whole 4 s L1 run,
//! reference rtol 1e-6, plain sparse LU): at rtol 1e-4 / 1e-5, 1.17 / 14.7 s with a ceiling
//! of half after every failure, 1.12 / 7.1 s with this rule (without a ceiling: 2.06 / 7.45 s
//! in an earlier sweep).
//! The iteration matrix is factorised after eliminating each body's positions and
//! normalisation multiplier (their block is α·I plus small terms; `eliminable_blocks` of
//! [`MultibodyDae`]), so the sparse LU works on velocities and multipliers only (218 → 114
//! unknowns on the 63-DOF MR2120): measured on one of its matrices, 128 µs per plain sparse
//! LU; in `lash bench mr2120` at rtol 1e-4 / 1e-5, 1.12 / 7.1 s → 0.99 / 3.0 s for the whole
//! run. Side by side (5 alternated whole-process pairs of `lash mr2120 trajectory --clearance
//! L1`, both rules together against the half-after-every-failure ceiling on the plain LU):
//! 0.70× the wall time.

use super::analysis::{Analysis, AssemblyOptions, Reaction};
use super::data::MechanismData;
use super::error::ModelError;
use super::formulation::{FormulationOptions, Layout, MultibodyDae};
use super::model::Mechanism;
use crate::dae::{AbsTol, BdfOptions, BdfSolver, LinearSolverKind, Statistics};
use serde::Serialize;
use std::sync::Arc;

/// Every tunable of a simulation; the defaults are listed in the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// The integrator's settings.
    pub bdf: BdfOptions,
    /// Position assembly (initial state and analyses).
    pub assembly: AssemblyOptions,
    /// The equations of motion.
    pub formulation: FormulationOptions,
    /// Singularity measure (see [`Analysis::singularity_measure`]) below which a warning is
    /// recorded.
    pub singularity_warning: f64,
    /// Measure the singularity at every output sample ([`Sample::singularity`], the
    /// warnings). `false` for a caller that reads neither: the samples' measure is then NaN
    /// (not measured) and no warnings are recorded, but a failed step still measures the
    /// last sample to tell a stop at a singular configuration from an error (the same
    /// decision as with the measure on). The measure is an SVD of the constraint Jacobian
    /// per output sample: 8 % of a multibody truth simulation and diagnosis in a profile.
    pub measure_singularity: bool,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            bdf: BdfOptions {
                suppress_algebraic: true,
                max_steps: 200_000,
                max_newton_iters: 8,
                max_jacobian_refreshes_in_solve: 2,
                step_ceiling_after_newton_failure: 0.3,
                step_ceiling_relaxation: 1.2,
                linear_solver: LinearSolverKind::BlockSchurLu,
                ..BdfOptions::with_tolerances(1e-8, 1e-9)
            },
            assembly: AssemblyOptions::default(),
            formulation: FormulationOptions::default(),
            singularity_warning: 1e-3,
            measure_singularity: true,
        }
    }
}

impl SimulationOptions {
    /// The defaults with the integrator's relative tolerance `rtol` and scalar absolute
    /// tolerance `atol`.
    pub fn with_tolerances(rtol: f64, atol: f64) -> Self {
        let mut o = Self::default();
        o.bdf.rtol = rtol;
        o.bdf.atol = AbsTol::Scalar(atol);
        o
    }
}

/// One output sample. Typed access by handle: [`body_position`](Self::body_position),
/// [`body_velocity`](Self::body_velocity), [`reaction`](Self::reaction),
/// [`driver_effort`](Self::driver_effort), …
#[derive(Debug, Clone, Serialize)]
pub struct Sample {
    /// Time, s.
    pub t: f64,
    /// Positions (r, p) per body (see [`Layout::body_q`]).
    pub q: Vec<f64>,
    /// Velocities (v, ω') per body (see [`Layout::body_w`]).
    pub w: Vec<f64>,
    /// Constraint multipliers (joints, then drivers; see [`Layout::joint_lambda`]).
    pub lambda: Vec<f64>,
    /// Singularity measure of the constraint Jacobian (1 good, 0 singular; NaN where
    /// [`SimulationOptions::measure_singularity`] is off).
    pub singularity: f64,
}

/// A recorded approach to a singular configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SingularityEvent {
    /// Time, s.
    pub t: f64,
    /// Measure there.
    pub measure: f64,
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum RunEnd {
    /// All requested samples were produced.
    Completed,
    /// The integrator stopped near a singular configuration; the samples before it stand.
    StoppedAtSingularity {
        /// Time of the last good sample, s.
        t: f64,
        /// Singularity measure there.
        measure: f64,
        /// The integrator's error.
        error: String,
    },
}

/// The result of [`Simulation::run`].
#[derive(Debug, Clone, Serialize)]
pub struct Trajectory {
    /// Output samples.
    pub samples: Vec<Sample>,
    /// First sample below the warning threshold, and the smallest measure seen.
    pub singularity_warnings: Vec<SingularityEvent>,
    /// How the run ended.
    pub end: RunEnd,
}

/// Most output times one run may ask for (each sample keeps every body's state: for the
/// MR2120's 13 bodies ~1 kB, so 10⁷ samples ~10 GB).
pub const MAX_OUTPUT_TIMES: usize = 10_000_000;

/// How many output times a run sampled every `dt` s up to `t_end` s has: t_end/dt rounded,
/// at least 1. Refused ([`ModelError::Output`]) unless both are positive and finite, the
/// times are finite and there are at most [`MAX_OUTPUT_TIMES`].
pub fn output_count(t_end: f64, dt: f64) -> Result<usize, ModelError> {
    if !(t_end > 0.0 && t_end.is_finite() && dt > 0.0 && dt.is_finite()) {
        return Err(ModelError::Output(format!(
            "the end time ({t_end:e} s) and the sample interval ({dt:e} s) must be positive and finite"
        )));
    }
    let n = (t_end / dt).round().max(1.0);
    if n > MAX_OUTPUT_TIMES as f64 {
        return Err(ModelError::Output(format!(
            "{t_end:e} s sampled every {dt:e} s is {n:.3e} output times, more than the {MAX_OUTPUT_TIMES} one run may keep"
        )));
    }
    if !(n * t_end).is_finite() {
        return Err(ModelError::Output(format!(
            "the end time {t_end:e} s is too large"
        )));
    }
    Ok(n as usize)
}

/// The output times of a run sampled every `dt` s up to `t_end` s: k·t_end/n for k = 1…n,
/// n = [`output_count`].
pub fn output_times(t_end: f64, dt: f64) -> Result<Vec<f64>, ModelError> {
    let n = output_count(t_end, dt)?;
    Ok((1..=n)
        .map(|k| (k as f64 * t_end / n as f64).min(t_end))
        .collect())
}

/// A running simulation of a mechanism.
#[derive(Debug)]
pub struct Simulation {
    model: Arc<Mechanism>,
    solver: BdfSolver<MultibodyDae>,
    analysis: Analysis,
    data: MechanismData,
    opts: SimulationOptions,
}

impl Simulation {
    /// Validates the model, computes a consistent initial state at `t0` and sets up the
    /// integrator.
    pub fn new(model: Arc<Mechanism>, t0: f64, opts: SimulationOptions) -> Result<Self, ModelError> {
        let analysis = Analysis::with_options(&model, opts.assembly)?;
        let mut data = MechanismData::new(&model);
        let s0 = analysis.initial_state(&model, &mut data, t0)?;
        let dae = MultibodyDae::with_options(model.clone(), opts.formulation)?;
        let lay = dae.layout();
        let mut y0 = vec![0.0; lay.dim()];
        let mut yp0 = vec![0.0; lay.dim()];
        y0[lay.y_q()].copy_from_slice(&s0.q);
        y0[lay.y_w()].copy_from_slice(&s0.w);
        y0[lay.y_lambda()].copy_from_slice(&s0.lambda);
        // q̇ = H w at the initial state.
        for (h, _) in model.bodies().iter() {
            let p = s0.body_euler_parameters(h);
            let om = s0.body_angular_velocity(h);
            let pd = 0.5 * super::rotation::l_matrix(&p).transpose() * om;
            let qr = lay.body_q(h);
            yp0[qr.start..qr.start + 3].copy_from_slice(s0.body_velocity(h).as_slice());
            yp0[qr.start + 3..qr.end].copy_from_slice(pd.as_slice());
        }
        yp0[lay.y_w()].copy_from_slice(&s0.wdot);
        let solver = BdfSolver::new(dae, t0, &y0, &yp0, &[], opts.bdf.clone())?;
        Ok(Self {
            model,
            solver,
            analysis,
            data,
            opts,
        })
    }

    /// Index layout of the state.
    pub fn layout(&self) -> &Layout {
        self.model.layout()
    }

    /// Integrator statistics so far.
    pub fn stats(&self) -> &Statistics {
        self.solver.stats()
    }

    /// The model.
    pub fn model(&self) -> &Mechanism {
        &self.model
    }

    /// The analyses' settings (use them with [`model`](Self::model) and a
    /// [`MechanismData`]).
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The data at the last sample (t, q, w, ẇ, λ).
    pub fn data(&self) -> &MechanismData {
        &self.data
    }

    /// Largest |Φ_k(q, t)| over the constraints and Euler-parameter normalisations (drift)
    /// at (q, t). Evaluates in a scratch copy of the data's (an allocation per call).
    pub fn constraint_residual(&self, t: f64, q: &[f64]) -> f64 {
        Analysis::residual_in(&mut self.data.ev.clone(), t, q)
    }

    fn sample(&mut self) -> Sample {
        let lay = self.model.layout();
        let y = self.solver.y();
        let s = Sample {
            t: self.solver.t(),
            q: y[lay.y_q()].to_vec(),
            w: y[lay.y_w()].to_vec(),
            lambda: y[lay.y_lambda()].to_vec(),
            singularity: 0.0,
        };
        self.data.t = s.t;
        self.data.q.clone_from(&s.q);
        self.data.w.clone_from(&s.w);
        self.data.lambda.clone_from(&s.lambda);
        self.data.wdot.copy_from_slice(&self.solver.yp()[lay.y_w()]);
        // In the simulation's own scratch: no copy per output sample.
        let measure = if self.opts.measure_singularity {
            self.analysis.singularity_in(&mut self.data.ev, s.t, &s.q)
        } else {
            f64::NAN
        };
        Sample {
            singularity: measure,
            ..s
        }
    }

    /// Integrates through `times` (increasing), sampling at each; `progress` is called with
    /// each sample time. Stops early, with the samples so far, if the integrator fails near a
    /// singular configuration; any other failure is an error.
    pub fn run(&mut self, times: &[f64], mut progress: impl FnMut(f64)) -> Result<Trajectory, ModelError> {
        self.run_dyn(times, &mut progress)
    }

    /// [`run`](Self::run) compiled once (the progress callback behind a reference).
    fn run_dyn(&mut self, times: &[f64], progress: &mut dyn FnMut(f64)) -> Result<Trajectory, ModelError> {
        let mut samples: Vec<Sample> = Vec::with_capacity(times.len());
        let mut warnings: Vec<SingularityEvent> = vec![];
        let mut min_seen: Option<SingularityEvent> = None;
        for &t in times {
            if let Err(e) = self.solver.solve_to(t) {
                let last = match samples.last() {
                    // Not measured along the run: measured here, where it decides.
                    Some(s) if s.singularity.is_nan() => {
                        (s.t, self.analysis.singularity_in(&mut self.data.ev, s.t, &s.q))
                    }
                    Some(s) => (s.t, s.singularity),
                    None => (self.solver.t(), 1.0),
                };
                if last.1 < self.opts.singularity_warning.sqrt() {
                    if let Some(m) = min_seen {
                        warnings.push(m);
                    }
                    return Ok(Trajectory {
                        samples,
                        singularity_warnings: warnings,
                        end: RunEnd::StoppedAtSingularity {
                            t: last.0,
                            measure: last.1,
                            error: e.to_string(),
                        },
                    });
                }
                return Err(ModelError::Integration(e));
            }
            let s = self.sample();
            if s.singularity < self.opts.singularity_warning {
                let ev = SingularityEvent {
                    t: s.t,
                    measure: s.singularity,
                };
                if warnings.is_empty() {
                    warnings.push(ev.clone());
                }
                if min_seen.as_ref().is_none_or(|m| ev.measure < m.measure) {
                    min_seen = Some(ev);
                }
            }
            progress(s.t);
            samples.push(s);
        }
        if let Some(m) = min_seen {
            if warnings.first() != Some(&m) {
                warnings.push(m);
            }
        }
        Ok(Trajectory {
            samples,
            singularity_warnings: warnings,
            end: RunEnd::Completed,
        })
    }

    /// Reactions of the joints present (in insertion order) at a sample; see
    /// [`Sample::reaction`] for one joint by handle.
    pub fn reactions(&self, s: &Sample) -> Vec<Reaction> {
        self.analysis.reactions(&self.model, s.t, &s.q, &s.lambda)
    }
}
