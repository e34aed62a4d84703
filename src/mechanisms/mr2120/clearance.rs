//! The MR2120 with clearance: 13 moving bodies (3 arms, 3 forearms, 6 crosses, platform),
//! the driven revolute pairs A, B, C ideal, and the six universal joints D, E, F, P, Q, R as
//! shape connections with radial and axial clearance (paper §3, Fig. 6) — 63 degrees of
//! freedom.
//!
//! The bearing dimensions the paper does not give (4 mm balls, 24 mm apart, 50 g crosses)
//! are the documented defaults of [`BearingDesign::mr2120`] and [`MassProperties`]. Contact
//! damping: the paper's contact is ideally elastic ([`Damping::Elastic`]); lash's default is
//! a light Hunt–Crossley damping (see [`DEFAULT_DAMPING`]) so that the rattling started by
//! the initial settling decays physically rather than only through the integrator's
//! numerical damping.

use super::geometry::{Geometry, MassProperties};
use super::ideal::{add_links, LinkSpec, Links, Mr2120Error, ELBOW_JOINTS, PLATFORM_JOINTS};
use super::paper::{ClearanceSet, STEEL_E, TABLE1};
use crate::contact::{universal_with_clearance, BearingDesign, Damping, Material};
use crate::multibody::{BodyHandle, JointHandle, Mechanism, MotionLaw};
use nalgebra::Vector3;

/// Default contact damping of the clearance model: Hunt–Crossley α = 1 s/m (a coefficient of
/// restitution e ≈ 1 − α·v ≈ 0.9 for a 0.1 m/s impact, with the law's F = K·δ^1.5·(1 + 1.5·α·δ̇);
/// Hunt & Crossley 1975). With it
/// and index-2 velocity errors the settling rattle at M1 takes 1 500 steps instead of 26 000
/// (elastic contact, index-1 velocities) while the static sag differs by a few per cent.
pub const DEFAULT_DAMPING: Damping = Damping::HuntCrossley(1.0);

/// Contact damping of lubricated steel joints: Hunt–Crossley α = 300 s/m (with
/// F = K·δ^1.5·(1 + 1.5·α·δ̇), impacts above ~5 mm/s are fully damped; restitution ≈ 0.7 at
/// 1 mm/s). The paper's and the studies' near-elastic contact ([`DEFAULT_DAMPING`], α = 1 s/m:
/// restitution ≈ 0.999 at 1 mm/s) keeps the 63-DOF model rattling inside its clearances
/// wherever the motion is slow. Used by the benchmark (`bench::mr2120::BENCH_DAMPING`, where
/// the rattle made the motion chaotic) and by the concealed-effects suite's bearing truths
/// (`diagnose::suite::multibody`, where the rattle of nearly elastic contacts is what a
/// quasi-static diagnosis cannot explain; measured there).
pub const LUBRICATED_DAMPING: Damping = Damping::HuntCrossley(LUBRICATED_ALPHA);

/// The Hunt–Crossley factor α of [`LUBRICATED_DAMPING`], s/m.
pub const LUBRICATED_ALPHA: f64 = 300.0;

/// The clearance model and the handles of its parts.
#[derive(Debug)]
pub struct ClearanceModel {
    /// The mechanism.
    pub mechanism: Mechanism,
    /// Arms.
    pub arms: [BodyHandle; 3],
    /// Forearms.
    pub forearms: [BodyHandle; 3],
    /// Crosses of D, E, F, P, Q, R.
    pub crosses: [BodyHandle; 6],
    /// Platform.
    pub platform: BodyHandle,
    /// Driven revolute pairs.
    pub drives: [JointHandle; 3],
}

/// The named clearance set of Table 1 (L1, L2, L3), or an error naming the unknown name.
pub fn clearance_set(name: &str) -> Result<ClearanceSet, Mr2120Error> {
    TABLE1
        .iter()
        .copied()
        .find(|s| s.name.eq_ignore_ascii_case(name))
        .ok_or_else(|| Mr2120Error::UnknownClearanceSet(name.into()))
}

/// The six universal joints in the order of per-joint clearances ([`JointClearances`]) and
/// of [`clearance_model_per_joint`]'s designs: elbows D, E, F, then platform joints P, Q, R.
pub const UNIVERSAL_JOINTS: [&str; 6] = ["D", "E", "F", "P", "Q", "R"];

/// A clearance per universal joint and per direction, in the order of [`UNIVERSAL_JOINTS`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct JointClearances {
    /// Radial clearance h_LR of each joint's bearings, m.
    pub radial: [f64; 6],
    /// Axial clearance h_LW of each joint's bearings, m.
    pub axial: [f64; 6],
}

