//! Which recording column each role of a model reads (q1.., qd1.., tau1.., output roles),
//! and the derivative windows tried when none is given: the defaults `lash diagnose` applies
//! for the models it knows by name.

use super::data::{model_roles, role_kind, RoleKind};
use super::model::InverseDynamicsModel;
pub use super::model::{ColumnDefaults, DEFAULT_DERIVATIVE_WINDOWS, DFKI_COLUMNS};
use super::recording::{parse_pairs, RecordingError};
use std::path::Path;

/// Recordings a model is diagnosed on when the user names none (paths relative to the
/// working directory).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DefaultRecordings {
    /// Recordings to fit on.
    pub fit: &'static [&'static str],
    /// Recordings held out (never fitted).
    pub holdout: &'static [&'static str],
}

/// The DFKI double pendulum's default recordings: trajectories 0–5 fitted, 12 and 13 held
/// out (beside [`DFKI_README`](crate::mechanisms::double_pendulum::DFKI_README)).
pub const DFKI_RECORDINGS: DefaultRecordings = DefaultRecordings {
    fit: &[
        "../shared/data/dfki-double-pendulum/recordings/trajectory_00.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_01.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_02.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_03.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_04.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_05.csv",
    ],
    holdout: &[
        "../shared/data/dfki-double-pendulum/recordings/trajectory_12.csv",
        "../shared/data/dfki-double-pendulum/recordings/trajectory_13.csv",
    ],
};

/// The column of every role of `model` that will be read: `user` ("role=column,…", `None`
/// when not given) applied to the model's [`column_defaults`]; `header` is the first
/// recording's header row (used by [`ColumnDefaults::RoleNames`] to leave out optional roles
/// the recordings lack).
///
/// [`column_defaults`]: InverseDynamicsModel::column_defaults
pub fn resolve_columns(
    model: &dyn InverseDynamicsModel,
    user: Option<&str>,
    header: &[String],
) -> Result<Vec<(String, String)>, RecordingError> {
    let roles = model_roles(model);
    match &model.column_defaults() {
        ColumnDefaults::Fixed(map) => {
            // Recorded accelerations are optional: mapped only when named and present.
            let required: Vec<String> = roles
                .iter()
                .filter(|r| role_kind(model, r) != Some(RoleKind::Acceleration))
                .cloned()
                .collect();
            let pairs = parse_pairs(user.unwrap_or(map), &roles)?;
            if let Some(r) = required.iter().find(|r| !pairs.iter().any(|(m, _)| m == *r)) {
                return Err(RecordingError::Unmapped {
                    role: r.clone(),
                    hint: format!("--map {r}=<column>"),
                });
            }
            let mut out: Vec<(String, String)> = pairs
                .iter()
                .filter(|(r, _)| required.contains(r))
                .cloned()
                .collect();
            out.extend(pairs.into_iter().filter(|(r, c)| {
                role_kind(model, r) == Some(RoleKind::Acceleration)
                    && (header.is_empty() || header.contains(c))
            }));
            Ok(out)
        }
        ColumnDefaults::RoleNames => {
            let user = parse_pairs(user.unwrap_or_default(), &roles)?;
            Ok(roles
                .iter()
                .map(|r| {
                    let col = user
                        .iter()
                        .find(|(u, _)| u == r)
                        .map(|(_, c)| c.clone())
                        .unwrap_or(r.clone());
                    (r.clone(), col)
                })
                .filter(|(r, c)| header.contains(c) || role_kind(model, r) == Some(RoleKind::Motion))
                .collect())
        }
    }
}

/// The header row of a CSV recording: its column names, trimmed.
pub fn csv_header(path: &Path) -> Result<Vec<String>, RecordingError> {
    let text = std::fs::read_to_string(path).map_err(|e| RecordingError::Io {
        path: path.into(),
        message: e.to_string(),
    })?;
    match text.lines().next() {
        Some(l) => Ok(l.split(',').map(|c| c.trim().to_string()).collect()),
        None => Err(RecordingError::Empty { path: path.into() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::model::Mr2120Model;
    use crate::mechanisms::mr2120::record::nominal_model;

    fn header(cols: &[&str]) -> Vec<String> {
        cols.iter().map(|c| c.to_string()).collect()
    }

    #[test]
    fn mr2120_roles_read_their_own_columns_and_drop_missing_torques() {
        let m = Mr2120Model {
            nominal: nominal_model(),
        };
        let h = header(&["time", "q1", "q2", "q3", "qd1", "qd2", "qd3", "x", "y", "z"]);
        let map = resolve_columns(&m, None, &h).unwrap();
        let roles: Vec<&str> = map.iter().map(|(r, _)| r.as_str()).collect();
        assert_eq!(roles, ["q1", "q2", "q3", "qd1", "qd2", "qd3", "x", "y", "z"]);
        assert!(map.iter().all(|(r, c)| r == c));
        // A user mapping renames a role's column; an unknown role is refused by name.
        let map = resolve_columns(&m, Some("x=px"), &h).unwrap();
        assert!(!map.iter().any(|(r, _)| r == "x"), "px is not in the header");
        let e = resolve_columns(&m, Some("w=px"), &h).unwrap_err();
        assert!(e.to_string().contains("'w'"), "{e}");
    }

    #[test]
    fn fixed_defaults_apply_without_a_user_mapping_and_must_be_complete_with_one() {
        let m = crate::diagnose::model::DoublePendulumModel::example();
        assert_eq!(m.column_defaults(), ColumnDefaults::Fixed(DFKI_COLUMNS.into()));
        let map = resolve_columns(&m, None, &[]).unwrap();
        assert_eq!(map[0], ("q1".to_string(), "pos_filt1".to_string()));
        assert_eq!(map.len(), 6);
        let e = resolve_columns(&m, Some("q1=a"), &[]).unwrap_err();
        assert!(e.to_string().contains("q2"), "{e}");
    }
}
