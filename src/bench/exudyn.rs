//! The MR2120 clearance model of [`bench_mr2120`](super::mr2120::bench_mr2120), exported for
//! the Exudyn comparison (`benches/exudyn/`): bodies with their consistent initial state,
//! the three drives in closed form, and every trunnion bearing with its contact laws. The
//! Python side rebuilds the same mechanism from this file alone, so the two engines cannot
//! drift apart in geometry, masses or contact parameters.
//!
//! Units are SI throughout; vectors are base-frame unless a field says otherwise.

use super::mr2120::{build, BenchError, Mr2120BenchOptions};
use crate::contact::{ClearanceBearing, NormalLaw};
use crate::mechanisms::mr2120::kinematics::inverse;
use crate::mechanisms::mr2120::paper::{TABLE2, TRAJECTORY_T_M2, TRAJECTORY_T_M3};
use crate::mechanisms::mr2120::trajectory::drive_laws;
use crate::mechanisms::mr2120::Geometry;
use crate::multibody::{Analysis, Attach, MechanismData};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// The exported model (the schema `benches/exudyn/mr2120_exudyn.py` reads).
#[derive(Debug, Clone, Serialize)]
pub struct ExportedModel {
    /// What this is.
    pub description: String,
    /// Gravity, m/s².
    pub gravity: [f64; 3],
    /// End of the trajectory, s.
    pub t_end: f64,
    /// Interval of the output samples, s.
    pub dt_output: f64,
    /// Index of the platform in `bodies`.
    pub platform_body: usize,
    /// Rigid bodies with the consistent initial state lash starts from.
    pub bodies: Vec<ExportedBody>,
    /// Driven revolute joints (arm to ground).
    pub drives: Vec<ExportedDrive>,
    /// Platform height z(t): two quintic rest-to-rest legs through `z` at times `t`.
    pub z_law: ZLaw,
    /// Trunnion bearings (ball end in a cylindrical socket).
    pub bearings: Vec<ExportedBearing>,
}

/// A rigid body.
#[derive(Debug, Clone, Serialize)]
pub struct ExportedBody {
    /// Name.
    pub name: String,
    /// Mass, kg.
    pub mass: f64,
    /// Inertia about the centre of mass, body frame, kg·m² (rows).
    pub inertia: [[f64; 3]; 3],
    /// Centre of mass at t = 0, m.
    pub position: [f64; 3],
    /// Rotation body → base at t = 0 (rows).
    pub rotation: [[f64; 3]; 3],
    /// Velocity of the centre of mass at t = 0, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity at t = 0, body frame, rad/s.
    pub omega_body: [f64; 3],
}

/// A drive: the arm turns about `axis` through `point` by q(t) − q(0).
#[derive(Debug, Clone, Serialize)]
pub struct ExportedDrive {
    /// Name.
    pub name: String,
    /// Index of the arm in `bodies`.
    pub body: usize,
    /// A point on the axis, m.
    pub point: [f64; 3],
    /// Unit axis (positive q turns the arm about it).
    pub axis: [f64; 3],
    /// q(0), rad.
    pub q_initial: f64,
    /// Closed form of q(t): with w = w0 + (0, 0, z(t)), a = w·arm_dir, b = w_z,
    /// k = (|w|² + L1² − L2²)/(2·L1): q = atan2(b, a) − acos(k/√(a² + b²)) − q0.
    pub arm_dir: [f64; 3],
    /// See `arm_dir`, m.
    pub w0: [f64; 3],
    /// L1, m.
    pub arm_length: f64,
    /// L2, m.
    pub forearm_length: f64,
    /// q0, rad.
    pub q0: f64,
    /// q(t) sampled from lash's own drive law, to check an implementation of the closed form.
    pub angle_table: AngleTable,
}

/// Samples of a drive angle.
#[derive(Debug, Clone, Serialize)]
pub struct AngleTable {
    /// Times, s.
    pub t: Vec<f64>,
    /// Angles, rad.
    pub q: Vec<f64>,
}

/// Knots of the platform-height law.
#[derive(Debug, Clone, Serialize)]
pub struct ZLaw {
    /// t0, t1, t2, s.
    pub t: [f64; 3],
    /// z0, z1, z2, m.
    pub z: [f64; 3],
}

/// A ball end in a cylindrical socket: see [`ClearanceBearing`]. Contact force
/// F = k·δ^n·(1 + 1.5·α·δ̇) ≥ 0, radial and axial with their own k, n, α.
#[derive(Debug, Clone, Serialize)]
pub struct ExportedBearing {
    /// Name.
    pub name: String,
    /// Index of the ball body.
    pub ball_body: usize,
    /// Ball centre, ball-body frame, m.
    pub ball_centre: [f64; 3],
    /// Index of the socket body (None: the ground).
    pub socket_body: Option<usize>,
    /// Socket centre, socket-body frame, m.
    pub socket_centre: [f64; 3],
    /// Unit outward socket axis, socket-body frame.
    pub socket_axis: [f64; 3],
    /// Radial clearance, m.
    pub radial_clearance: f64,
    /// Axial travel before the end face, m.
    pub axial_stop: f64,
    /// Radial stiffness, N/m^n.
    pub k: f64,
    /// Radial exponent.
    pub n: f64,
    /// Radial Hunt–Crossley α, s/m.
    pub alpha: f64,
    /// Axial stiffness, N/m^n.
    pub k_axial: f64,
    /// Axial exponent.
    pub n_axial: f64,
    /// Axial Hunt–Crossley α, s/m.
    pub alpha_axial: f64,
}

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]])
}