impl JointClearances {
    /// The clearances of `set` in every joint.
    pub fn uniform(set: &ClearanceSet) -> Self {
        Self {
            radial: [set.radial; 6],
            axial: [set.axial; 6],
        }
    }

    /// Every clearance times `s`.
    pub fn scaled(&self, s: f64) -> Self {
        Self {
            radial: self.radial.map(|h| h * s),
            axial: self.axial.map(|h| h * s),
        }
    }

    /// The bearing designs of the six joints (lash's default contact damping).
    pub fn designs(&self) -> [Option<BearingDesign>; 6] {
        std::array::from_fn(|k| {
            Some(bearing_design(
                &ClearanceSet {
                    name: "per joint",
                    radial: self.radial[k],
                    axial: self.axial[k],
                },
                DEFAULT_DAMPING,
            ))
        })
    }
}

/// Bearing design of the MR2120 for a clearance set and a damping model.
pub fn bearing_design(set: &ClearanceSet, damping: Damping) -> BearingDesign {
    let mut d = BearingDesign::mr2120(set.radial, set.axial, damping);
    d.material = Material { e: STEEL_E, nu: 0.3 };
    d
}

/// Builds the clearance model in the configuration with platform centre `m_build`: the
/// geometry's nominal links and the same bearing `design` in all six universal joints.
pub fn clearance_model(
    g: &Geometry,
    mp: &MassProperties,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
    design: &BearingDesign,
) -> Result<ClearanceModel, Mr2120Error> {
    let designs: [Option<BearingDesign>; 6] = std::array::from_fn(|_| Some(*design));
    let m = clearance_model_per_joint(g, mp, &LinkSpec::nominal(g), m_build, laws, &designs)?;
    let platform = m.platform;
    Ok(ClearanceModel {
        mechanism: m.mechanism,
        arms: m.arms,
        forearms: m.forearms,
        crosses: m.crosses.map(|c| c.unwrap_or(platform)),
        platform,
        drives: m.drives,
    })
}

/// The MR2120 with its own bearing design in each universal joint: the model and the handles
/// of its parts ([`clearance_model_per_joint`]).
#[derive(Debug)]
pub struct JointPlayModel {
    /// The mechanism.
    pub mechanism: Mechanism,
    /// Arms.
    pub arms: [BodyHandle; 3],
    /// Forearms.
    pub forearms: [BodyHandle; 3],
    /// Crosses of D, E, F, P, Q, R; `None` for an ideal universal joint.
    pub crosses: [Option<BodyHandle>; 6],
    /// Ideal universal joints D, E, F, P, Q, R; `None` for a joint with play.
    pub ideal_joints: [Option<JointHandle>; 6],
    /// Platform.
    pub platform: BodyHandle,
    /// Revolute pairs A, B, C (driven if laws were given).
    pub drives: [JointHandle; 3],
    /// Drive angles of the build configuration per branch, rad.
    pub q_build: [f64; 3],
}

/// Builds the MR2120 in the configuration with platform centre `m_build` (m), with each
/// branch's own links, payload and gravity (`spec`) and, per universal joint in the order
/// D, E, F, P, Q, R, its own bearing design: `Some(design)` a trunnion bearing with radial and
/// axial clearance (a cross body of mass `mp.cross`, eight Hertz ball contacts), `None` an
/// ideal universal joint. All `None` is the ideal model ([`ideal_model_with`](super::ideal_model_with));
/// all equal `Some` with the nominal `spec` is [`clearance_model`]. The drives A, B, C follow
/// `laws` (rad) or are free revolute pairs if `None`.
pub fn clearance_model_per_joint(
    g: &Geometry,
    mp: &MassProperties,
    spec: &LinkSpec,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
    designs: &[Option<BearingDesign>; 6],
) -> Result<JointPlayModel, Mr2120Error> {
    let mut mech = Mechanism::new();
    let l = add_links(&mut mech, g, mp, spec, m_build, laws, [false; 6])?;
    let (crosses, ideal_joints) = add_universal_joints(&mut mech, &l, mp, designs)?;
    Ok(JointPlayModel {
        mechanism: mech,
        arms: l.arms,
        forearms: l.forearms,
        crosses,
        ideal_joints,
        platform: l.platform,
        drives: l.drives,
        q_build: l.q,
    })
}

/// Crosses and ideal-joint handles of the six universal joints.
pub(crate) type UniversalParts = ([Option<BodyHandle>; 6], [Option<JointHandle>; 6]);

