//! The MR2120 as the diagnosis sees it, as a multibody model: the ideal 3-DOF mechanism
//! ([`crate::mechanisms::mr2120::ideal_model_with`]: rigid arms, forearms as rigid rods,
//! platform, universal joints) evaluated by the multibody inverse dynamics and forward
//! kinematics at every sample ([`MechanismModel`]), with its sensors declared:
//!
//! * the drive encoders sit on the motors, behind compliant transmissions (compliance a model
//!   parameter, nominal [`NOMINAL_COMPLIANCE`]; torsional damping
//!   [`NOMINAL_TRANSMISSION_DAMPING`]; reflected rotor inertia [`NOMINAL_ROTOR_INERTIA`]:
//!   the machine's data sheet, the same values the synthetic machines are built with); the
//!   drive torques are read from the motor currents; along a recording the wind-up follows
//!   its own dynamics;
//! * a laser tracker reads the platform centre (x, y, z);
//! * the six universal joints D, E, F, P, Q, R may have play (bearing spacing of
//!   [`BearingDesign::mr2120`]).
//!
//! * the joints of each leg (elbow and platform joint) may be compliant (contact in their
//!   bearings), in series with the leg's drive: a compliance c along the forearm reads as a
//!   drive compliance c/ℓ'² that changes with the configuration ([`leg_compliance_gain`]);
//!   and a compliance c_a of the joints' axial contacts (the trunnion ends on their faces,
//!   along the drive's axis n, which both joints of a leg have as a bearing axis), which the
//!   forearm's load loads by its share u·n and which the leg then yields by (u·n)²·c_a:
//!   a drive compliance (u·n)²·c_a/ℓ'² ([`leg_axial_compliance_gain`]).
//!
//! Parameters, in this order: arm A, B, C lengths, forearm A, B, C lengths (m), arm and
//! forearm masses, payload on the platform (kg), base tilt about x and y (rad), drive A, B, C
//! compliances (rad/(N·m)), joint compliances along legs A, B, C, then of their axial contacts (m/N, nominal 0). The closed-form lumped model
//! ([`Mr2120Model`](super::model::Mr2120Model)) stays as a fast cross-check only.

use super::mechanism::{EncoderPlacement, MechanismModel, PlaySite, PointSensor, Sensors, SeriesCompliance};
use super::model::{ModelParameter, ParameterFamily};
use super::DiagnoseError;
use crate::contact::play::UniversalPlay;
use crate::contact::{BearingDesign, Damping};
use crate::mechanisms::mr2120::ideal::{ELBOW_JOINTS, PLATFORM_JOINTS};
use crate::mechanisms::mr2120::kinematics::singularity;
use crate::mechanisms::mr2120::lumped::tilted_gravity;
use crate::mechanisms::mr2120::{ideal_model_with, Geometry, LinkSpec, MassProperties};
use crate::multibody::{ModelError, MotionLaw};
use nalgebra::Vector3;
use std::sync::Arc;

pub use crate::mechanisms::mr2120::lumped::NOMINAL_COMPLIANCE;

pub use crate::mechanisms::mr2120::truth::{NOMINAL_ROTOR_INERTIA, NOMINAL_TRANSMISSION_DAMPING};

/// Direct-singularity measure below which the localisation tags a configuration as near it.
pub const NEAR_DIRECT: f64 = 0.3;

/// Platform centre of the configuration the model is built in, m.
pub const BUILD_POINT: [f64; 3] = [0.0, 0.0, 0.5];

/// The parameters of the MR2120 model with their nominal values.
pub fn parameters(g: &Geometry, mp: &MassProperties) -> Vec<ModelParameter> {
    use ParameterFamily::*;
    let mk = |name: String, unit: &str, nominal: f64, scale: f64, family| ModelParameter {
        name,
        unit: unit.into(),
        nominal,
        scale,
        family,
    };
    let mut p = vec![];
    for b in ["A", "B", "C"] {
        p.push(mk(
            format!("arm {b} length"),
            "m",
            g.arm_length,
            g.arm_length,
            LinkGeometry,
        ));
    }
    for b in ["A", "B", "C"] {
        p.push(mk(
            format!("forearm {b} length"),
            "m",
            g.forearm_length,
            g.forearm_length,
            LinkGeometry,
        ));
    }
    p.push(mk("arm mass".into(), "kg", mp.arm, mp.arm, MassProperties));
    p.push(mk(
        "forearm mass".into(),
        "kg",
        mp.forearm,
        mp.forearm,
        MassProperties,
    ));
    p.push(mk(
        "payload on the platform".into(),
        "kg",
        0.0,
        mp.platform,
        Payload,
    ));
    p.push(mk("base tilt about x".into(), "rad", 0.0, 0.1, BaseTilt));
    p.push(mk("base tilt about y".into(), "rad", 0.0, 0.1, BaseTilt));
    for b in ["A", "B", "C"] {
        p.push(mk(
            format!("drive {b} compliance"),
            "rad/(N m)",
            NOMINAL_COMPLIANCE,
            NOMINAL_COMPLIANCE,
            DriveCompliance,
        ));
    }
    // The legs' joint compliances, then their axial contacts'.
    for contacts in ["", ", axial contacts"] {
        for (i, b) in ["A", "B", "C"].iter().enumerate() {
            p.push(mk(
                format!(
                    "joint compliance along leg {b} (joints {}, {}){contacts}",
                    ELBOW_JOINTS[i], PLATFORM_JOINTS[i]
                ),
                "m/N",
                0.0,
                JOINT_COMPLIANCE_SCALE,
                JointCompliance,
            ));
        }
    }
    p
}

