//! Joints with clearance, built from contact elements ("shape connections").

use super::bearing::{BallInSocket, ClearanceBearing};
use super::laws::{Friction, NormalLaw};
use super::stiffness::{ball_in_bore, ball_in_socket, ball_on_flat, Material};
use super::{clearance, positive, ContactError};
use crate::multibody::{Attach, BodyHandle, Mechanism, RigidBody};
use nalgebra::{Matrix3, Vector3};

/// How contact damping is modelled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Damping {
    /// Ideally elastic Hertz contact, as in the paper.
    Elastic,
    /// Hunt–Crossley damping with factor α (s/m).
    HuntCrossley(f64),
    /// Lankarani–Nikravesh hysteresis with restitution e at reference velocity v_ref (m/s).
    LankaraniNikravesh(f64, f64),
    /// Flores hysteresis with restitution e at reference velocity v_ref (m/s).
    Flores(f64, f64),
}

/// Design data of the bearings of a joint with clearance (one place for every dimension
/// the paper does not give; defaults from `../shared/reference/mr2120-geometry.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingDesign {
    /// Ball (trunnion end) radius, m.
    pub ball_radius: f64,
    /// Distance between the two ball centres across the cross (or along a pin), m.
    pub ball_spacing: f64,
    /// Radial clearance h_LR, m.
    pub radial_clearance: f64,
    /// Axial clearance h_LW (total axial play), m.
    pub axial_clearance: f64,
    /// Material of both contacting parts.
    pub material: Material,
    /// Damping model.
    pub damping: Damping,
    /// Optional Coulomb friction.
    pub friction: Option<Friction>,
}

impl BearingDesign {
    /// The MR2120 trunnion bearing: 4 mm balls 24 mm apart, steel, with the given clearances
    /// (m) and damping.
    pub fn mr2120(radial: f64, axial: f64, damping: Damping) -> Self {
        Self {
            ball_radius: 0.004,
            ball_spacing: 0.024,
            radial_clearance: radial,
            axial_clearance: axial,
            material: Material::steel(),
            damping,
            friction: None,
        }
    }

    /// Checks every quantity, naming the bad one.
    pub fn validate(&self) -> Result<(), ContactError> {
        positive("ball radius", self.ball_radius)?;
        positive("ball spacing", self.ball_spacing)?;
        clearance("radial clearance h_LR", self.radial_clearance)?;
        clearance("axial clearance h_LW", self.axial_clearance)?;
        self.material.validate()?;
        if let Some(f) = &self.friction {
            f.validate()?;
        }
        self.law(1.0).validate()
    }

    fn law(&self, k: f64) -> NormalLaw {
        match self.damping {
            Damping::Elastic => NormalLaw::hertz(k),
            Damping::HuntCrossley(alpha) => NormalLaw::HuntCrossley { k, n: 1.5, alpha },
            Damping::LankaraniNikravesh(e, v) => NormalLaw::LankaraniNikravesh {
                k,
                n: 1.5,
                restitution: e,
                v_ref: v,
            },
            Damping::Flores(e, v) => NormalLaw::Flores {
                k,
                n: 1.5,
                restitution: e,
                v_ref: v,
            },
        }
    }

    /// Radial law (ball in a bore of radius ball + h_LR) and axial law (ball on the end face).
    pub fn laws(&self) -> Result<(NormalLaw, NormalLaw), ContactError> {
        self.validate()?;
        let m = &self.material;
        let kr = ball_in_bore(self.ball_radius, self.ball_radius + self.radial_clearance, m, m)?;
        let ka = ball_on_flat(self.ball_radius, m, m)?;
        Ok((self.law(kr), self.law(ka)))
    }
}

/// A universal joint with clearance: its cross as a body of its own, four trunnion bearings.
#[derive(Debug, Clone, Copy)]
pub struct ClearanceUniversal {
    /// The cross.
    pub cross: BodyHandle,
}

/// Principal inertia (kg·m²) of a universal joint's cross of mass `cross_mass` (kg) whose
/// trunnion balls sit `ball_spacing` (m) apart: two perpendicular rods of that length, about
/// the side-i axis, the side-j axis and their normal.
pub fn cross_inertia(cross_mass: f64, ball_spacing: f64) -> Vector3<f64> {
    let rod = cross_mass / 2.0 * ball_spacing * ball_spacing / 12.0;
    Vector3::new(rod, rod, 2.0 * rod)
}

