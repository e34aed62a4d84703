//! Why a diagnosis cannot run.

use super::recording::RecordingError;

/// Why a diagnosis cannot run: no recording to fit, recordings that do not fit the model or
/// each other, or a recording that could not be read. Recordings are named by
/// [`MotionData::name`](super::data::MotionData::name), series by their recording roles
/// (`q1`, `qd2`, `tau1`, output roles such as `x`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// The derivative-window candidates are empty or contain 0 (a half-width of 0 samples
    /// would differentiate nothing and leave the accelerations at zero).
    #[error("derivative windows [{given}]: give at least one half-width of 1 sample or more")]
    DerivativeWindows {
        /// The half-widths given, comma-separated.
        given: String,
    },
    /// The fit set is empty.
    #[error("no fit recording: the diagnosis needs at least one recording to fit the candidate physics on")]
    NoFitRecordings,
    /// A recording's residual channels differ from those of the first fit recording.
    #[error(
        "{role} recording '{recording}' has the channels [{channels}], but the fit recording '{reference}' has [{expected}]: every recording must carry the same torque and output channels"
    )]
    ChannelMismatch {
        /// "fit" or "held-out".
        role: &'static str,
        /// The recording.
        recording: String,
        /// Its channels.
        channels: String,
        /// The first fit recording.
        reference: String,
        /// Its channels.
        expected: String,
    },
    /// Joint positions, rates or accelerations for a different number of joints than the
    /// model has.
    #[error("recording '{recording}': {what} of {found} joints, but the model has {joints} joints")]
    JointCount {
        /// The recording.
        recording: String,
        /// "positions", "rates" or "accelerations".
        what: &'static str,
        /// Joints in the recording.
        found: usize,
        /// Joints of the model.
        joints: usize,
    },
    /// Torques of some joints but not of all.
    #[error(
        "recording '{recording}': torques of {found} joints, but the model has {joints} joints (record the torques of every joint or of none)"
    )]
    TorqueCount {
        /// The recording.
        recording: String,
        /// Torque series in the recording.
        found: usize,
        /// Joints of the model.
        joints: usize,
    },
    /// Some outputs but not all.
    #[error(
        "recording '{recording}': {found} output series, but the model has {outputs} outputs (record every output or none)"
    )]
    OutputCount {
        /// The recording.
        recording: String,
        /// Output series in the recording.
        found: usize,
        /// Outputs of the model.
        outputs: usize,
    },
    /// Neither torques nor outputs: nothing to compare with the model.
    #[error("recording '{recording}' has neither torques nor outputs to compare with the model")]
    NoChannels {
        /// The recording.
        recording: String,
    },
    /// A series whose length differs from the time column's.
    #[error(
        "recording '{recording}': series {series} has {found} samples, but its time column has {expected}"
    )]
    SeriesLength {
        /// The recording.
        recording: String,
        /// The series' role (`q1`, `qd2`, `qdd1`, `tau2`, an output role).
        series: String,
        /// Its samples.
        found: usize,
        /// Samples of the time column.
        expected: usize,
    },
    /// Too few samples for the noise floor and the fit.
    #[error(
        "recording '{recording}': {found} samples; at least {needed} are needed to estimate the noise floor"
    )]
    TooFewSamples {
        /// The recording.
        recording: String,
        /// Samples found.
        found: usize,
        /// Samples needed.
        needed: usize,
    },
    /// An exclusion that matches no candidate.
    #[error("--exclude '{text}' matches no candidate of the library (candidates: {available})")]
    UnknownExclusion {
        /// The text.
        text: String,
        /// Candidate names, comma-separated.
        available: String,
    },
    /// One fit recording too short to cut into cross-validation folds.
    #[error(
        "recording '{recording}' is the only fit recording, so it is cut into {folds} parts for cross-validation, but its {found} samples give fewer than {needed} per part: record longer, or fit on several recordings"
    )]
    TooFewSamplesForFolds {
        /// The recording.
        recording: String,
        /// Samples found.
        found: usize,
        /// Folds it would be cut into.
        folds: usize,
        /// Samples each fold needs.
        needed: usize,
    },
    /// Time is not finite or does not increase strictly.
    #[error("recording '{recording}': time {t} s at sample {index} is not finite or not after the previous sample ({previous} s)")]
    TimeNotIncreasing {
        /// The recording.
        recording: String,
        /// 0-based sample index.
        index: usize,
        /// Time at the sample, s.
        t: f64,
        /// Time at the previous sample, s (−∞ for the first).
        previous: f64,
    },
    /// The residual (measured − nominal model) is not finite at more than
    /// [`MAX_UNDEFINED_FRACTION`](super::MAX_UNDEFINED_FRACTION) of a recording's
    /// samples: the recording does not fit the model.
    #[error(
        "recording '{recording}': the residual (measured − nominal model) is not finite at {undefined} of its {samples} samples (the first at t = {t} s): the model cannot be evaluated there (a pose the mechanism cannot reach?) or the values are out of range"
    )]
    ResidualUndefined {
        /// The recording.
        recording: String,
        /// Samples with an undefined residual.
        undefined: usize,
        /// Samples in the recording.
        samples: usize,
        /// Time of the first such sample, s.
        t: f64,
    },
    /// The nominal model cannot serve the diagnosis (e.g. a mechanism builder that fails, or
    /// attaches a driver count other than the torque channels').
    #[error("model '{model}': {message}")]
    Model {
        /// The model's name.
        model: String,
        /// What is wrong.
        message: String,
    },
    /// A recording could not be read or mapped.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}
