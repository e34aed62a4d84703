//! The ideal (clearance-free) MR2120 as a multibody model: 7 bodies (3 arms, 3 forearms,
//! platform), revolute pairs A, B, C with drivers q1..q3, universal joints D, E, F (elbows)
//! and P, Q, R (platform), gravity — 3 degrees of freedom, 0 with the drivers.

use super::geometry::{Geometry, MassProperties};
use super::kinematics::{inverse, KinematicsError};
use crate::multibody::{Attach, BodyHandle, JointHandle, Mechanism, ModelError, MotionLaw, RigidBody};
use nalgebra::{Matrix3, Vector3};

/// Names of the elbow and platform universal joints per branch.
pub const ELBOW_JOINTS: [&str; 3] = ["D", "E", "F"];
/// Names of the platform universal joints per branch.
pub const PLATFORM_JOINTS: [&str; 3] = ["P", "Q", "R"];
/// Names of the driven revolute pairs.
pub const DRIVE_JOINTS: [&str; 3] = ["A", "B", "C"];

/// The ideal model and the handles of its parts.
#[derive(Debug)]
pub struct IdealModel {
    /// The mechanism.
    pub mechanism: Mechanism,
    /// Arms (A, B, C branches).
    pub arms: [BodyHandle; 3],
    /// Forearms.
    pub forearms: [BodyHandle; 3],
    /// Platform.
    pub platform: BodyHandle,
    /// Driven revolute pairs A, B, C.
    pub drives: [JointHandle; 3],
    /// Drive angles of the build configuration, rad.
    pub q_build: [f64; 3],
}

/// A static equilibrium of the accuracy study that was not found, with its point, clearance
/// set and load case.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("static equilibrium at {point}, clearance set {set}, load case {case} (force {force:?} N, torque {torque:?} N·m on the platform): {source}")]
pub struct EquilibriumError {
    /// Point (M1, M2, M3).
    pub point: String,
    /// Clearance set.
    pub set: String,
    /// Index of the load case in `accuracy::static_load_cases`.
    pub case: usize,
    /// Force on the platform, N.
    pub force: [f64; 3],
    /// Torque on the platform, N·m.
    pub torque: [f64; 3],
    /// The solver's error.
    pub source: ModelError,
}

/// Errors building an MR2120 model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Mr2120Error {
    /// Kinematics failed (e.g. a target outside the work zone).
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// The multibody model failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// Contact data are invalid.
    #[error(transparent)]
    Contact(#[from] crate::contact::ContactError),
    /// A static equilibrium of the accuracy study was not found.
    #[error(transparent)]
    Equilibrium(Box<EquilibriumError>),
    /// An unknown clearance set name.
    #[error("unknown clearance set '{0}'; expected none, L1, L2, L3 or all")]
    UnknownClearanceSet(String),
}

/// What an MR2120 model is built from beyond the geometry's layout: each branch's own link
/// lengths, a payload carried at the platform centre and the gravity vector (a tilted base).
/// [`LinkSpec::nominal`] is the geometry's lengths, no payload, a level base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkSpec {
    /// Arm length |A_i D_i| per branch A, B, C, m.
    pub arm_length: [f64; 3],
    /// Forearm length |D_i P_i| per branch, m.
    pub forearm_length: [f64; 3],
    /// Payload at the platform centre (a point mass added to the platform), kg.
    pub payload: f64,
    /// Gravity in the base frame, m/s² (−9.81 e_z for a level base).
    pub gravity: Vector3<f64>,
}

impl LinkSpec {
    /// The geometry's lengths on every branch, no payload, level base (standard gravity).
    pub fn nominal(g: &Geometry) -> Self {
        Self {
            arm_length: [g.arm_length; 3],
            forearm_length: [g.forearm_length; 3],
            payload: 0.0,
            gravity: Vector3::new(0.0, 0.0, -crate::multibody::STANDARD_GRAVITY),
        }
    }

    /// The geometry of branch `i` (its own arm and forearm lengths).
    pub fn branch_geometry(&self, g: &Geometry, i: usize) -> Geometry {
        Geometry {
            arm_length: self.arm_length[i],
            forearm_length: self.forearm_length[i],
            ..*g
        }
    }
}

/// Orthonormal frame with x along `x` and z along `z` (made perpendicular to x).
fn frame(x: Vector3<f64>, z: Vector3<f64>) -> Matrix3<f64> {
    let x = x.normalize();
    let z = (z - x * z.dot(&x)).normalize();
    Matrix3::from_columns(&[x, z.cross(&x), z])
}

