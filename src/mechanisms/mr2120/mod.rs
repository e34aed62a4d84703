//! The WUT MR2120: a 3-RUU translational parallel mechanism (three arms on revolute drives A,
//! B, C; forearms with universal joints D, E, F at the elbows and P, Q, R at the platform).
//!
//! * [`paper`] — every value the reference paper publishes (Tables 1–3, dimensions, E).
//! * [`geometry`] — the reconstructed layout (`../shared/reference/mr2120-geometry.md`).
//! * [`kinematics`] — inverse/forward kinematics, Jacobians, singularity measures.
//! * [`ideal`] — the ideal 3-DOF multibody model.
//! * [`clearance`] — the 63-DOF clearance model (trunnion bearings in every universal joint).
//! * [`trajectory`] — the trajectory M1 → M2 → M3 (paper §4.1) and the errors of eq. (4.1).
//! * [`accuracy`] — positioning accuracy at M1–M3 (Table 3), dynamic and static methods.
//! * [`output`] — CSV files and charts of the studies.
//! * [`lumped`] — a closed-form rigid model (fast cross-check of the ideal model's torques).
//! * [`record`] — synthetic recordings with hidden effects for the diagnosis suite.
//! * [`truth`] — synthetic recordings from a simulated multibody truth (compliant
//!   transmissions as bodies, friction force elements, per-joint bearings, payload body,
//!   sensor model), independent of the diagnosis' candidate library.

pub mod accuracy;
pub mod clearance;
pub mod geometry;
pub mod ideal;
pub mod kinematics;
pub mod lumped;
pub mod output;
pub mod paper;
pub mod record;
pub mod trajectory;
pub mod truth;

pub use geometry::{Geometry, MassProperties};
pub use ideal::{ideal_model, ideal_model_with, IdealModel, LinkSpec, Mr2120Error};

use nalgebra::Vector3;
use serde::Serialize;

/// One row of the Table 2 comparison (`lash mr2120 kinematics`).
#[derive(Debug, Clone, Serialize)]
pub struct Table2Row {
    /// Point name (M1, M2, M3).
    pub point: String,
    /// Platform centre (x_M, y_M, z_M), m.
    pub m: [f64; 3],
    /// Drive angles from lash's inverse kinematics, degrees.
    pub q_deg: [f64; 3],
    /// Drive angles published in Table 2, degrees.
    pub q_paper_deg: [f64; 3],
    /// Largest |q − q_paper|, degrees.
    pub max_diff_deg: f64,
    /// Singularity measures and class.
    pub singularity: kinematics::SingularityReport,
    /// Reachable z interval on the vertical through the point, m.
    pub z_range: Option<(f64, f64)>,
    /// Distance below the upper work-zone boundary on that vertical, m.
    pub below_boundary: Option<f64>,
}

/// lash's kinematics at the three points of Table 2, beside the paper's values.
pub fn table2(g: &Geometry) -> Result<Vec<Table2Row>, kinematics::KinematicsError> {
    paper::TABLE2
        .iter()
        .map(|p| {
            let m = Vector3::from(p.m);
            let q = kinematics::inverse(g, m)?;
            let q_deg = q.map(f64::to_degrees);
            let max_diff_deg = (0..3).map(|i| (q_deg[i] - p.q_deg[i]).abs()).fold(0.0, f64::max);
            let z_range = kinematics::reachable_z_range(g, p.m[0], p.m[1]);
            Ok(Table2Row {
                point: p.name.into(),
                m: p.m,
                q_deg,
                q_paper_deg: p.q_deg,
                max_diff_deg,
                singularity: kinematics::singularity(g, q, m),
                z_range,
                below_boundary: z_range.map(|(_, hi)| hi - p.m[2]),
            })
        })
        .collect()
}
