//! First-order pose error of a body from the play of a mechanism's universal joints: the
//! linearised bound of the clearance-design study, built on the one play model
//! ([`super::play`]) the diagnosis uses too.
//!
//! At a pose of the ideal mechanism (drivers held, no free degrees of freedom) under a load
//! case (gravity and the model's force elements at rest), the joints' static reactions say
//! which way each joint's play lets it sit ([`UniversalPlay::shift`], exact signs); the
//! constraint-offset sensitivity of the assembly ([`Analysis::constraint_offset_sensitivity`])
//! carries each joint's shift and tilt to the body; side i's trunnion pair also carries its
//! cross's weight ([`JointPlay::cross_mass`]). The result is linear in the clearances:
//! a 6-vector (d_x, d_y, d_z in m, δx, δy, δz in rad; base frame, rotation vector of the body
//! against its ideal orientation) per metre of radial clearance and per metre of axial play,
//! the same in every joint. Contact elasticity is left out (it is not play); near a singular
//! configuration the first order fails, which is what comparing it with the nonlinear
//! equilibria ([`crate::multibody::static_equilibrium`]) shows.

use super::play::UniversalPlay;
use crate::multibody::rotation::{l_matrix, rotation};
use crate::multibody::{
    Analysis, AssemblyOptions, Attach, BodyHandle, JointHandle, JointKind, Mechanism, MechanismData,
    ModelError, Snapshot,
};
use nalgebra::{Vector3, Vector4};

/// Singularity measure of the constraint Jacobian ([`Analysis::singularity_measure`]) below
/// which [`play_pose_error`] refuses: first-order sensitivities there grow without bound.
pub const SINGULAR_MEASURE: f64 = 1e-6;

/// A universal joint of the ideal model and the play its clearance would give it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointPlay {
    /// The joint (a universal joint of the ideal model).
    pub joint: JointHandle,
    /// Its play geometry.
    pub play: UniversalPlay,
    /// Mass of its cross, kg (0 for a joint whose cross is weightless): under gravity side
    /// i's trunnion pair carries the cross's weight besides the joint's force
    /// ([`UniversalPlay::shift_with_cross_weight`]). The model's own loads must carry the
    /// cross too (a mass lumped on side i at the joint, or its weight as a load there), so
    /// that the joint's reaction is the force across side j's pair.
    pub cross_mass: f64,
}

/// The first-order pose error of a body per unit clearance (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PlayPoseError {
    /// Per metre of radial clearance in every joint: d (m/m) then δ (rad/m).
    pub radial: [f64; 6],
    /// Per metre of axial play in every joint: d (m/m) then δ (rad/m).
    pub axial: [f64; 6],
}

impl PlayPoseError {
    /// The pose error for radial clearance `h` and axial play `h_axial` (m): d in m, δ in rad.
    pub fn at(&self, h: f64, h_axial: f64) -> [f64; 6] {
        std::array::from_fn(|k| h * self.radial[k] + h_axial * self.axial[k])
    }
}

/// The first-order pose error of `body` from the play of `joints` in `model` at time `t`
/// (drivers evaluated there; the model must have no free degrees of freedom).
///
/// Errors: [`ModelError::BadElement`] for a joint that is not universal or a model with free
/// degrees of freedom, [`ModelError::AssemblyFailed`] when the pose cannot be assembled, and
/// the sensitivity's error at a singular configuration.
pub fn play_pose_error(
    model: &Mechanism,
    t: f64,
    joints: &[JointPlay],
    body: BodyHandle,
    assembly: AssemblyOptions,
) -> Result<PlayPoseError, ModelError> {
    play_pose_errors(model, t, joints, body, assembly, 1, |_| {}).map(|v| v[0])
}

/// [`play_pose_error`] for `cases` load cases at one pose: the assembly, the singularity
/// test and the constraint-offset sensitivity are computed once (they do not depend on the
/// loads); before case k the caller's `set_case(k)` sets the loads (e.g. through a force
/// element whose load it shares), and the joints' reactions are evaluated for it.
pub fn play_pose_errors(
    model: &Mechanism,
    t: f64,
    joints: &[JointPlay],
    body: BodyHandle,
    assembly: AssemblyOptions,
    cases: usize,
    set_case: impl FnMut(usize),
) -> Result<Vec<PlayPoseError>, ModelError> {
    let per_joint = play_pose_errors_per_joint(model, t, joints, body, assembly, cases, set_case)?;
    Ok(per_joint
        .iter()
        .map(|case| PlayPoseError {
            radial: std::array::from_fn(|c| case.iter().map(|e| e.radial[c]).sum()),
            axial: std::array::from_fn(|c| case.iter().map(|e| e.axial[c]).sum()),
        })
        .collect())
}

