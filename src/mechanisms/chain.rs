//! A chain of N rigid links joined by universal joints with clearance: the scaling benchmark.
//! Link k spans x ∈ [k·L, (k + 1)·L] at rest; joint k sits at x = k·L (joint 0 to the ground),
//! its cross turning about y on the inboard side and about z on the outboard side. The chain
//! starts horizontal and falls under gravity, so every bearing comes into contact. With the
//! crosses as bodies it has 2N bodies and 12N degrees of freedom, no kinematic constraints,
//! and a Jacobian whose sparsity is that of a path: its factorisation should cost O(N).

use crate::contact::{universal_with_clearance, BearingDesign, ContactError, Damping};
use crate::multibody::{Attach, Mechanism, RigidBody};
use nalgebra::Vector3;

/// Link length, m.
pub const LINK_LENGTH: f64 = 0.1;
/// Link mass, kg.
pub const LINK_MASS: f64 = 0.1;
/// Cross mass, kg.
pub const CROSS_MASS: f64 = 0.01;

/// The bearings of the chain: the MR2120's (4 mm balls 24 mm apart) with 20 µm radial and
/// axial clearance and Hunt–Crossley damping α = 300 s/m.
pub fn chain_design() -> BearingDesign {
    BearingDesign::mr2120(20e-6, 20e-6, Damping::HuntCrossley(300.0))
}

/// Builds the chain of `n` links (n ≥ 1).
pub fn clearance_chain(n: usize, design: &BearingDesign) -> Result<Mechanism, ContactError> {
    if n == 0 {
        return Err(ContactError::NonPositive {
            what: "number of chain links".into(),
            value: 0.0,
        });
    }
    let mut mech = Mechanism::new();
    let mut prev = Attach::Ground;
    for k in 0..n {
        let x0 = k as f64 * LINK_LENGTH;
        let link = mech.add_body(
            RigidBody::rod(format!("link {k}"), LINK_MASS, LINK_LENGTH).at(Vector3::new(
                x0 + LINK_LENGTH / 2.0,
                0.0,
                0.0,
            )),
        );
        universal_with_clearance(
            &mut mech,
            &format!("joint {k}"),
            prev,
            link,
            Vector3::new(x0, 0.0, 0.0),
            Vector3::y(),
            Vector3::z(),
            design,
            CROSS_MASS,
        )?;
        prev = Attach::Body(link);
    }
    Ok(mech)
}