/// Adds a universal joint with clearance at base-frame `point` between sides i and j: a cross
/// body (mass `cross_mass`, kg) whose trunnions along `axis_i` sit in two sockets on side i
/// and whose trunnions along `axis_j` sit in two sockets on side j (paper Fig. 6). Each
/// socket is a cylinder coaxial with its trunnion, of radius ball + h_LR; the socket spacing
/// exceeds the ball spacing by h_LW.
#[allow(clippy::too_many_arguments)]
pub fn universal_with_clearance(
    mech: &mut Mechanism,
    name: &str,
    i: impl Into<Attach>,
    j: impl Into<Attach>,
    point: Vector3<f64>,
    axis_i: Vector3<f64>,
    axis_j: Vector3<f64>,
    design: &BearingDesign,
    cross_mass: f64,
) -> Result<ClearanceUniversal, ContactError> {
    let (i, j) = (i.into(), j.into());
    positive("cross mass", cross_mass)?;
    pose0(mech, i)?;
    pose0(mech, j)?;
    let (radial_law, axial_law) = design.laws()?;
    let (ai, aj) = (axis_i.normalize(), axis_j.normalize());
    let aj = (aj - ai * aj.dot(&ai)).normalize();
    let frame = Matrix3::from_columns(&[ai, aj, ai.cross(&aj)]);
    // A cross of four rods of half-length s/2: inertia of two perpendicular rods.
    let s = design.ball_spacing;
    let inertia = Matrix3::from_diagonal(&cross_inertia(cross_mass, s));
    let cross = mech.add_body(
        RigidBody::new(format!("cross {name}"), cross_mass, inertia)
            .at(point)
            .oriented(&frame),
    );
    let half = s / 2.0;
    for (side, axis, label, local_axis) in [(i, ai, "i", Vector3::x()), (j, aj, "j", Vector3::y())] {
        let (r, rot) = pose0(mech, side)?;
        for sign in [1.0, -1.0] {
            let ball_local = local_axis * (sign * half);
            let socket_centre = rot.transpose() * (point + axis * (sign * half) - r);
            let socket_axis = rot.transpose() * (axis * sign);
            mech.add_force(Box::new(ClearanceBearing {
                name: format!("{name} bearing {label}{}", if sign > 0.0 { "+" } else { "-" }),
                ball_body: Attach::Body(cross),
                ball_centre: ball_local,
                socket_body: side,
                socket_centre,
                socket_axis,
                radial_clearance: design.radial_clearance,
                axial_stop: design.axial_clearance / 2.0,
                radial_law,
                axial_law,
                friction: design.friction,
            }));
        }
    }
    Ok(ClearanceUniversal { cross })
}

fn pose0(mech: &Mechanism, a: Attach) -> Result<(Vector3<f64>, Matrix3<f64>), ContactError> {
    // (Only a body can be missing: the ground's pose is the base frame.)
    let index = match a {
        Attach::Body(h) => h.index(),
        Attach::Ground => usize::MAX,
    };
    mech.initial_pose(a).ok_or(ContactError::UnknownBody(index))
}

/// Adds a revolute joint with clearance: a pin on side j in a bore on side i along `axis`
/// through `point`, modelled by two ball-in-bore contacts `design.ball_spacing` apart (radial
/// play h_LR, axial play h_LW between the pin's shoulders and the bore's faces).
pub fn revolute_with_clearance(
    mech: &mut Mechanism,
    name: &str,
    i: impl Into<Attach>,
    j: impl Into<Attach>,
    point: Vector3<f64>,
    axis: Vector3<f64>,
    design: &BearingDesign,
) -> Result<(), ContactError> {
    let (i, j) = (i.into(), j.into());
    let (radial_law, axial_law) = design.laws()?;
    let a = axis.normalize();
    let (ri, roti) = pose0(mech, i)?;
    let (rj, rotj) = pose0(mech, j)?;
    let half = design.ball_spacing / 2.0;
    for sign in [1.0, -1.0] {
        let x = point + a * (sign * half);
        mech.add_force(Box::new(ClearanceBearing {
            name: format!("{name} bearing {}", if sign > 0.0 { "+" } else { "-" }),
            ball_body: j,
            ball_centre: rotj.transpose() * (x - rj),
            socket_body: i,
            socket_centre: roti.transpose() * (x - ri),
            socket_axis: roti.transpose() * (a * sign),
            radial_clearance: design.radial_clearance,
            axial_stop: design.axial_clearance / 2.0,
            radial_law,
            axial_law,
            friction: design.friction,
        }));
    }
    Ok(())
}

/// Adds a spherical joint with clearance: a ball on side j in a spherical socket on side i at
/// `point`, with clearance h_LR.
pub fn spherical_with_clearance(
    mech: &mut Mechanism,
    name: &str,
    i: impl Into<Attach>,
    j: impl Into<Attach>,
    point: Vector3<f64>,
    design: &BearingDesign,
) -> Result<(), ContactError> {
    let (i, j) = (i.into(), j.into());
    design.validate()?;
    let m = &design.material;
    let k = ball_in_socket(
        design.ball_radius,
        design.ball_radius + design.radial_clearance,
        m,
        m,
    )?;
    let (ri, roti) = pose0(mech, i)?;
    let (rj, rotj) = pose0(mech, j)?;
    mech.add_force(Box::new(BallInSocket {
        name: name.into(),
        ball_body: j,
        ball_centre: rotj.transpose() * (point - rj),
        socket_body: i,
        socket_centre: roti.transpose() * (point - ri),
        clearance: design.radial_clearance,
        law: design.law(k),
        friction: design.friction,
    }));
    Ok(())
}
