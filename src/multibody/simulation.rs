//! The simulation pipeline (named stages, as in MuJoCo's): validate → assemble the initial
//! state (positions, velocities, accelerations and forces) → integrate the GGL equations with
//! the BDF → sample outputs, watching the constraint Jacobian for singular configurations.

use super::analysis::{Analysis, Reaction};
use super::error::ModelError;
use super::formulation::{Layout, MultibodyDae};
use super::model::Mechanism;
use crate::dae::{BdfOptions, BdfSolver, Statistics};
use serde::Serialize;
use std::sync::Arc;

/// Every tunable of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// Relative tolerance of the integrator.
    pub rtol: f64,
    /// Absolute tolerance of the integrator (m, rad, m/s, rad/s alike).
    pub atol: f64,
    /// Singularity measure (see [`Analysis::singularity_measure`]) below which a warning is
    /// recorded.
    pub singularity_warning: f64,
    /// Maximum integrator steps between two output samples.
    pub max_steps: usize,
    /// Filter the BDF's local error estimates through the iteration matrix (see
    /// `dae::bdf::estimate`): transients along stiff contact directions then no longer force
    /// tiny steps.
    pub filter_error_estimate: bool,
    /// Measure velocity errors as index-2 variables (scaled by the step), as for very stiff
    /// mechanical systems (see `DaeSystem::error_index`).
    pub velocities_index2: bool,
    /// Newton iterations allowed per step before the step is retried smaller. The default, 8
    /// (IDA: 4), and two matrix rebuilds within a step suit stiff contact: a contact that
    /// switches on within the step makes the iteration crawl, and failing the step costs more
    /// than a few iterations. Measured on the MR2120 clearance model (L1, first 1.5 s,
    /// `lash bench mr2120`): 25–45 % less wall time at rtol 1e-4…1e-7 than 4 iterations
    /// without rebuilds.
    pub max_newton_iters: usize,
    /// Times the Newton matrix may be rebuilt within one step when the iteration converges
    /// slowly (see [`BdfOptions::max_jacobian_refreshes_in_solve`]).
    pub max_jacobian_refreshes_in_solve: usize,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: 1e-9,
            singularity_warning: 1e-3,
            max_steps: 200_000,
            filter_error_estimate: false,
            velocities_index2: false,
            max_newton_iters: 8,
            max_jacobian_refreshes_in_solve: 2,
        }
    }
}

/// One output sample.
#[derive(Debug, Clone, Serialize)]
pub struct Sample {
    /// Time, s.
    pub t: f64,
    /// Positions (r, p) per body.
    pub q: Vec<f64>,
    /// Velocities (v, ω') per body.
    pub w: Vec<f64>,
    /// Constraint multipliers (joints, then drivers).
    pub lambda: Vec<f64>,
    /// Singularity measure of the constraint Jacobian (1 good, 0 singular).
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

/// A running simulation of a mechanism.
#[derive(Debug)]
pub struct Simulation {
    solver: BdfSolver<MultibodyDae>,
    analysis: Analysis,
    layout: Layout,
    opts: SimulationOptions,
}

impl Simulation {
    /// Validates the model, computes a consistent initial state at `t0` and sets up the
    /// integrator.
    pub fn new(model: Arc<Mechanism>, t0: f64, opts: SimulationOptions) -> Result<Self, ModelError> {
        let mut analysis = Analysis::new(model.clone())?;
        let s0 = analysis.initial_state(t0)?;
        let mut dae = MultibodyDae::new(model);
        dae.velocities_index2 = opts.velocities_index2;
        let lay = dae.layout();
        let mut y0 = vec![0.0; lay.dim()];
        let mut yp0 = vec![0.0; lay.dim()];
        y0[..7 * lay.nb].copy_from_slice(&s0.q);
        y0[7 * lay.nb..13 * lay.nb].copy_from_slice(&s0.w);
        y0[lay.lambda()..lay.lambda() + lay.m].copy_from_slice(&s0.lambda);
        // q̇ = H w at the initial state.
        for b in 0..lay.nb {
            let p =
                nalgebra::Vector4::new(s0.q[7 * b + 3], s0.q[7 * b + 4], s0.q[7 * b + 5], s0.q[7 * b + 6]);
            let om = nalgebra::Vector3::new(s0.w[6 * b + 3], s0.w[6 * b + 4], s0.w[6 * b + 5]);
            let pd = 0.5 * super::rotation::l_matrix(&p).transpose() * om;
            yp0[7 * b..7 * b + 3].copy_from_slice(&s0.w[6 * b..6 * b + 3]);
            yp0[7 * b + 3..7 * b + 7].copy_from_slice(pd.as_slice());
        }
        yp0[7 * lay.nb..13 * lay.nb].copy_from_slice(&s0.wdot);
        let bdf = BdfOptions {
            suppress_algebraic: true,
            max_steps: opts.max_steps,
            filter_error_estimate: opts.filter_error_estimate,
            max_newton_iters: opts.max_newton_iters,
            max_jacobian_refreshes_in_solve: opts.max_jacobian_refreshes_in_solve,
            ..BdfOptions::with_tolerances(opts.rtol, opts.atol)
        };
        let solver = BdfSolver::new(dae, t0, &y0, &yp0, &[], bdf)?;
        Ok(Self {
            solver,
            analysis,
            layout: lay,
            opts,
        })
    }

    /// Index layout of the state.
    pub fn layout(&self) -> Layout {
        self.layout
    }

    /// Integrator statistics so far.
    pub fn stats(&self) -> &Statistics {
        self.solver.stats()
    }

    /// The analyses on the same model (reactions, drift, measures).
    pub fn analysis(&mut self) -> &mut Analysis {
        &mut self.analysis
    }

    fn sample(&mut self) -> Sample {
        let lay = self.layout;
        let y = self.solver.y();
        let q = y[..7 * lay.nb].to_vec();
        let s = Sample {
            t: self.solver.t(),
            w: y[7 * lay.nb..13 * lay.nb].to_vec(),
            lambda: y[lay.lambda()..lay.lambda() + lay.m].to_vec(),
            singularity: 0.0,
            q,
        };
        let measure = self.analysis.singularity_measure(s.t, &s.q);
        Sample {
            singularity: measure,
            ..s
        }
    }

    /// Integrates through `times` (increasing), sampling at each; `progress` is called with
    /// each sample time. Stops early, with the samples so far, if the integrator fails near a
    /// singular configuration; any other failure is an error.
    pub fn run(&mut self, times: &[f64], mut progress: impl FnMut(f64)) -> Result<Trajectory, ModelError> {
        let mut samples = Vec::with_capacity(times.len());
        let mut warnings: Vec<SingularityEvent> = vec![];
        let mut min_seen: Option<SingularityEvent> = None;
        for &t in times {
            if let Err(e) = self.solver.solve_to(t) {
                let last = samples
                    .last()
                    .map(|s: &Sample| (s.t, s.singularity))
                    .unwrap_or((self.solver.t(), 1.0));
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

    /// Joint reactions at a sample.
    pub fn reactions(&mut self, s: &Sample) -> Vec<Reaction> {
        self.analysis.reactions(s.t, &s.q, &s.lambda)
    }
}
