//! Settings of the MR2120 benchmark ([`bench_mr2120`](super::mr2120::bench_mr2120)): their
//! defaults, their check, and why a run cannot start. Re-exported from
//! [`bench::mr2120`](super::mr2120).

use crate::contact::Damping;
use crate::mechanisms::mr2120::clearance::clearance_set;
use crate::mechanisms::mr2120::trajectory;
use crate::mechanisms::mr2120::Mr2120Error;

/// Why the MR2120 benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The model could not be built.
    #[error(transparent)]
    Model(#[from] Mr2120Error),
    /// The tight-tolerance reference run failed, so no accuracy can be measured.
    #[error("the reference run failed: {0}")]
    Reference(String),
    /// A setting is out of range ([`Mr2120BenchOptions::validate`]).
    #[error("invalid benchmark settings: {0}")]
    Invalid(String),
    /// Runs of diffsol's BDF were asked for, but lash was built without the `peers` feature.
    #[error("diffsol runs asked for (diffsol_rtols {0:?}) but lash was built without the `peers` feature")]
    PeersDisabled(Vec<f64>),
}

/// Settings of the MR2120 benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct Mr2120BenchOptions {
    /// Clearance set (L1, L2, L3).
    pub set: String,
    /// End of the trajectory, s (the paper's trajectory ends at
    /// [`trajectory::DURATION`], 4 s).
    pub t_end: f64,
    /// Interval of the output samples at which accuracy is measured, s.
    pub dt: f64,
    /// Target accuracy: largest platform-centre distance from the reference, m.
    pub target: f64,
    /// Relative tolerance of the reference run (lash BDF; atol = rtol/100 m).
    pub reference_rtol: f64,
    /// Relative tolerances swept for lash's BDF (atol = rtol/100).
    pub bdf_rtols: Vec<f64>,
    /// Relative tolerances swept for Dormand–Prince (atol = rtol/100).
    pub dopri_rtols: Vec<f64>,
    /// Fixed steps swept for symplectic Euler, s.
    pub symplectic_steps: Vec<f64>,
    /// Relative tolerances swept for diffsol's BDF on the index-1 ODE (atol = rtol/100).
    pub diffsol_rtols: Vec<f64>,
    /// Also check the reference with Dormand–Prince at this tolerance (None: skip).
    pub reference_check_rtol: Option<f64>,
    /// Contact damping of the bearings (see [`BENCH_DAMPING`]).
    pub damping: Damping,
    /// Wall-time budget of each explicit run, s: a run that exhausts it stops and reports
    /// how far it got, and the time ratio becomes a lower bound.
    pub explicit_budget_s: f64,
}

/// Contact damping of the benchmark: lubricated steel joints
/// ([`LUBRICATED_DAMPING`](crate::mechanisms::mr2120::clearance::LUBRICATED_DAMPING),
/// Hunt–Crossley α = 300 s/m; impacts above ~5 mm/s are fully damped). With the studies' near-elastic default
/// ([`DEFAULT_DAMPING`](crate::mechanisms::mr2120::clearance::DEFAULT_DAMPING), α = 1 s/m) the 63-DOF model rattles inside its clearances for the
/// whole run and the motion is chaotic: BDF runs at rtol 1e-4, 1e-5 and 1e-6 differ from each
/// other by 20–40 µm at every time (measured over the first second), so no run is within 1 µm
/// of any "reference" and equal-accuracy timing has no meaning. With α = 300 s/m runs at
/// 1e-5 and 1e-6 agree to ~1 µm.
pub const BENCH_DAMPING: Damping = crate::mechanisms::mr2120::clearance::LUBRICATED_DAMPING;

/// The Hunt–Crossley factor α of [`BENCH_DAMPING`], s/m.
pub const BENCH_ALPHA: f64 = crate::mechanisms::mr2120::clearance::LUBRICATED_ALPHA;

impl Default for Mr2120BenchOptions {
    fn default() -> Self {
        Self {
            set: "L1".into(),
            t_end: trajectory::DURATION,
            dt: 0.01,
            target: 1e-6,
            reference_rtol: 1e-8,
            bdf_rtols: vec![1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7],
            dopri_rtols: vec![1e-5],
            symplectic_steps: vec![5e-7],
            // Only when the peer is built in: without it, asking for them is an error.
            diffsol_rtols: if cfg!(feature = "peers") {
                vec![1e-4, 1e-6]
            } else {
                vec![]
            },
            reference_check_rtol: None,
            damping: BENCH_DAMPING,
            explicit_budget_s: 600.0,
        }
    }
}

impl Mr2120BenchOptions {
    /// Checks the settings: a known clearance set, 0 < `t_end` ≤ [`trajectory::DURATION`],
    /// positive `dt`, `target` and `reference_rtol`, positive finite swept tolerances and
    /// steps (and reference check), a non-negative Hunt–Crossley α, and no diffsol runs when
    /// lash is built without the `peers` feature ([`BenchError::PeersDisabled`]).
    pub fn validate(&self) -> Result<(), BenchError> {
        clearance_set(&self.set)?;
        let positive = |x: f64| x > 0.0 && x.is_finite();
        let valid = self.t_end > 0.0
            && self.t_end <= trajectory::DURATION
            && positive(self.dt)
            && positive(self.target)
            && positive(self.reference_rtol);
        if !valid {
            return Err(BenchError::Invalid(format!(
                "need 0 < t_end <= {} s, dt > 0, target > 0 and reference_rtol > 0",
                trajectory::DURATION
            )));
        }
        let lists = [
            ("bdf_rtols", &self.bdf_rtols),
            ("dopri_rtols", &self.dopri_rtols),
            ("symplectic_steps", &self.symplectic_steps),
            ("diffsol_rtols", &self.diffsol_rtols),
        ];
        for (name, list) in lists {
            if let Some(x) = list.iter().find(|x| !positive(**x)) {
                return Err(BenchError::Invalid(format!(
                    "{name}: {x} is not a positive number"
                )));
            }
        }
        if let Some(x) = self.reference_check_rtol.filter(|x| !positive(*x)) {
            return Err(BenchError::Invalid(format!(
                "reference_check_rtol: {x} is not a positive number"
            )));
        }
        if let Damping::HuntCrossley(alpha) = self.damping {
            if alpha.is_nan() || alpha < 0.0 {
                return Err(BenchError::Invalid(format!(
                    "the Hunt–Crossley factor must be >= 0 s/m, got {alpha}"
                )));
            }
        }
        if !cfg!(feature = "peers") && !self.diffsol_rtols.is_empty() {
            return Err(BenchError::PeersDisabled(self.diffsol_rtols.clone()));
        }
        Ok(())
    }
}