/// Scale of the legs' joint compliances, m/N: their largest plausible value. A Hertz ball
/// contact of [`BearingDesign::mr2120`] deflects ~1 µm under tens of newtons (≈ 1e-8 m/N
/// linearised); a step of `PARAMETER_STEP` of this scale changes a drive's compliance by
/// about as much as a step of the drive compliance's own scale does.
pub const JOINT_COMPLIANCE_SCALE: f64 = 4e-6;

/// First parameter index of the drives' transmission compliances (drives A, B, C).
pub const DRIVE_COMPLIANCE: usize = 11;

/// First parameter index of the legs' joint compliances (legs A, B, C).
pub const JOINT_COMPLIANCE: usize = 14;

/// First parameter index of the legs' joints' axial contact compliances (legs A, B, C).
pub const AXIAL_JOINT_COMPLIANCE: usize = 17;

/// How a compliance c (m/N) of the joints along leg `i` (elbow and platform joint, in series
/// with the forearm) reads in drive coordinates: c/ℓ'², with ℓ' = ∂D/∂q·u the rate at which
/// the drive stretches the leg (D the elbow, u the unit vector from D to the platform joint
/// P; the forearm carries its load along u), at drive position `q` (rad) and platform centre
/// `y` (m). Infinite at an inverse-kinematics singularity (ℓ' = 0).
pub fn leg_compliance_gain(g: &Geometry, i: usize, q: f64, y: &[f64]) -> f64 {
    let (_, rate) = leg_direction(g, i, q, y);
    1.0 / (rate * rate)
}

/// Leg `i`'s unit vector u from the elbow D to the platform joint P, and ℓ' = ∂D/∂q·u.
fn leg_direction(g: &Geometry, i: usize, q: f64, y: &[f64]) -> (Vector3<f64>, f64) {
    let b = &g.branches()[i];
    let p = Vector3::new(y[0], y[1], y[2]) + b.platform_joint;
    let u = (p - g.elbow(b, q)).normalize();
    (u, g.elbow_rate(b, q).dot(&u))
}

/// How a compliance c_a (m/N) of the axial contacts of leg `i`'s joints reads in drive
/// coordinates: (u·n)²·c_a/ℓ'², n the drive's revolute axis — a bearing axis of both the elbow
/// (the cross's pair in the arm) and the platform joint (the pair in the platform, which only
/// translates) — u and ℓ' as in [`leg_compliance_gain`]. The forearm's load F along u presses
/// those pairs' trunnion ends on their faces with F·(u·n); their yield along n moves the leg's
/// end by (u·n) of it along u. u·n depends on the platform position only (the elbow stays in
/// the arm's plane, normal to n; the forearm keeps its length): (u·n)² = 0.53 with the
/// platform centre on the z axis, 0.35 for leg A with it at (0.05, −0.08) m. Infinite where
/// ℓ' = 0.
pub fn leg_axial_compliance_gain(g: &Geometry, i: usize, q: f64, y: &[f64]) -> f64 {
    let (u, rate) = leg_direction(g, i, q, y);
    let un = u.dot(&g.branches()[i].axis);
    un * un * (1.0 / (rate * rate))
}

