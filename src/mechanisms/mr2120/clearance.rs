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
use super::ideal::{add_links, LinkSpec, Mr2120Error, ELBOW_JOINTS, PLATFORM_JOINTS};
use super::paper::{ClearanceSet, STEEL_E, TABLE1};
use crate::contact::{universal_with_clearance, BearingDesign, Damping, Material};
use crate::multibody::{BodyHandle, JointHandle, Mechanism, MotionLaw};
use nalgebra::Vector3;

/// Default contact damping of the clearance model: Hunt–Crossley α = 1 s/m (a coefficient of
/// restitution e ≈ 1 − (2/3)·α·v ≈ 0.93 for a 0.1 m/s impact; Hunt & Crossley 1975). With it
/// and index-2 velocity errors the settling rattle at M1 takes 1 500 steps instead of 26 000
/// (elastic contact, index-1 velocities) while the static sag differs by a few per cent.
pub const DEFAULT_DAMPING: Damping = Damping::HuntCrossley(1.0);

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

/// Bearing design of the MR2120 for a clearance set and a damping model.
pub fn bearing_design(set: &ClearanceSet, damping: Damping) -> BearingDesign {
    let mut d = BearingDesign::mr2120(set.radial, set.axial, damping);
    d.material = Material { e: STEEL_E, nu: 0.3 };
    d
}

/// Builds the clearance model in the configuration with platform centre `m_build`.
pub fn clearance_model(
    g: &Geometry,
    mp: &MassProperties,
    m_build: Vector3<f64>,
    laws: Option<[MotionLaw; 3]>,
    design: &BearingDesign,
) -> Result<ClearanceModel, Mr2120Error> {
    let mut mech = Mechanism::new();
    let l = add_links(&mut mech, g, mp, &LinkSpec::nominal(g), m_build, laws)?;
    let mut crosses = [l.platform; 6];
    for i in 0..3 {
        let d = universal_with_clearance(
            &mut mech,
            ELBOW_JOINTS[i],
            l.arms[i],
            l.forearms[i],
            l.elbows[i],
            l.axes[i],
            l.cross_axes[i],
            design,
            mp.cross,
        )?;
        let p = universal_with_clearance(
            &mut mech,
            PLATFORM_JOINTS[i],
            l.forearms[i],
            l.platform,
            l.platform_points[i],
            l.cross_axes[i],
            l.axes[i],
            design,
            mp.cross,
        )?;
        crosses[i] = d.cross;
        crosses[3 + i] = p.cross;
    }
    Ok(ClearanceModel {
        mechanism: mech,
        arms: l.arms,
        forearms: l.forearms,
        crosses,
        platform: l.platform,
        drives: l.drives,
    })
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
}
