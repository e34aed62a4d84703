//! Errors of model files: every one names the file, and where the text is at fault, the line
//! and column (1-based) and the kind of problem.

use std::path::Path;
use thiserror::Error;

/// The kind of problem in a model file (stable, for tests and tools that sort errors).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Problem {
    /// The file cannot be read.
    Read,
    /// Not valid TOML.
    Syntax,
    /// A key the format does not have (misspelt or in the wrong table).
    UnknownKey,
    /// A required key is missing.
    Missing,
    /// A value of the wrong type or shape (a string for a number, 2 components for a vector).
    WrongType,
    /// A number that must be positive (mass, stiffness, …) is not.
    NotPositive,
    /// A number that must not be negative (damping, clearance, …) is.
    Negative,
    /// An inertia tensor that is not symmetric positive definite or violates the triangle
    /// inequality of principal moments.
    Inertia,
    /// A vector that must not be zero (an axis) is.
    ZeroVector,
    /// Two axes that must be perpendicular are not.
    NotPerpendicular,
    /// A unit that does not parse or does not fit the field.
    Unit,
    /// An unknown `type` (joint, driver law, force, sensor).
    UnknownType,
    /// A name that refers to no body, joint, marker, driver or parameter.
    UnknownReference,
    /// Two elements of the same kind with one name.
    Duplicate,
    /// A joint between a body and itself.
    SelfJoint,
    /// A driver on a joint that cannot be driven, or a sensor or force on a joint that has
    /// no such coordinate.
    NotApplicable,
    /// An include that cannot be read or includes itself through others.
    Include,
    /// A sampled series (CSV) that is missing, malformed or has no such column.
    Series,
    /// Inconsistent values (a rest-to-rest motion ending before it starts, bounds that
    /// exclude the nominal value, …).
    Inconsistent,
    /// The mechanism cannot assemble (the joints named with their residuals).
    Assembly,
    /// The mechanism is not valid for the multibody layer for another reason.
    Model,
}

/// A model file that cannot be read or built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelFileError {
    /// A problem at a place in a file.
    #[error("{file}:{line}:{column}: {message}")]
    At {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (in characters).
        column: usize,
        /// The kind of problem.
        problem: Problem,
        /// What is wrong, naming the element.
        message: String,
    },
    /// A problem with a file as a whole (it cannot be read).
    #[error("{file}: {message}")]
    File {
        /// The file.
        file: String,
        /// The kind of problem.
        problem: Problem,
        /// What is wrong.
        message: String,
    },
}

impl ModelFileError {
    /// The kind of problem.
    pub fn problem(&self) -> Problem {
        match self {
            ModelFileError::At { problem, .. } | ModelFileError::File { problem, .. } => *problem,
        }
    }

    /// (line, column) if the error has a place.
    pub fn place(&self) -> Option<(usize, usize)> {
        match self {
            ModelFileError::At { line, column, .. } => Some((*line, *column)),
            ModelFileError::File { .. } => None,
        }
    }
}

/// A source text and its file name, to turn byte offsets into line and column.
#[derive(Debug, Clone)]
pub(crate) struct Source {
    pub file: String,
    pub text: String,
}

impl Source {
    pub fn new(path: &Path, text: String) -> Self {
        Self {
            file: path.display().to_string(),
            text,
        }
    }

    /// 1-based (line, column) of byte offset `at`.
    pub fn line_column(&self, at: usize) -> (usize, usize) {
        let at = at.min(self.text.len());
        let mut at = at;
        while !self.text.is_char_boundary(at) {
            at -= 1;
        }
        let before = &self.text[..at];
        let line = before.matches('\n').count() + 1;
        let start = before.rfind('\n').map(|k| k + 1).unwrap_or(0);
        (line, before[start..].chars().count() + 1)
    }

    /// An error at byte offset `at`.
    pub fn error(&self, at: usize, problem: Problem, message: impl Into<String>) -> ModelFileError {
        let (line, column) = self.line_column(at);
        ModelFileError::At {
            file: self.file.clone(),
            line,
            column,
            problem,
            message: message.into(),
        }
    }
}
