//! Every value the reference paper publishes, in one place.
//!
//! Source: J. Bałchanowski, "Modelling and simulation studies on the mechanism positioning
//! accuracy of the WUT MR2120 parallel mechanism with clearances near singular positions"
//! (`../shared/reference/mr2120-clearance-paper.txt`).

/// Side of the base triangle ABC, m (paper §3).
pub const BASE_SIDE: f64 = 0.74;
/// Side of the platform triangle PQR, m (paper §3).
pub const PLATFORM_SIDE: f64 = 0.15;
/// Arm length AD = BE = CF, m (paper §3).
pub const ARM_LENGTH: f64 = 0.30;
/// Forearm length DP = EQ = FR, m (paper §3).
pub const FOREARM_LENGTH: f64 = 0.68;
/// Young's modulus of the steel joints, Pa (paper §3: E = 2.1e5 MPa).
pub const STEEL_E: f64 = 2.1e11;
/// Degrees of freedom of the clearance model (paper §3).
pub const CLEARANCE_MODEL_DOF: usize = 63;

/// A named point of the paper's Table 2.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Table2Point {
    /// Name (M1, M2, M3).
    pub name: &'static str,
    /// Platform centre (x_M, y_M, z_M), m.
    pub m: [f64; 3],
    /// Drive angles (q1, q2, q3), degrees.
    pub q_deg: [f64; 3],
}

/// Table 2: coordinates of the platform positions and the corresponding drive angles.
pub const TABLE2: [Table2Point; 3] = [
    Table2Point {
        name: "M1",
        m: [0.0, 0.0, 0.5],
        q_deg: [59.33; 3],
    },
    Table2Point {
        name: "M2",
        m: [0.0, 0.0, 0.7962],
        q_deg: [112.37; 3],
    },
    Table2Point {
        name: "M3",
        m: [0.0, 0.0, 0.2509],
        q_deg: [46.70; 3],
    },
];

/// The point of Table 2 named `name` (M1, M2, M3; case-insensitive).
pub fn table2_point(name: &str) -> Option<Table2Point> {
    TABLE2
        .iter()
        .find(|p| p.name.eq_ignore_ascii_case(name.trim()))
        .copied()
}

/// A clearance set of Table 1: radial and axial clearance of the universal-joint bearings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClearanceSet {
    /// Name (L1, L2, L3).
    pub name: &'static str,
    /// Radial clearance h_LR (socket radius minus ball radius), m.
    pub radial: f64,
    /// Axial clearance h_LW (socket spacing minus ball spacing), m.
    pub axial: f64,
}

/// Table 1: the clearance sets.
pub const TABLE1: [ClearanceSet; 3] = [
    ClearanceSet {
        name: "L1",
        radial: 0.020e-3,
        axial: 0.020e-3,
    },
    ClearanceSet {
        name: "L2",
        radial: 0.020e-3,
        axial: 0.001e-3,
    },
    ClearanceSet {
        name: "L3",
        radial: 0.001e-3,
        axial: 0.020e-3,
    },
];

/// A range (min, max) of one error of Table 3.
pub type Range = (f64, f64);

/// One row of Table 3: ranges of d_xM, d_yM, d_zM (mm) and δx, δy, δz (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table3Row {
    /// Point (M1, M2, M3).
    pub point: &'static str,
    /// Clearance set (L1, L2, L3).
    pub set: &'static str,
    /// Ranges of d_xM, d_yM, d_zM in mm, then δx, δy, δz in degrees.
    pub ranges: [Range; 6],
}

/// Table 3: positioning-error ranges at M1, M2, M3 for L1, L2, L3.
pub const TABLE3: [Table3Row; 9] = [
    Table3Row {
        point: "M1",
        set: "L1",
        ranges: [
            (-0.12, 0.11),
            (-0.12, 0.13),
            (-0.15, 0.16),
            (-0.36, 0.36),
            (-0.08, 0.08),
            (-0.12, 0.12),
        ],
    },
    Table3Row {
        point: "M1",
        set: "L2",
        ranges: [
            (-0.08, 0.09),
            (-0.08, 0.08),
            (-0.11, 0.10),
            (-0.18, 0.18),
            (-0.03, 0.03),
            (-0.06, 0.06),
        ],
    },
    Table3Row {
        point: "M1",
        set: "L3",
        ranges: [
            (-0.02, 0.02),
            (-0.02, 0.02),
            (-0.02, 0.02),
            (-0.25, 0.25),
            (-0.01, 0.01),
            (-0.08, 0.08),
        ],
    },
    Table3Row {
        point: "M2",
        set: "L1",
        ranges: [
            (-1.01, 1.0),
            (-1.0, 1.02),
            (-0.22, 0.21),
            (-0.86, 0.84),
            (-0.7, 0.176),
            (-0.4, 0.3),
        ],
    },
    Table3Row {
        point: "M2",
        set: "L2",
        ranges: [
            (-0.7, 0.7),
            (-0.70, 0.72),
            (-0.10, 0.11),
            (-0.71, 0.74),
            (-0.57, 0.6),
            (-0.34, 0.4),
        ],
    },
    Table3Row {
        point: "M2",
        set: "L3",
        ranges: [
            (-0.19, 0.2),
            (-0.18, 0.19),
            (-0.01, 0.01),
            (-0.2, 0.3),
            (-0.19, 0.2),
            (-0.16, 0.24),
        ],
    },
    Table3Row {
        point: "M3",
        set: "L1",
        ranges: [
            (-0.15, 0.16),
            (-0.18, 0.17),
            (-16.5, 16.4),
            (-0.7, 0.65),
            (-0.7, 0.6),
            (-8.1, 8.0),
        ],
    },
    Table3Row {
        point: "M3",
        set: "L2",
        ranges: [
            (-0.1, 0.11),
            (-0.10, 0.10),
            (-13.2, 13.4),
            (-0.5, 0.45),
            (-0.5, 0.45),
            (-7.2, 7.2),
        ],
    },
    Table3Row {
        point: "M3",
        set: "L3",
        ranges: [
            (-0.06, 0.06),
            (-0.04, 0.05),
            (-1.2, 1.3),
            (-0.05, 0.03),
            (-0.06, 0.04),
            (-5.7, 5.3),
        ],
    },
];

/// Time at which the trajectory reaches M' (= M2), s (paper §4.1, as reconstructed).
pub const TRAJECTORY_T_M2: f64 = 2.0;
/// Time at which the trajectory reaches M'' (= M3), s (paper §4.1).
pub const TRAJECTORY_T_M3: f64 = 4.0;
