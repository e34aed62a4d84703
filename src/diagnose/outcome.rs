//! What a diagnosis returns: the ranking, the greedy steps, the estimates with their
//! uncertainty, the confounded pairs, the per-channel fit before and after, and the verdict.

use super::locate::Location;
use serde::Serialize;

/// A candidate's test at the nominal model.
#[derive(Debug, Clone, Serialize)]
pub struct Ranked {
    /// Candidate.
    pub candidate: String,
    /// Likelihood-ratio statistic against the nominal model (effective samples).
    pub statistic: f64,
    /// Its p-value.
    pub p_value: f64,
    /// Cross-validated residual RMS with this candidate alone, relative to nominal.
    pub cv_ratio: f64,
    /// Its fitted parameters alone lie in their physically plausible ranges.
    pub plausible: bool,
}

/// One step of the greedy selection.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Candidate added.
    pub added: String,
    /// Likelihood-ratio statistic of the addition.
    pub statistic: f64,
    /// p-value.
    pub p_value: f64,
    /// Cross-validated weighted residual RMS after adding it (noise-floor units).
    pub cv_rms: f64,
    /// Effective BIC after adding it.
    pub bic: f64,
}

/// An estimated parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// Candidate.
    pub candidate: String,
    /// Parameter with unit.
    pub parameter: String,
    /// Value.
    pub value: f64,
    /// Standard deviation (effective-sample corrected).
    pub std: f64,
}

/// A pair of effects the data cannot tell apart.
#[derive(Debug, Clone, Serialize)]
pub struct Confound {
    /// The selected effect.
    pub selected: String,
    /// An alternative that fits (cross-validated) as well.
    pub alternative: String,
    /// Cross-validated RMS with the alternative / with the selection.
    pub cv_ratio: f64,
    /// The recording that would separate them.
    pub experiment: String,
}

/// Residual of one torque channel before and after the fit.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFit {
    /// Channel name.
    pub channel: String,
    /// Unit of the values below (N m for torques).
    pub unit: String,
    /// Noise floor of the measured channel (in `unit`).
    pub noise_floor: f64,
    /// RMS on the fit recordings, nominal model, N·m.
    pub fit_before: f64,
    /// RMS on the fit recordings, fitted model, N·m.
    pub fit_after: f64,
    /// RMS on the held-out recordings, nominal model, N·m.
    pub holdout_before: f64,
    /// RMS on the held-out recordings, fitted model, N·m.
    pub holdout_after: f64,
    /// 1 − after/before on the held-out recordings.
    pub holdout_reduction: f64,
}

/// Residual time series of one held-out recording and channel (for plots).
#[derive(Debug, Clone, Serialize)]
pub struct ResidualTrace {
    /// Recording.
    pub recording: String,
    /// Channel.
    pub channel: String,
    /// Unit of the residuals.
    pub unit: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Nominal residual, N·m.
    pub before: Vec<f64>,
    /// Fitted residual, N·m.
    pub after: Vec<f64>,
}

/// The outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// Model.
    pub model: String,
    /// Fit recordings.
    pub fit_recordings: Vec<String>,
    /// Held-out recordings.
    pub holdout_recordings: Vec<String>,
    /// Samples × channels in the fit.
    pub samples: usize,
    /// Effective independent samples.
    pub effective_samples: f64,
    /// Where the nominal residual is significant, tied to the mechanism's state.
    pub location: Location,
    /// Every candidate's test at the nominal model, strongest first.
    pub ranking: Vec<Ranked>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// Selected effects, in order.
    pub selected: Vec<String>,
    /// Estimates.
    pub estimates: Vec<Estimate>,
    /// Estimate pairs correlated beyond ±0.8: (a, b, correlation).
    pub correlations: Vec<(String, String, f64)>,
    /// Effects the data cannot separate.
    pub confounded: Vec<Confound>,
    /// Per channel, before/after.
    pub channels: Vec<ChannelFit>,
    /// True if nothing significant is missing.
    pub no_significant_mismatch: bool,
    /// One-paragraph verdict.
    pub verdict: String,
    /// Leave-one-recording-out residual RMS of the final model on the fit recordings, in
    /// noise-floor units (comparable between pre-processing choices).
    pub cv_rms_noise_units: f64,
    /// Half-width (samples) of the rate differentiation, and the cross-validated RMS of each
    /// half-width tried (empty if it was given).
    pub derivative_window: (usize, Vec<(usize, f64)>),
    /// Held-out residual traces.
    #[serde(skip)]
    pub traces: Vec<ResidualTrace>,
}