/// A slender rod of mass `mass` (kg) and length `length` (m) from `a` to `b` (m, base
/// frame), body z across it along `z`, less a point mass `carved` (kg) at its end `b`: the
/// part of the link that remains when a joint's cross at `b` becomes a body of its own.
/// Mass, first and second moments of the rest plus the point mass equal the whole rod's (the
/// point's own rotational inertia is not carved out).
fn rod_between(
    name: String,
    mass: f64,
    length: f64,
    (a, b): (Vector3<f64>, Vector3<f64>),
    z: Vector3<f64>,
    carved: f64,
) -> RigidBody {
    // The inertia from the nominal `length` (|b − a| up to round-off), as the model files
    // build it: the settling rattle of the clearance model amplifies a last-bit difference.
    let whole = RigidBody::rod(name, mass, length);
    let orient = frame(b - a, z);
    let centre = (a + b) / 2.0;
    if carved == 0.0 {
        return whole.at(centre).oriented(&orient);
    }
    // Along the rod's axis from its centre: the point at l/2, the rest's centre at x.
    let half = length / 2.0;
    let rest = mass - carved;
    let x = -carved * half / rest;
    let across = whole.inertia[(1, 1)] + mass * x * x - carved * (half - x) * (half - x);
    let axial = whole.inertia[(0, 0)];
    RigidBody::new(
        whole.name,
        rest,
        Matrix3::from_diagonal(&Vector3::new(axial, across, across)),
    )
    .at(centre + (b - a).normalize() * x)
    .oriented(&orient)
}

/// The links of the MR2120 (arms, forearms, platform) and the driven revolute pairs, in the
/// configuration with platform centre `m_build`; the elbow and platform joints are left to
/// the caller. Returns, per branch, the elbow point D, the platform point P and the cross
/// axis m = unit(n × (P − D)).
pub(crate) struct Links {
    pub arms: [BodyHandle; 3],
    pub forearms: [BodyHandle; 3],
    pub platform: BodyHandle,
    pub drives: [JointHandle; 3],
    pub q: [f64; 3],
    pub elbows: [Vector3<f64>; 3],
    pub platform_points: [Vector3<f64>; 3],
    pub cross_axes: [Vector3<f64>; 3],
    pub axes: [Vector3<f64>; 3],
}

pub(crate) fn add_links(
    mech: &mut Mechanism,
    g: &Geometry,
    mp: &MassProperties,
    spec: &LinkSpec,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
    carved: [bool; 6],
) -> Result<Links, Mr2120Error> {
    // Each branch assembled with its own lengths (their drive angles differ slightly).
    let mut q = [0.0; 3];
    for (i, qi) in q.iter_mut().enumerate() {
        *qi = inverse(&spec.branch_geometry(g, i), m_build)?[i];
    }
    mech.set_gravity(spec.gravity);
    let br = g.branches();
    let a = mp.platform_thickness;
    let side = 3f64.sqrt() * g.platform_radius;
    let ixx = mp.platform * (side * side / 24.0 + a * a / 12.0);
    let platform = mech.add_body(
        RigidBody::new(
            "platform",
            mp.platform + spec.payload,
            Matrix3::from_diagonal(&Vector3::new(ixx, ixx, mp.platform * side * side / 12.0)),
        )
        .at(m_build),
    );
    let mut links = Links {
        arms: [platform; 3],
        forearms: [platform; 3],
        platform,
        drives: [JointHandle(0); 3],
        q,
        elbows: [Vector3::zeros(); 3],
        platform_points: [Vector3::zeros(); 3],
        cross_axes: [Vector3::zeros(); 3],
        axes: [Vector3::zeros(); 3],
    };
    let mut laws = laws.map(|l| l.into_iter());
    for i in 0..3 {
        let b = &br[i];
        let gi = spec.branch_geometry(g, i);
        let d = gi.elbow(b, q[i]);
        let p = m_build + b.platform_joint;
        let f = p - d;
        let cross_axis = b.axis.cross(&f).normalize();
        let arm = mech.add_body(rod_between(
            format!("arm {}", DRIVE_JOINTS[i]),
            mp.arm,
            gi.arm_length,
            (b.arm_centre, d),
            b.axis,
            if carved[i] { mp.cross } else { 0.0 },
        ));
        let forearm = mech.add_body(rod_between(
            format!("forearm {}{}", ELBOW_JOINTS[i], PLATFORM_JOINTS[i]),
            mp.forearm,
            gi.forearm_length,
            (d, p),
            cross_axis,
            if carved[3 + i] { mp.cross } else { 0.0 },
        ));
        // Positive q raises the arm: a rotation about −n.
        let rev = mech.revolute_at(DRIVE_JOINTS[i], Attach::Ground, arm, b.arm_centre, -b.axis);
        if let Some(it) = laws.as_mut() {
            let law = it.next().expect("three laws");
            mech.drive(&format!("q{}", i + 1), rev, law, q[i])?;
        }
        links.arms[i] = arm;
        links.forearms[i] = forearm;
        links.drives[i] = rev;
        links.elbows[i] = d;
        links.platform_points[i] = p;
        links.cross_axes[i] = cross_axis;
        links.axes[i] = b.axis;
    }
    Ok(links)
}