/// Adds the six universal joints (D, P of branch A, then E, Q, then F, R — the order of the
/// original clearance model) to the links `l`: a bearing with clearance where `designs` has
/// one, an ideal universal joint elsewhere.
pub(crate) fn add_universal_joints(
    mech: &mut Mechanism,
    l: &Links,
    mp: &MassProperties,
    designs: &[Option<BearingDesign>; 6],
) -> Result<UniversalParts, Mr2120Error> {
    let mut crosses = [None; 6];
    let mut ideal = [None; 6];
    for i in 0..3 {
        // Elbow: axis_i along the drive axis (arm side), axis_j across (forearm side); the
        // platform joint the other way round.
        let joints = [
            (
                i,
                ELBOW_JOINTS[i],
                l.arms[i],
                l.forearms[i],
                l.elbows[i],
                l.axes[i],
                l.cross_axes[i],
            ),
            (
                3 + i,
                PLATFORM_JOINTS[i],
                l.forearms[i],
                l.platform,
                l.platform_points[i],
                l.cross_axes[i],
                l.axes[i],
            ),
        ];
        for (k, name, bi, bj, point, axis_i, axis_j) in joints {
            match &designs[k] {
                Some(design) => {
                    let u = universal_with_clearance(
                        mech, name, bi, bj, point, axis_i, axis_j, design, mp.cross,
                    )?;
                    crosses[k] = Some(u.cross);
                }
                None => ideal[k] = Some(mech.universal_at(name, bi, bj, point, axis_i, axis_j)),
            }
        }
    }
    Ok((crosses, ideal))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clearance_model_has_63_degrees_of_freedom() {
        let g = Geometry::default();
        let set = clearance_set("L1").unwrap();
        let m = clearance_model(
            &g,
            &MassProperties::default(),
            Vector3::new(0.0, 0.0, 0.5),
            None,
            &bearing_design(&set, DEFAULT_DAMPING),
        )
        .unwrap();
        assert_eq!(m.mechanism.bodies().len(), 13);
        assert_eq!(m.mechanism.degrees_of_freedom(), 63);
        assert_eq!(m.mechanism.forces().count(), 24);
        assert!(matches!(
            clearance_set("L9"),
            Err(Mr2120Error::UnknownClearanceSet(_))
        ));
    }

    #[test]
    fn per_joint_designs_build_the_same_models() {
        use crate::multibody::{Analysis, MechanismData};
        let g = Geometry::default();
        let mp = MassProperties::default();
        let m1 = Vector3::new(0.0, 0.0, 0.5);
        let design = bearing_design(&clearance_set("L2").unwrap(), DEFAULT_DAMPING);
        // All six equal: the same model as `clearance_model` (same bodies, joints, forces in
        // the same order, hence the same state layout and results).
        let a = clearance_model(&g, &mp, m1, None, &design).unwrap();
        let b =
            clearance_model_per_joint(&g, &mp, &LinkSpec::nominal(&g), m1, None, &[Some(design); 6]).unwrap();
        assert_eq!(a.mechanism.initial_guess(), b.mechanism.initial_guess());
        assert_eq!(a.mechanism.constraint_count(), b.mechanism.constraint_count());
        let names =
            |m: &Mechanism| -> Vec<String> { m.forces().map(|(_, f)| f.name().to_string()).collect() };
        assert_eq!(names(&a.mechanism), names(&b.mechanism));
        assert_eq!(a.crosses, b.crosses.map(Option::unwrap));
        assert!(b.ideal_joints.iter().all(Option::is_none));
        // None everywhere: the ideal model (3 degrees of freedom, no crosses).
        let c = clearance_model_per_joint(&g, &mp, &LinkSpec::nominal(&g), m1, None, &[None; 6]).unwrap();
        assert_eq!(c.mechanism.degrees_of_freedom(), 3);
        assert_eq!(c.mechanism.bodies().len(), 7);
        // Play in leg C's joints only (F and R): 3 + 2 × 10 degrees of freedom, 16 contacts.
        let mut designs = [None; 6];
        designs[2] = Some(design);
        designs[5] = Some(design);
        let d = clearance_model_per_joint(&g, &mp, &LinkSpec::nominal(&g), m1, None, &designs).unwrap();
        assert_eq!(d.mechanism.degrees_of_freedom(), 23);
        assert_eq!(d.mechanism.forces().count(), 8);
        assert!(d.crosses[2].is_some() && d.crosses[0].is_none() && d.ideal_joints[0].is_some());
        let an = Analysis::new(&d.mechanism).unwrap();
        an.initial_state(&d.mechanism, &mut MechanismData::new(&d.mechanism), 0.0)
            .unwrap();
    }
}
