//! Which recording column each role of a model reads (q1.., qd1.., tau1.., output roles),
//! and the derivative windows tried when none is given: the defaults `lash diagnose` applies
//! for the models it knows by name.

use super::data::model_roles;
use super::model::InverseDynamicsModel;
use super::recording::RecordingError;
use std::path::Path;

/// The columns of the DFKI double pendulum's recordings for q1, q2, qd1, qd2, tau1, tau2
/// (filtered positions in rad, filtered rates in rad/s, measured torques in N·m).
pub const DFKI_COLUMNS: &str =
    "q1=pos_filt1,q2=pos_filt2,qd1=vel_filt1,qd2=vel_filt2,tau1=tau_meas1,tau2=tau_meas2";

/// Half-widths (samples) of the rate differentiation tried by cross-validation when a model
/// states no grid of its own ([`InverseDynamicsModel::derivative_windows`]).
pub const DEFAULT_DERIVATIVE_WINDOWS: [usize; 11] = [2, 3, 5, 8, 12, 16, 20, 25, 30, 40, 50];

/// How the roles of a model find their columns when the user maps none or only some.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnDefaults {
    /// Without a user mapping, this "role=column,…" mapping; a user mapping replaces it and
    /// must then name every role.
    Fixed(String),
    /// Each role reads the column of its own name unless the user maps it; torque and output
    /// roles whose column the recording's header lacks are left out (they are optional
    /// measurements), motion roles (q, qd) are always read.
    RoleNames,
}

/// Parses "role=column,role=column" into pairs, checking every role against `roles`.
fn parse_pairs(text: &str, roles: &[String]) -> Result<Vec<(String, String)>, RecordingError> {
    let mut map = vec![];
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((role, col)) = item.split_once('=') else {
            return Err(RecordingError::Unmapped {
                role: item.into(),
                hint: "role=column pairs, e.g. q1=pos_filt1".into(),
            });
        };
        let role = role.trim().to_string();
        if !roles.contains(&role) {
            return Err(RecordingError::Unmapped {
                role: format!(
                    "'{role}' (not an input or output of this model; it has {})",
                    roles.join(", ")
                ),
                hint: "one of the model's roles".into(),
            });
        }
        map.push((role, col.trim().to_string()));
    }
    Ok(map)
}

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
        ColumnDefaults::Fixed(map) => super::recording::parse_mapping(user.unwrap_or(map), &roles),
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
                .filter(|(r, c)| header.contains(c) || r.starts_with('q'))
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
        let m = crate::diagnose::model::DoublePendulumModel {
            params: crate::mechanisms::double_pendulum::DoublePendulumParams {
                m1: 0.6,
                m2: 0.6,
                l1: 0.3,
                l2: 0.2,
                r1: 0.3,
                r2: 0.2,
                i1: 0.054,
                i2: 0.024,
                g: 9.81,
                tilt: 0.0,
                payload: 0.0,
                gear_ratio: None,
            },
        };
        assert_eq!(m.column_defaults(), ColumnDefaults::Fixed(DFKI_COLUMNS.into()));
        let map = resolve_columns(&m, None, &[]).unwrap();
        assert_eq!(map[0], ("q1".to_string(), "pos_filt1".to_string()));
        assert_eq!(map.len(), 6);
        let e = resolve_columns(&m, Some("q1=a"), &[]).unwrap_err();
        assert!(e.to_string().contains("q2"), "{e}");
    }
}