/// k, n and α of a Hertz or Hunt–Crossley law.
fn law_parameters(law: &NormalLaw, name: &str) -> Result<(f64, f64, f64), BenchError> {
    match *law {
        NormalLaw::Hertz { k, n } => Ok((k, n, 0.0)),
        NormalLaw::HuntCrossley { k, n, alpha } => Ok((k, n, alpha)),
        _ => Err(BenchError::Reference(format!(
            "bearing '{name}': only Hertz and Hunt–Crossley laws can be exported"
        ))),
    }
}

/// Builds the exported model of the benchmark's clearance set and damping.
pub fn export_mr2120(opts: &Mr2120BenchOptions) -> Result<ExportedModel, BenchError> {
    let g = Geometry::default();
    let m1 = Vector3::from(TABLE2[0].m);
    let model = build(opts)?;
    let mech = model.mech.clone();
    let s0 = Analysis::new(&mech)
        .and_then(|a| a.initial_state(&mech, &mut MechanismData::new(&mech), 0.0))
        .map_err(|e| BenchError::Reference(format!("initial state: {e}")))?;
    let bodies = mech
        .bodies()
        .iter()
        .map(|(h, body)| ExportedBody {
            name: body.name.clone(),
            mass: body.mass,
            inertia: rows(&body.inertia),
            position: arr(&s0.body_position(h)),
            rotation: rows(&s0.body_rotation(h)),
            velocity: arr(&s0.body_velocity(h)),
            omega_body: arr(&s0.body_angular_velocity(h)),
        })
        .collect();
    let q_build = inverse(&g, m1).map_err(|e| BenchError::Reference(e.to_string()))?;
    let laws = drive_laws(&g);
    let n_table = (opts.t_end / opts.dt).round() as usize;
    let table_t: Vec<f64> = (0..=n_table).map(|k| k as f64 * opts.dt).collect();
    let drives = g
        .branches()
        .iter()
        .enumerate()
        .map(|(i, b)| ExportedDrive {
            name: format!("q{}", i + 1),
            body: model.arms[i],
            point: arr(&b.arm_centre),
            axis: arr(&(-b.axis)),
            q_initial: q_build[i],
            arm_dir: arr(&b.arm_dir),
            w0: arr(&(b.platform_joint - b.arm_centre)),
            arm_length: g.arm_length,
            forearm_length: g.forearm_length,
            q0: g.q0,
            angle_table: AngleTable {
                t: table_t.clone(),
                q: table_t.iter().map(|&t| laws[i].eval(t)[0]).collect(),
            },
        })
        .collect();
    let index = |a: Attach| a.body().map(|h| h.index());
    let mut bearings = vec![];
    for (_, f) in mech.forces() {
        let any: &dyn std::any::Any = f;
        let Some(cb) = any.downcast_ref::<ClearanceBearing>() else {
            return Err(BenchError::Reference(format!(
                "force element '{}' is not a trunnion bearing and cannot be exported",
                f.name()
            )));
        };
        let Some(ball_body) = index(cb.ball_body) else {
            return Err(BenchError::Reference(format!(
                "bearing '{}' has its ball on the ground",
                cb.name
            )));
        };
        let (k, n, alpha) = law_parameters(&cb.radial_law, &cb.name)?;
        let (k_axial, n_axial, alpha_axial) = law_parameters(&cb.axial_law, &cb.name)?;
        bearings.push(ExportedBearing {
            name: cb.name.clone(),
            ball_body,
            ball_centre: arr(&cb.ball_centre),
            socket_body: index(cb.socket_body),
            socket_centre: arr(&cb.socket_centre),
            socket_axis: arr(&cb.socket_axis),
            radial_clearance: cb.radial_clearance,
            axial_stop: cb.axial_stop,
            k,
            n,
            alpha,
            k_axial,
            n_axial,
            alpha_axial,
        });
    }
    Ok(ExportedModel {
        description: format!(
            "MR2120 clearance model, set {}, exported by lash {} for the Exudyn comparison",
            opts.set,
            env!("CARGO_PKG_VERSION")
        ),
        gravity: arr(&mech.gravity()),
        t_end: opts.t_end,
        dt_output: opts.dt,
        platform_body: model.platform.index(),
        bodies,
        drives,
        z_law: ZLaw {
            t: [0.0, TRAJECTORY_T_M2, TRAJECTORY_T_M3],
            z: [TABLE2[0].m[2], TABLE2[1].m[2], TABLE2[2].m[2]],
        },
        bearings,
    })
}
