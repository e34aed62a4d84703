//! Why a diagnosis cannot run.

use super::recording::RecordingError;

/// Why a diagnosis cannot run: no recording to fit, recordings that do not fit the model or
/// each other, or a recording that could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DiagnoseError {
    /// The fit set is empty.
    #[error("no fit recording: the diagnosis needs at least one recording to fit the candidate physics on")]
    NoFitRecordings,
    /// A recording could not be read or mapped.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}