/// [`play_pose_errors`] joint by joint: for each load case, the pose error per metre of
/// radial clearance and per metre of axial play in each joint of `joints` alone (in their
/// order), the others ideal. To first order the errors add: a design with clearance h_k and
/// play h_a,k in joint k errs by Σ_k (h_k · radial_k + h_a,k · axial_k), the load-dependent
/// sides of the play fixed by the ideal model's reactions.
pub fn play_pose_errors_per_joint(
    model: &Mechanism,
    t: f64,
    joints: &[JointPlay],
    body: BodyHandle,
    assembly: AssemblyOptions,
    cases: usize,
    mut set_case: impl FnMut(usize),
) -> Result<Vec<Vec<PlayPoseError>>, ModelError> {
    let free = 6 * model.bodies().len() as isize - model.constraint_count() as isize;
    if free != 0 {
        return Err(ModelError::BadElement {
            kind: "joint",
            name: "(mechanism)".into(),
            reason: format!(
                "the play bound needs the drivers to fix the pose; with its drivers the model has {free} free degrees of freedom"
            ),
        });
    }
    for jp in joints {
        let j = model.joint(jp.joint).ok_or_else(|| ModelError::BadElement {
            kind: "joint",
            name: format!("{:?}", jp.joint),
            reason: "not in this model".into(),
        })?;
        if !matches!(j.kind, JointKind::Universal) {
            return Err(ModelError::BadElement {
                kind: "joint",
                name: j.name.clone(),
                reason: format!(
                    "a {:?} joint: only the play of universal joints is modelled",
                    j.kind
                ),
            });
        }
    }
    let analysis = Analysis::with_options(model, assembly)?;
    let mut data = MechanismData::new(model);
    let q = analysis.assemble(model, &mut data, t, &model.initial_guess().0)?;
    let measure = analysis.singularity_measure(model, &data, t, &q)?;
    if measure < SINGULAR_MEASURE {
        return Err(ModelError::Singular {
            t,
            measure,
            detail: "the first-order play bound does not hold at a singular configuration; solve the equilibria (static_equilibrium)".into(),
        });
    }
    let lay = model.layout();
    let rows: Vec<usize> = joints
        .iter()
        .flat_map(|jp| {
            let r = lay.joint_lambda(jp.joint);
            r.start..r.start + 4
        })
        .collect();
    let dq = analysis.constraint_offset_sensitivity(model, &mut data, t, &q, &rows)?;
    let n = q.len();
    let pose = |dq: &[f64]| -> [f64; 6] {
        let d = Analysis::point_variation(model, &q, dq, body, &Vector3::zeros());
        let r = lay.body_q(body);
        let p = Vector4::new(q[r.start + 3], q[r.start + 4], q[r.start + 5], q[r.start + 6]);
        let dp = Vector4::new(dq[r.start + 3], dq[r.start + 4], dq[r.start + 5], dq[r.start + 6]);
        // Small rotation, base frame: A·(2·L(p)·δp).
        let om = rotation(&p) * (2.0 * l_matrix(&p) * dp);
        [d.x, d.y, d.z, om.x, om.y, om.z]
    };
    let mut out = Vec::with_capacity(cases);
    for case in 0..cases {
        set_case(case);
        let w = vec![0.0; model.layout().w_len()];
        let (wdot, lambda) = analysis.accelerations(model, &mut data, t, &q, &w)?;
        let s = Snapshot {
            t,
            q: q.clone(),
            w,
            wdot,
            lambda,
        };
        let mut per_joint = Vec::with_capacity(joints.len());
        for (k, jp) in joints.iter().enumerate() {
            let (mut dq_r, mut dq_a) = (vec![0.0; n], vec![0.0; n]);
            let joint = model.joint(jp.joint).expect("checked above");
            let reaction = s
                .reaction(model, jp.joint)
                .ok_or_else(|| ModelError::BadElement {
                    kind: "joint",
                    name: joint.name.clone(),
                    reason: "no reaction at this state".into(),
                })?;
            let axis = |side: Attach, a: Vector3<f64>| match side {
                Attach::Ground => a,
                Attach::Body(h) => s.body_rotation(h) * a,
            };
            let z_i = axis(joint.body_i, joint.frame_i.axes.column(2).into());
            let z_j = axis(joint.body_j, joint.frame_j.axes.column(2).into());
            let shift = jp.play.shift_with_cross_weight(
                &z_i,
                &z_j,
                &Vector3::from(reaction.force),
                &Vector3::from(reaction.torque),
                &(jp.cross_mass * model.gravity()),
                0.0,
            );
            for i in 0..n {
                for c in 0..3 {
                    dq_r[i] += shift.radial_translation[c] * dq[4 * k + c][i];
                    dq_a[i] += shift.axial_translation[c] * dq[4 * k + c][i];
                }
                // The perpendicularity row's offset ε is −φ, φ the tilt about z_i × z_j.
                dq_r[i] -= shift.radial_tilt * dq[4 * k + 3][i];
            }
            per_joint.push(PlayPoseError {
                radial: pose(&dq_r),
                axial: pose(&dq_a),
            });
        }
        out.push(per_joint);
    }
    Ok(out)
}