/// The multibody MR2120 model for the diagnosis (see the module documentation).
pub fn mr2120_model(g: &Geometry, mp: &MassProperties) -> Result<MechanismModel, DiagnoseError> {
    let (g0, mp0) = (*g, *mp);
    let builder = Arc::new(move |theta: &[f64], laws: &[MotionLaw]| {
        let spec = LinkSpec {
            arm_length: [theta[0], theta[1], theta[2]],
            forearm_length: [theta[3], theta[4], theta[5]],
            payload: theta[8],
            gravity: tilted_gravity(theta[9], theta[10]),
        };
        let mp = MassProperties {
            arm: theta[6],
            forearm: theta[7],
            ..mp0
        };
        let laws: [MotionLaw; 3] =
            std::array::from_fn(|i| laws.get(i).cloned().unwrap_or(MotionLaw::Constant(0.0)));
        ideal_model_with(&g0, &mp, &spec, Vector3::from(BUILD_POINT), Some(laws))
            .map(|m| m.mechanism)
            .map_err(|e| match e {
                crate::mechanisms::mr2120::Mr2120Error::Model(m) => m,
                other => ModelError::Output(other.to_string()),
            })
    });
    let model = MechanismModel::new(
        "WUT MR2120 (multibody ideal model, compliant drives with motor-side encoders, tracked platform centre)",
        ["A", "B", "C"].iter().map(|b| format!("drive {b}")).collect(),
        parameters(g, mp),
        builder,
    )?;
    let sensors = Sensors {
        encoders: (0..3)
            .map(|j| EncoderPlacement::MotorSide {
                compliance: DRIVE_COMPLIANCE + j,
                rotor_inertia: NOMINAL_ROTOR_INERTIA,
                damping: NOMINAL_TRANSMISSION_DAMPING,
            })
            .collect(),
        outputs: ["x", "y", "z"]
            .iter()
            .enumerate()
            .map(|(axis, r)| PointSensor {
                name: format!("platform {r}"),
                role: (*r).into(),
                body: "platform".into(),
                point: Vector3::zeros(),
                axis,
            })
            .collect(),
    };
    let play = UniversalPlay::from_design(&BearingDesign::mr2120(0.0, 0.0, Damping::Elastic));
    let sites = ELBOW_JOINTS
        .iter()
        .chain(PLATFORM_JOINTS.iter())
        .enumerate()
        // Site s is in leg s mod 3 (elbows, then platform joints): its contact compliance
        // is the leg's joint compliance, isotropic and of the axial contacts.
        .map(|(s, j)| PlaySite {
            joint: (*j).into(),
            play,
            cross_mass: mp0.cross,
            compliance: vec![JOINT_COMPLIANCE + s % 3, AXIAL_JOINT_COMPLIANCE + s % 3],
        })
        .collect();
    type Gain = fn(&Geometry, usize, f64, &[f64]) -> f64;
    let gains: [(usize, Gain); 2] = [
        (JOINT_COMPLIANCE, leg_compliance_gain),
        (AXIAL_JOINT_COMPLIANCE, leg_axial_compliance_gain),
    ];
    let series = gains
        .into_iter()
        .flat_map(|(first, gain)| {
            (0..3).map(move |i| SeriesCompliance {
                drive: i,
                parameter: first + i,
                gain: Arc::new(move |q: &[f64], y: &[f64]| {
                    if q.len() < 3 || y.len() < 3 {
                        return 0.0;
                    }
                    gain(&g0, i, q[i], y)
                }),
            })
        })
        .collect();
    Ok(model
        .with_sensors(sensors)?
        .with_series_compliance(series)?
        .with_play(sites)?
        .with_derivative_windows(vec![4, 6, 8, 12, 16])
        .with_tagger(Arc::new(move |q: &[f64], y: &[f64]| {
            if q.len() < 3 || y.len() < 3 || !y.iter().all(|v| v.is_finite()) {
                return None;
            }
            let s = singularity(&g0, [q[0], q[1], q[2]], Vector3::new(y[0], y[1], y[2]));
            (s.direct_measure < NEAR_DIRECT)
                .then(|| format!("near the direct-kinematics singularity (measure below {NEAR_DIRECT})"))
        })))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::model::{InverseDynamicsModel, PlayDynamics};
    use crate::mechanisms::mr2120::kinematics::inverse;

    /// ℓ' is the rate at which the drive stretches its leg: differences of |P − D(q)|.
    #[test]
    fn the_leg_gain_is_one_over_the_squared_stretch_rate() {
        let g = Geometry::default();
        let m = Vector3::new(0.03, -0.02, 0.48);
        let q = inverse(&g, m).unwrap();
        let y = [m.x, m.y, m.z];
        for (i, b) in g.branches().iter().enumerate() {
            let p = m + b.platform_joint;
            let len = |x: f64| (p - g.elbow(b, x)).norm();
            let h = 1e-6;
            let rate = (len(q[i] + h) - len(q[i] - h)) / (2.0 * h);
            let gain = leg_compliance_gain(&g, i, q[i], &y);
            assert!(
                (gain * rate * rate - 1.0).abs() < 1e-6,
                "leg {i}: {gain} vs 1/{rate}²"
            );
        }
    }

    /// The axial contacts' share: a leg stretched by a load F along u presses the trunnion
    /// ends of its joints' n-pairs with F·(u·n); their yield c_a·F·(u·n) along n lengthens
    /// the leg by (u·n)·c_a·F·(u·n). Checked against the leg's length with its end moved
    /// along n by that yield (differences); u·n is fixed by the platform position (the elbow
    /// stays in the arm's plane, normal to n).
    #[test]
    fn the_axial_contacts_gain_is_the_legs_yield_along_the_bearing_axis() {
        let g = Geometry::default();
        let m = Vector3::new(0.05, -0.08, 0.48);
        let q = inverse(&g, m).unwrap();
        let y = [m.x, m.y, m.z];
        for (i, b) in g.branches().iter().enumerate() {
            let p = m + b.platform_joint;
            let u = (p - g.elbow(b, q[i])).normalize();
            let un = u.dot(&b.axis);
            assert!((0.2..0.95).contains(&(un * un)), "leg {i}: (u·n)² = {}", un * un);
            // The elbow stays in the arm's plane: u·n is (P − A')·n over the forearm's length.
            let along = (p - b.arm_centre).dot(&b.axis) / g.forearm_length;
            assert!((along - un).abs() < 1e-9, "leg {i}: u·n {un} vs {along}");
            let (c_a, f) = (3e-8, 20.0);
            let yield_n = c_a * f * un;
            let stretch = (p + b.axis * yield_n - g.elbow(b, q[i])).norm() - (p - g.elbow(b, q[i])).norm();
            let gain = leg_axial_compliance_gain(&g, i, q[i], &y);
            let leg = leg_compliance_gain(&g, i, q[i], &y);
            // In drive coordinates: the stretch per unit load, over ℓ'².
            assert!(
                ((stretch / f) * leg / (c_a * gain) - 1.0).abs() < 1e-5,
                "leg {i}: stretch {stretch:e} m, gain {gain:e}, leg gain {leg:e}"
            );
        }
    }

    /// The play's coupling to the drives obeys reciprocity: the torque a play coordinate's
    /// acceleration asks of a drive equals the reaction conjugate to that coordinate which
    /// the drive's acceleration asks of the joint (∂τ_k/∂ë_c = ∂Λ_c/∂q̈_k), and the play
    /// coordinates' own inertia ∂Λ/∂ë is symmetric and positive definite. A check of the
    /// constraint offsets, the tilt's sign and the reaction's conjugate components at once.
    #[test]
    fn the_plays_inertial_coupling_is_reciprocal() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let model = mr2120_model(&g, &mp).unwrap();
        let m = Vector3::new(0.02, 0.01, 0.5);
        let q: Vec<f64> = inverse(&g, m).unwrap().to_vec();
        let (qd, qdd) = (vec![0.1, -0.2, 0.05], vec![1.0, 0.5, -2.0]);
        let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
        let sites = model.play_dynamics(&theta, &q, &qd, &qdd).expect("play dynamics");
        assert_eq!(sites.len(), model.play_sites().len());
        for (s, name) in sites.iter().zip(model.play_sites()) {
            let scale = s
                .reaction_by_offset_acceleration
                .iter()
                .flatten()
                .fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(scale > 0.1, "joint {name}: inertia {scale}");
            for c in 0..4 {
                for k in 0..3 {
                    let (a, b) = (
                        s.torque_by_offset_acceleration[c][k],
                        s.reaction_by_drive_acceleration[k][c],
                    );
                    assert!(
                        (a - b).abs() < 1e-6 * scale,
                        "joint {name}, coordinate {c}, drive {k}: {a} vs {b}"
                    );
                }
                for r in 0..4 {
                    let (a, b) = (
                        s.reaction_by_offset_acceleration[c][r],
                        s.reaction_by_offset_acceleration[r][c],
                    );
                    assert!(
                        (a - b).abs() < 1e-6 * scale,
                        "joint {name}: inertia ({c}, {r}) {a} vs {b}"
                    );
                }
            }
            let inertia = nalgebra::Matrix4::from_fn(|r, c| s.reaction_by_offset_acceleration[c][r]);
            assert!(
                inertia.symmetric_eigenvalues().iter().all(|&e| e > 0.0),
                "joint {name}: {inertia}"
            );
        }
    }

    /// The cross's own load m_x·(g − a_i): at rest its weight at every joint; moving, at an
    /// elbow (side i the arm, turning about its drive's axis) the elbow point's acceleration
    /// D″(q)·q̇² + D′(q)·q̈ from the geometry, another route than the model's bodies.
    #[test]
    fn the_crosss_load_is_its_weight_at_rest_and_follows_the_elbows_acceleration() {
        let (model, theta, q) = rigid_at_a_pose();
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let gravity = tilted_gravity(theta[9], theta[10]);
        let rest = model
            .play_dynamics(&theta, &q, &[0.0; 3], &[0.0; 3])
            .expect("play dynamics");
        for (s, name) in rest.iter().zip(model.play_sites()) {
            let load = Vector3::from(s.cross_load);
            assert!((load - mp.cross * gravity).norm() < 1e-9, "joint {name}: {load}");
        }
        let (qd, qdd) = (vec![2.0, -1.5, 1.0], vec![30.0, 20.0, -40.0]);
        let moving = model.play_dynamics(&theta, &q, &qd, &qdd).expect("play dynamics");
        for (i, b) in g.branches().iter().enumerate() {
            let h = 1e-5;
            let d2 = (g.elbow_rate(b, q[i] + h) - g.elbow_rate(b, q[i] - h)) / (2.0 * h);
            let a = d2 * qd[i] * qd[i] + g.elbow_rate(b, q[i]) * qdd[i];
            let expected = mp.cross * (gravity - a);
            let load = Vector3::from(moving[i].cross_load);
            assert!(
                (load - expected).norm() < 1e-6 * expected.norm(),
                "elbow {i}: {load} vs {expected}"
            );
            assert!(
                (load - mp.cross * gravity).norm() > 0.02,
                "elbow {i}: the motion shows"
            );
        }
        // The quasi-static play columns carry the same load (one play model for both).
        for (qd, qdd) in [(vec![0.0; 3], vec![0.0; 3]), (qd.clone(), qdd.clone())] {
            let dynamics = model.play_dynamics(&theta, &q, &qd, &qdd).expect("play dynamics");
            let sens = model
                .output_sensitivities(&theta, &q, &qd, &qdd, &[0.0; 3])
                .expect("sensitivities");
            assert_eq!(sens.play.len(), dynamics.len());
            for ((d, p), name) in dynamics.iter().zip(&sens.play).zip(model.play_sites()) {
                let load = Vector3::from(d.cross_load);
                assert!(
                    (p.cross_load - load).norm() < 1e-9 * load.norm(),
                    "joint {name}: {} vs {load}",
                    p.cross_load
                );
            }
        }
    }

    /// The outputs at an expansion point of joint F's play, evaluated there, agree with the
    /// first-order output sensitivities (the constraint offsets' variation, another route)
    /// for a small point, and stay near them for one a hundred times larger.
    #[test]
    fn the_outputs_at_an_expansion_point_follow_the_sensitivities_to_first_order() {
        let (model, theta, q) = rigid_at_a_pose();
        let (qd, qdd) = (vec![0.3, -0.2, 0.1], vec![1.0, 0.5, -2.0]);
        let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
        model.evaluate_at(0.0, &theta, &q, &qd, &qdd, &mut tau, &mut y);
        let sens = model
            .output_sensitivities(&theta, &q, &qd, &qdd, &y)
            .expect("sensitivities");
        let p = &sens.play[2];
        for c in 0..4 {
            let first = |k: usize| if c < 3 { p.dy_dshift[c][k] } else { p.dy_dtilt[k] };
            let scale = (0..3).map(|k| first(k).abs()).fold(0.0, f64::max);
            assert!(scale > 1e-3, "coordinate {c}: {scale}");
            // 1e-7 m or 1e-6 rad, then a hundred times that.
            let small = if c < 3 { 1e-7 } else { 1e-6 };
            let mut rest = [0.0; 2];
            for (r, step) in [small, 100.0 * small].into_iter().enumerate() {
                let mut offset = [0.0; 4];
                offset[c] = step;
                let point = model
                    .play_dynamics_at(&theta, &q, &qd, &qdd, 2, &[0.0; 3], offset)
                    .expect("point");
                assert_eq!(point.outputs.len(), 3);
                rest[r] = (0..3)
                    .map(|k| (point.outputs[k] - first(k) * step).abs())
                    .fold(0.0, f64::max)
                    / (scale * step);
            }
            assert!(rest[0] < 1e-3, "coordinate {c}: relative rest {rest:?}");
            // Away from a singular position the first order still carries most of it.
            assert!(rest[1] < 0.2, "coordinate {c}: {rest:?}");
        }
    }

    /// Sample interval (s) and sample of the jerk in [`jerk_motion`].
    const JERK_DT: f64 = 2e-3;
    const JERK_AT: usize = 270;

    /// The encoders at rest at `q0` past the model's start transient (`WINDUP_SETTLING`),
    /// then accelerating at 20, −15 and 10 rad/s² from sample [`JERK_AT`] on: positions, rates
    /// and accelerations at sample i.
    fn jerk_motion(q0: &[f64], i: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let acc = [20.0, -15.0, 10.0];
        let s = (i.saturating_sub(JERK_AT)) as f64 * JERK_DT;
        let on = if i >= JERK_AT { 1.0 } else { 0.0 };
        let q: Vec<f64> = (0..3).map(|j| q0[j] + 0.5 * acc[j] * s * s).collect();
        let qd: Vec<f64> = (0..3).map(|j| acc[j] * s).collect();
        let qdd: Vec<f64> = (0..3).map(|j| on * acc[j]).collect();
        (q, qd, qdd)
    }

    /// The MR2120's model with rigid drives (the arms follow the encoders), its parameters
    /// and the encoder angles of a pose, rad.
    fn rigid_at_a_pose() -> (MechanismModel, Vec<f64>, Vec<f64>) {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let model = mr2120_model(&g, &mp).unwrap();
        let mut theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
        for j in 0..3 {
            theta[DRIVE_COMPLIANCE + j] = 0.0;
        }
        let q: Vec<f64> = inverse(&g, Vector3::new(0.02, 0.01, 0.5)).unwrap().to_vec();
        (model, theta, q)
    }

    /// The velocity products in the play's coupling: ∂τ_s/∂q̇ agrees with central differences
    /// of the model's own torques in the rates (with rigid drives, where the arms follow the
    /// encoders; another route through the model), and every rate derivative is linear in the
    /// motion's rates: zero at rest, doubled with them.
    #[test]
    fn the_plays_velocity_coupling_follows_the_torques_and_scales_with_the_rates() {
        let (model, theta, q) = rigid_at_a_pose();
        let (qd, qdd) = (vec![0.8, -1.1, 0.5], vec![1.0, 0.5, -2.0]);
        let sites = model.play_dynamics(&theta, &q, &qd, &qdd).expect("play dynamics");
        let s = &sites[0];
        let step = 1e-3;
        let torques = |qd: &[f64]| {
            let mut tau = vec![0.0; 3];
            model.torques(&theta, &q, qd, &qdd, &mut tau);
            tau
        };
        let scale = s
            .torque_by_drive_rate
            .iter()
            .flatten()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(scale > 1e-3, "{scale}");
        for k in 0..3 {
            let (mut up, mut down) = (qd.clone(), qd.clone());
            up[k] += step;
            down[k] -= step;
            let (a, b) = (torques(&up), torques(&down));
            for j in 0..3 {
                let want = (a[j] - b[j]) / (2.0 * step);
                let got = s.torque_by_drive_rate[k][j];
                assert!((got - want).abs() < 1e-4 * scale, "∂τ{j}/∂q̇{k}: {got} vs {want}");
            }
        }
        // Linear in the rates: at rest nothing, with the rates doubled twice as much.
        let at = |f: f64| {
            let qd: Vec<f64> = qd.iter().map(|v| f * v).collect();
            model.play_dynamics(&theta, &q, &qd, &qdd).unwrap().swap_remove(0)
        };
        let (rest, double) = (at(0.0), at(2.0));
        let all = |p: &PlayDynamics| -> Vec<f64> {
            p.torque_by_offset_rate
                .iter()
                .flatten()
                .chain(p.reaction_by_offset_rate.iter().flatten())
                .chain(p.reaction_by_drive_rate.iter().flatten())
                .chain(p.torque_by_drive_rate.iter().flatten())
                .copied()
                .collect()
        };
        let (one, zero, two) = (all(s), all(&rest), all(&double));
        let big = one.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for ((a, z), d) in one.iter().zip(&zero).zip(&two) {
            assert!(z.abs() < 1e-6 * big, "at rest {z} (scale {big})");
            assert!((d - 2.0 * a).abs() < 1e-4 * big, "doubled {d} vs 2 × {a}");
        }
    }

    /// Re-linearised at the sample itself, a play site's coupling and reaction are the
    /// sample's and the torques do not change; a small step off it changes the torques by the
    /// sample's derivatives (first order, within a percent of the change).
    #[test]
    fn the_play_re_linearised_at_the_sample_is_the_samples() {
        let (model, theta, q) = rigid_at_a_pose();
        let (qd, qdd) = (vec![0.1, -0.2, 0.05], vec![1.0, 0.5, -2.0]);
        let site = 2;
        let nominal = model
            .play_dynamics(&theta, &q, &qd, &qdd)
            .unwrap()
            .swap_remove(site);
        let same = model
            .play_dynamics_at(&theta, &q, &qd, &qdd, site, &[0.0; 3], [0.0; 4])
            .expect("the point");
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-6 * scale;
        let scale = nominal
            .torque_by_offset
            .iter()
            .flatten()
            .fold(1.0f64, |a, v| a.max(v.abs()));
        for c in 0..4 {
            for j in 0..3 {
                let (a, b) = (
                    same.dynamics.torque_by_offset[c][j],
                    nominal.torque_by_offset[c][j],
                );
                assert!(close(a, b, scale), "∂τ{j}/∂e{c}: {a} vs {b}");
            }
        }
        assert!(same.torque.iter().all(|v| *v == 0.0), "{:?}", same.torque);
        for r in 0..4 {
            let (a, b) = (same.dynamics.reaction[r], nominal.reaction[r]);
            assert!(close(a, b, 1.0 + b.abs()), "Λ{r}: {a} vs {b}");
        }
        // A micrometre off: the torques move as the sample's derivatives say.
        let (e, w) = ([1e-6, -2e-6, 1.5e-6, 3e-5], [2e-5, -1e-5, 1e-5]);
        let off = model
            .play_dynamics_at(&theta, &q, &qd, &qdd, site, &w, e)
            .expect("the point off the sample");
        for j in 0..3 {
            let linear: f64 = (0..4).map(|c| nominal.torque_by_offset[c][j] * e[c]).sum::<f64>()
                - (0..3).map(|k| same.load_stiffness[(j, k)] * w[k]).sum::<f64>();
            assert!(
                (off.torque[j] - linear).abs() < 0.01 * linear.abs() + 1e-9,
                "drive {j}: {} vs {linear}",
                off.torque[j]
            );
        }
    }

    /// A sample's state kept along a walk and put back later ([`InverseDynamicsModel::sample_state`],
    /// `restore_sample`) answers a question about that sample as the walk did: a play site
    /// re-linearised off the sample while the transmissions ring after a jerk gives the same
    /// point (to the analyses' tolerance) whether the model walked there or was put back there
    /// after walking on, also in a copy of the model that never walked. A lone sample keeps no
    /// state, and another model's state is refused.
    #[test]
    fn a_sample_state_put_back_answers_as_the_walk_did() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let model = mr2120_model(&g, &mp).unwrap();
        let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
        let q0 = inverse(&g, Vector3::new(0.02, 0.01, 0.5)).unwrap();
        let (dt, jerk_at) = (JERK_DT, JERK_AT);
        let motion = |i: usize| jerk_motion(&q0, i);
        let (site, w, e) = (2, [2e-5, -1e-5, 1e-5], [1e-6, -2e-6, 1.5e-6, 3e-5]);
        let asked = [jerk_at + 5, jerk_at + 12];
        let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
        let (mut walked, mut states) = (vec![], vec![]);
        for i in 0..jerk_at + 20 {
            let (q, qd, qdd) = motion(i);
            model.evaluate_at(i as f64 * dt, &theta, &q, &qd, &qdd, &mut tau, &mut y);
            if asked.contains(&i) {
                states.push(model.sample_state().expect("a state along the recording"));
                walked.push(
                    model
                        .play_dynamics_at(&theta, &q, &qd, &qdd, site, &w, e)
                        .expect("the point"),
                );
            }
        }
        let copy = model.clone();
        for m in [&model, &copy] {
            for ((&i, state), want) in asked.iter().zip(&states).zip(&walked) {
                assert!(m.restore_sample(state));
                let (q, qd, qdd) = motion(i);
                let got = m
                    .play_dynamics_at(&theta, &q, &qd, &qdd, site, &w, e)
                    .expect("the point");
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-7 * (1.0 + b.abs());
                for j in 0..3 {
                    assert!(
                        close(got.torque[j], want.torque[j]),
                        "sample {i}: {:?} vs {:?}",
                        got.torque,
                        want.torque
                    );
                    for k in 0..3 {
                        let (a, b) = (got.load_stiffness[(j, k)], want.load_stiffness[(j, k)]);
                        // (Differences over 1e-6 rad of positions assembled to 1e-12: their
                        // round-off follows the warm start, ~1e-6 of S.)
                        assert!(
                            (a - b).abs() <= 1e-5 * want.load_stiffness.amax(),
                            "S[{j},{k}] {a} vs {b}"
                        );
                    }
                }
                for r in 0..4 {
                    assert!(
                        close(got.dynamics.reaction[r], want.dynamics.reaction[r]),
                        "sample {i}, Λ{r}"
                    );
                }
                // The ringing moves the arms off the encoders: the state carries what a lone
                // sample would not know.
                assert!(got.windup.iter().zip(&w).all(|(a, b)| a == b));
            }
        }
        // Without the state, a copy answers for a lone sample (its wind-up quasi-static),
        // which the ringing moves off the walk's answer by newtons: the check discriminates.
        let lone = model.clone();
        let (q, qd, qdd) = motion(asked[1]);
        let alone = lone
            .play_dynamics_at(&theta, &q, &qd, &qdd, site, &w, e)
            .expect("a lone point");
        let apart = (0..4)
            .map(|r| (alone.dynamics.reaction[r] - walked[1].dynamics.reaction[r]).abs())
            .fold(0.0f64, f64::max);
        assert!(
            apart > 0.1,
            "a lone sample's reaction is {apart} N off the walk's"
        );
        assert!(lone.sample_state().is_none(), "a lone sample keeps no state");
        assert!(!model.restore_sample(&crate::diagnose::model::SampleState::new(5u8)));
    }

    /// The play's load and the load stiffness follow the arms, not the encoders: while the
    /// transmissions ring after a jerk of the encoders, every play joint's reaction is the
    /// inverse dynamics' at the arms' motion, and S = ∂τ_s/∂q_arm the derivative of the
    /// joint-side torques at the arms' motion (their accelerations are the encoders' less the
    /// wind-up's: S carries ∂M/∂q·q̈_arm). Checked against the model with rigid transmissions
    /// driven by that motion, found independently: positions from the tracker by inverse
    /// kinematics, rates as the encoders' less the wind-up rate, accelerations by central
    /// differences of those rates.
    #[test]
    fn the_plays_load_and_the_load_stiffness_follow_the_ringing_arms() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let model = mr2120_model(&g, &mp).unwrap();
        let rigid_model = mr2120_model(&g, &mp).unwrap();
        let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
        let mut rigid = theta.clone();
        for j in 0..3 {
            assert!(theta[DRIVE_COMPLIANCE + j] > 0.0);
            rigid[DRIVE_COMPLIANCE + j] = 0.0;
        }
        let q0 = inverse(&g, Vector3::new(0.02, 0.01, 0.5)).unwrap();
        // At rest past the model's start transient (`WINDUP_SETTLING`), then a jerk.
        let (dt, jerk_at) = (JERK_DT, JERK_AT);
        let motion = |i: usize| jerk_motion(&q0, i);
        let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
        let mut arm_rate = vec![];
        let mut arm_at = vec![];
        let mut reaction = vec![];
        let mut stiffness = vec![];
        for i in 0..jerk_at + 30 {
            let (q, qd, qdd) = motion(i);
            model.evaluate_at(i as f64 * dt, &theta, &q, &qd, &qdd, &mut tau, &mut y);
            if i + 1 < jerk_at {
                continue;
            }
            let td = model.transmission_dynamics(&theta).expect("compliant drives");
            stiffness.push(td.load_stiffness.expect("the load stiffness"));
            let wd = td.windup_rate;
            arm_rate.push((0..3).map(|j| qd[j] - wd[j]).collect::<Vec<f64>>());
            arm_at.push(inverse(&g, Vector3::new(y[0], y[1], y[2])).unwrap().to_vec());
            let sites = model.play_dynamics(&theta, &q, &qd, &qdd).expect("play dynamics");
            reaction.push(sites.iter().map(|s| s.reaction).collect::<Vec<_>>());
        }
        // Per joint and component: the largest ring (arms' load less the encoders') and the
        // largest error over the samples after the jerk.
        let sites = model.play_sites();
        let mut ring = vec![[0.0f64; 4]; sites.len()];
        let mut error = vec![[0.0f64; 4]; sites.len()];
        for k in 3..29 {
            let qdd_arm: Vec<f64> = (0..3)
                .map(|j| (arm_rate[k + 1][j] - arm_rate[k - 1][j]) / (2.0 * dt))
                .collect();
            let at = |qdd: &[f64]| {
                rigid_model
                    .play_dynamics(&rigid, &arm_at[k], &arm_rate[k], qdd)
                    .unwrap()
            };
            let (arms, encoders) = (at(&qdd_arm), at(&motion(jerk_at - 1 + k).2));
            for site in 0..sites.len() {
                for r in 0..4 {
                    let want = arms[site].reaction[r];
                    ring[site][r] = ring[site][r].max((want - encoders[site].reaction[r]).abs());
                    error[site][r] = error[site][r].max((reaction[k][site][r] - want).abs());
                }
            }
        }
        for (site, name) in sites.iter().enumerate() {
            for r in 0..4 {
                assert!(
                    error[site][r] <= 0.05 * ring[site][r] + 1e-3,
                    "joint {name}, component {r}: off by {} where the ringing moves it by {}",
                    error[site][r],
                    ring[site][r]
                );
            }
        }
        // The ringing moves the loads by newtons: the check discriminates.
        let largest = ring.iter().flatten().fold(0.0f64, |a, &v| a.max(v));
        assert!(largest > 1.0, "{largest}");

        // S: the rigid model's torques differenced in the arms' positions at their own motion
        // (the rotor's inertia times the acceleration is in both sides of a difference).
        let (mut s_ring, mut s_error) = (0.0f64, 0.0f64);
        for k in 3..29 {
            let qdd_arm: Vec<f64> = (0..3)
                .map(|j| (arm_rate[k + 1][j] - arm_rate[k - 1][j]) / (2.0 * dt))
                .collect();
            let step = 1e-6;
            let s_at = |qdd: &[f64]| {
                nalgebra::DMatrix::from_fn(3, 3, |j, c| {
                    let torque = |sign: f64| {
                        let mut q = arm_at[k].clone();
                        q[c] += sign * step;
                        let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
                        rigid_model.evaluate(&rigid, &q, &arm_rate[k], qdd, &mut tau, &mut y);
                        tau[j]
                    };
                    (torque(1.0) - torque(-1.0)) / (2.0 * step)
                })
            };
            let (arms, encoders) = (s_at(&qdd_arm), s_at(&motion(jerk_at - 1 + k).2));
            s_ring = s_ring.max((&arms - &encoders).amax());
            s_error = s_error.max((&stiffness[k] - &arms).amax());
        }
        assert!(
            s_error <= 0.05 * s_ring,
            "S off by {s_error} N·m/rad where the ringing moves it by {s_ring}"
        );
        // The ringing moves S by some N·m/rad: the check discriminates.
        assert!(s_ring > 1.0, "{s_ring}");
    }

    /// A leg's joint compliance acts as that much more compliance of its drive (at a lone
    /// sample, quasi-static wind-up): the same torques and platform position.
    #[test]
    fn a_legs_joint_compliance_reads_as_drive_compliance() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let model = mr2120_model(&g, &mp).unwrap();
        let m = Vector3::new(0.02, 0.01, 0.5);
        let q: Vec<f64> = inverse(&g, m).unwrap().to_vec();
        let (qd, qdd) = (vec![0.1, -0.2, 0.05], vec![1.0, 0.5, -2.0]);
        let run = |theta: &[f64]| {
            let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
            // Twice: the gain is taken where the previous evaluation left the mechanism.
            model.evaluate(theta, &q, &qd, &qdd, &mut tau, &mut y);
            model.evaluate(theta, &q, &qd, &qdd, &mut tau, &mut y);
            (tau, y)
        };
        let nominal: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
        let (_, y0) = run(&nominal);
        let c = 5e-8;
        let mut joint = nominal.clone();
        joint[JOINT_COMPLIANCE + 2] = c;
        let (tau_j, y_j) = run(&joint);
        let mut drive = nominal.clone();
        drive[DRIVE_COMPLIANCE + 2] += c * leg_compliance_gain(&g, 2, q[2], &y0);
        let (tau_d, y_d) = run(&drive);
        for k in 0..3 {
            assert!(
                (tau_j[k] - tau_d[k]).abs() < 1e-6,
                "torque {k}: {tau_j:?} vs {tau_d:?}"
            );
            assert!((y_j[k] - y_d[k]).abs() < 1e-9, "output {k}: {y_j:?} vs {y_d:?}");
        }
        assert!((y_j[2] - y0[2]).abs() > 1e-8, "the compliance moves the platform");
    }
}