/// Builds the ideal model in the configuration with platform centre `m_build` (m), with the
/// drivers following `laws` (absolute drive angles q_i(t), rad), or undriven if `None`.
pub fn ideal_model(
    g: &Geometry,
    mp: &MassProperties,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
) -> Result<IdealModel, Mr2120Error> {
    ideal_model_with(g, mp, &LinkSpec::nominal(g), m_build, laws)
}

/// [`ideal_model`] with each branch's own link lengths, a payload and a gravity direction
/// ([`LinkSpec`]). The drive angles of the build configuration come from each branch's own
/// inverse kinematics.
pub fn ideal_model_with(
    g: &Geometry,
    mp: &MassProperties,
    spec: &LinkSpec,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
) -> Result<IdealModel, Mr2120Error> {
    let mut mech = Mechanism::new();
    let l = add_links(&mut mech, g, mp, spec, m_build, laws, [false; 6])?;
    for i in 0..3 {
        mech.universal_at(
            ELBOW_JOINTS[i],
            l.arms[i],
            l.forearms[i],
            l.elbows[i],
            l.axes[i],
            l.cross_axes[i],
        );
        mech.universal_at(
            PLATFORM_JOINTS[i],
            l.forearms[i],
            l.platform,
            l.platform_points[i],
            l.cross_axes[i],
            l.axes[i],
        );
    }
    Ok(IdealModel {
        mechanism: mech,
        arms: l.arms,
        forearms: l.forearms,
        platform: l.platform,
        drives: l.drives,
        q_build: l.q,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::{Analysis, MechanismData};

    /// The rest of a rod less a point mass at its end, plus that point mass, has the whole
    /// rod's mass, centre of mass and inertia (about that centre, in the base frame).
    #[test]
    fn a_carved_rod_and_its_point_mass_make_the_whole_rod() {
        let (a, b, z) = (
            Vector3::new(0.1, -0.2, 0.3),
            Vector3::new(0.4, 0.1, 0.2),
            Vector3::new(0.0, 0.3, 1.0),
        );
        let inertia = |r: &RigidBody| {
            let rot = crate::multibody::rotation::rotation(&r.orientation.normalize());
            rot * r.inertia * rot.transpose()
        };
        let steiner =
            |m: f64, d: Vector3<f64>| m * (Matrix3::identity() * d.norm_squared() - d * d.transpose());
        let l = (b - a).norm();
        let whole = rod_between("w".into(), 1.0, l, (a, b), z, 0.0);
        let rest = rod_between("r".into(), 1.0, l, (a, b), z, 0.05);
        assert!((rest.mass - 0.95).abs() < 1e-15);
        let c = (rest.position * rest.mass + b * 0.05) / (rest.mass + 0.05);
        assert!((c - whole.position).norm() < 1e-15);
        let together = inertia(&rest)
            + steiner(rest.mass, rest.position - whole.position)
            + steiner(0.05, b - whole.position);
        assert!((together - inertia(&whole)).norm() < 1e-15 * inertia(&whole).norm().max(1.0));
        assert!((rest.orientation - whole.orientation).norm() < 1e-15);
    }

    #[test]
    fn ideal_model_has_3_dof_assembles_and_matches_kinematics() {
        let g = Geometry::default();
        let m1 = Vector3::new(0.0, 0.0, 0.5);
        let model = ideal_model(&g, &MassProperties::default(), m1, None).unwrap();
        assert_eq!(model.mechanism.degrees_of_freedom(), 3);
        assert_eq!(model.mechanism.bodies().len(), 7);
        // Driven off the build configuration: the platform goes where inverse kinematics says.
        let target = Vector3::new(0.02, -0.03, 0.55);
        let qt = inverse(&g, target).unwrap();
        let laws = qt.map(MotionLaw::Constant);
        let driven = ideal_model(&g, &MassProperties::default(), m1, Some(laws)).unwrap();
        let platform = driven.platform;
        let mech = driven.mechanism;
        let an = Analysis::new(&mech).unwrap();
        let s = an
            .initial_state(&mech, &mut MechanismData::new(&mech), 0.0)
            .unwrap();
        let r = s.body_position(platform);
        assert!((r - target).norm() < 1e-10, "{r:?}");
        // Tsai's conditions: the platform keeps its orientation.
        let e = s.body_euler_parameters(platform).fixed_rows::<3>(1).into_owned();
        assert!(e.norm() < 1e-10, "platform rotated by {e:?}");
    }
}
