//! The file's tables as serde reads them: every key optional and every value spanned, so the
//! builder (not serde) says what is missing or wrong, with the place. Unknown keys are refused
//! by serde (`deny_unknown_fields`), with their place.

use serde::Deserialize;
use toml::Spanned;

/// A value as written: a number (SI), a string (a number with a unit, or a parameter's
/// name), an array or a table.
pub(crate) type Val = Spanned<toml::Value>;
/// A name or other string, with its place.
pub(crate) type Name = Spanned<String>;

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileDoc {
    #[serde(default)]
    pub include: Vec<Name>,
    /// A URDF whose links and joints this file builds on (`urdf.rs`).
    pub urdf: Option<Name>,
    pub model: Option<Spanned<ModelDoc>>,
    #[serde(default)]
    pub parameter: Vec<Spanned<ParameterDoc>>,
    #[serde(default)]
    pub body: Vec<Spanned<BodyDoc>>,
    #[serde(default)]
    pub marker: Vec<Spanned<MarkerDoc>>,
    #[serde(default)]
    pub joint: Vec<Spanned<JointDoc>>,
    #[serde(default)]
    pub driver: Vec<Spanned<DriverDoc>>,
    #[serde(default)]
    pub force: Vec<Spanned<ForceDoc>>,
    #[serde(default)]
    pub sensor: Vec<Spanned<SensorDoc>>,
    #[serde(default)]
    pub transmission: Vec<Spanned<TransmissionDoc>>,
    pub recordings: Option<Spanned<RecordingsDoc>>,
    #[serde(default)]
    pub candidate: Vec<Spanned<CandidateDoc>>,
}

/// A candidate of the file's own for the diagnosis: parameters perturbed together.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct CandidateDoc {
    pub name: Option<Name>,
    #[serde(default)]
    pub parameters: Vec<Name>,
    pub description: Option<Name>,
}

/// A compliant transmission between a motor and the joint it drives.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct TransmissionDoc {
    pub joint: Option<Name>,
    pub compliance: Option<Val>,
    pub rotor_inertia: Option<Val>,
    pub damping: Option<Val>,
    pub rotor_mass: Option<Val>,
}

/// Recordings of the machine the file describes (paths relative to the file).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct RecordingsDoc {
    #[serde(default)]
    pub fit: Vec<Name>,
    #[serde(default)]
    pub holdout: Vec<Name>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct ModelDoc {
    pub name: Option<Name>,
    pub description: Option<Name>,
    pub gravity: Option<Val>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ParameterDoc {
    pub name: Option<Name>,
    pub nominal: Option<Val>,
    pub unit: Option<Name>,
    pub bounds: Option<Val>,
    pub description: Option<Name>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct OrientationDoc {
    pub axis: Option<Val>,
    pub angle: Option<Val>,
    pub x: Option<Val>,
    pub z: Option<Val>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct BodyDoc {
    pub name: Option<Name>,
    pub mass: Option<Val>,
    pub inertia: Option<Val>,
    pub position: Option<Val>,
    pub orientation: Option<Spanned<OrientationDoc>>,
    pub velocity: Option<Val>,
    pub angular_velocity: Option<Val>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct MarkerDoc {
    pub name: Option<Name>,
    pub body: Option<Name>,
    pub point: Option<Val>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ClearanceDoc {
    pub radial: Option<Val>,
    pub axial: Option<Val>,
    pub ball_radius: Option<Val>,
    pub ball_spacing: Option<Val>,
    pub cross_mass: Option<Val>,
    pub damping: Option<Val>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct JointDoc {
    pub name: Option<Name>,
    #[serde(rename = "type")]
    pub kind: Option<Name>,
    pub i: Option<Name>,
    pub j: Option<Name>,
    pub point: Option<Val>,
    pub axis: Option<Val>,
    pub axis_i: Option<Val>,
    pub axis_j: Option<Val>,
    pub coordinate: Option<Val>,
    pub limits: Option<Val>,
    pub clearance: Option<Spanned<ClearanceDoc>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DriverDoc {
    pub name: Option<Name>,
    pub joint: Option<Name>,
    pub law: Option<Name>,
    pub value: Option<Val>,
    pub coefficients: Option<Val>,
    pub t0: Option<Val>,
    pub t1: Option<Val>,
    pub from: Option<Val>,
    pub to: Option<Val>,
    pub profile: Option<Name>,
    pub file: Option<Name>,
    pub time_column: Option<Name>,
    pub column: Option<Name>,
    pub unit: Option<Name>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct ForceDoc {
    pub name: Option<Name>,
    #[serde(rename = "type")]
    pub kind: Option<Name>,
    pub i: Option<Name>,
    pub j: Option<Name>,
    pub point_i: Option<Val>,
    pub point_j: Option<Val>,
    pub stiffness: Option<Val>,
    pub damping: Option<Val>,
    pub free_length: Option<Val>,
    pub free_angle: Option<Val>,
    pub joint: Option<Name>,
    pub coulomb: Option<Val>,
    pub viscous: Option<Val>,
    pub viscous_backward: Option<Val>,
    pub velocity_scale: Option<Val>,
    pub smoothing: Option<Name>,
    pub value: Option<Val>,
    pub file: Option<Name>,
    pub time_column: Option<Name>,
    pub column: Option<Name>,
    pub unit: Option<Name>,
    pub body: Option<Name>,
    pub point: Option<Val>,
    pub force: Option<Val>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct SensorDoc {
    pub name: Option<Name>,
    #[serde(rename = "type")]
    pub kind: Option<Name>,
    pub joint: Option<Name>,
    pub body: Option<Name>,
    pub marker: Option<Name>,
    pub side: Option<Name>,
}
