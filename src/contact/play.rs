//! The play of a joint with clearance, quasi-statically: how far, and which way, the
//! clearance lets the joint's side j sit from side i under the load the joint carries. One
//! play model: the diagnosis' clearance candidates use it, and so can linearised worst-case
//! bounds (the loads set which side of each bearing a joint sits on).
//!
//! A universal joint with clearance ([`super::universal_with_clearance`]) is a cross in two
//! trunnion pairs; each pair has two bearings ([`BearingDesign`]) a ball spacing s apart,
//! with radial clearance h (the ball centre may move h off the bore axis) and axial play
//! h_a (total, ±h_a/2). Pushed by a force F (the joint's force on side j), each pair's
//! bearings sit against the bore wall opposite F's component across the pair's axis, and
//! against the end opposite F's component along it; a moment M about n = z_i × z_j (the
//! rotation a universal joint locks) tilts each pair by up to 2h/s, as far as the force
//! across the pair lets its balls part. So side j sits, from side i,
//!
//! * per pair (axis z): its two balls at ±(s/2)·z carry f± = F⊥/2 ± (M⊥ × z)/s across the
//!   axis (F⊥, M⊥ the parts of F and M perpendicular to z); each ball sits h against the wall
//!   opposite its own load, −h·f̂±; the pair moves by the mean, −(h/2)·(f̂₊ + f̂₋), and turns by
//!   −h·z × (f̂₊ − f̂₋)/s. So a pair pressed by a force much larger than the couple of the moment
//!   only shifts (both balls on the same side), and a pure moment tilts it by 2h/s;
//! * across the axes: the two pairs' shifts added; tilted about n by the two pairs' turns
//!   about n (up to 4h/s);
//! * along the axes: −(h_a/2)·(sign(F·z_i) z_i + sign(F·z_j) z_j).
//!
//! Signs and unit vectors are smoothed over a load scale F_c (N): sign(x) → x/√(x² + F_c²),
//! f̂ → f/√(|f|² + (F_c/2)²) per ball (half the joint's scale: one ball's share) — below F_c
//! the joint floats in its play. F_c is not a property of the joint but
//! of how firmly a load must press to move it across the play (friction, preload): the
//! diagnosis chooses it by cross-validation. Units: m, rad, N, N·m.

use super::stiffness::Material;
use super::BearingDesign;
use nalgebra::Vector3;

/// The play of a universal joint: two trunnion pairs with the same bearings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniversalPlay {
    /// Distance between the two bearings of a trunnion pair, m.
    pub ball_spacing: f64,
    /// Radius of the trunnion balls, m (with `material`, their Hertz contact).
    pub ball_radius: f64,
    /// Material of the balls and their bores.
    pub material: Material,
}

impl UniversalPlay {
    /// The play geometry of a universal joint built from `design`.
    pub fn from_design(design: &BearingDesign) -> Self {
        Self {
            ball_spacing: design.ball_spacing,
            ball_radius: design.ball_radius,
            material: design.material,
        }
    }
}

/// Where a universal joint's side j sits from side i, per unit clearance: the part of a
/// translation proportional to the radial clearance h, its tilt, and the part proportional
/// to the axial play h_a.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlayShift {
    /// Translation of side j per metre of radial clearance (base frame, m/m).
    pub radial_translation: Vector3<f64>,
    /// Rotation of side j about n = z_i × z_j per metre of radial clearance, rad/m.
    pub radial_tilt: f64,
    /// Translation of side j per metre of axial play (base frame, m/m).
    pub axial_translation: Vector3<f64>,
}

/// x/√(x² + s²): a smooth sign over the scale s (exact sign for s = 0, 0 at x = 0).
pub fn smooth_sign(x: f64, scale: f64) -> f64 {
    let d = (x * x + scale * scale).sqrt();
    if d > 0.0 {
        x / d
    } else {
        0.0
    }
}

impl UniversalPlay {
    /// The shift of side j under the joint's force `force` on side j (N, base frame) and
    /// moment `moment` on side j (N·m, base frame), with the axes `z_i`, `z_j` (unit, base
    /// frame) at the current pose, smoothed over the load scale `load_scale` (N). Both
    /// trunnion pairs carry `force`: the cross between them is weightless here
    /// ([`Self::shift_with_cross_weight`] when it is not).
    pub fn shift(
        &self,
        z_i: &Vector3<f64>,
        z_j: &Vector3<f64>,
        force: &Vector3<f64>,
        moment: &Vector3<f64>,
        load_scale: f64,
    ) -> PlayShift {
        self.shift_with_cross_weight(z_i, z_j, force, moment, &Vector3::zeros(), load_scale)
    }

    /// [`Self::shift`] with a cross of weight `cross_weight` (N, base frame: its mass times
    /// gravity at rest; moving, its mass times gravity less the acceleration of side i's point
    /// at the joint's centre, the load that carries it along) between the pairs: side j's
    /// pair carries `force`, side i's pair
    /// `force − cross_weight` (what side i passes to the cross, which holds the cross up as
    /// well); the weight acts at the cross's centre, so both pairs carry the same moment.
    /// Near a load reversal the weight decides which wall side i's balls sit against.
    pub fn shift_with_cross_weight(
        &self,
        z_i: &Vector3<f64>,
        z_j: &Vector3<f64>,
        force: &Vector3<f64>,
        moment: &Vector3<f64>,
        cross_weight: &Vector3<f64>,
        load_scale: f64,
    ) -> PlayShift {
        let n = z_i.cross(z_j);
        let n = if n.norm() > 0.0 { n.normalize() } else { n };
        let s = self.ball_spacing;
        // Per trunnion pair (axis z): its two balls at ±(s/2)·z carry F⊥/2 ± (M⊥ × z)/s
        // across the axis; each sits against the wall opposite its own load (a unit vector
        // smoothed over half the load scale, one ball's share). The pair moves by the mean
        // of its balls' shifts and turns by z × (difference)/s.
        let pair = |z: &Vector3<f64>, force: &Vector3<f64>| -> (Vector3<f64>, Vector3<f64>) {
            let f_perp = force - z * force.dot(z);
            let m_perp = moment - z * moment.dot(z);
            let g = m_perp.cross(z) / s;
            let unit = |f: Vector3<f64>| {
                let d = (f.norm_squared() + 0.25 * load_scale * load_scale).sqrt();
                if d > 0.0 {
                    f / d
                } else {
                    Vector3::zeros()
                }
            };
            let (u_plus, u_minus) = (unit(0.5 * f_perp + g), unit(0.5 * f_perp - g));
            (-0.5 * (u_plus + u_minus), -z.cross(&(u_plus - u_minus)) / s)
        };
        let force_i = force - cross_weight;
        let (t_i, th_i) = pair(z_i, &force_i);
        let (t_j, th_j) = pair(z_j, force);
        PlayShift {
            radial_translation: t_i + t_j,
            radial_tilt: (th_i + th_j).dot(&n),
            axial_translation: -0.5
                * (z_i * smooth_sign(force_i.dot(z_i), load_scale)
                    + z_j * smooth_sign(force.dot(z_j), load_scale)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::Damping;

    #[test]
    fn a_hanging_load_sits_on_the_far_side_of_the_play() {
        let play = UniversalPlay::from_design(&BearingDesign::mr2120(1e-5, 2e-5, Damping::Elastic));
        // Axes horizontal (x and y): a weight on side j pulled down by the joint's upward
        // force sags by the radial clearance across both pairs.
        let up = Vector3::new(0.0, 0.0, 100.0);
        let s = play.shift(&Vector3::x(), &Vector3::y(), &up, &Vector3::zeros(), 1e-3);
        assert!((s.radial_translation - Vector3::new(0.0, 0.0, -2.0)).norm() < 1e-6);
        assert_eq!(s.axial_translation, Vector3::zeros());
        // A load along z_i pushes that pair against its end: −h_a/2 along z_i; across z_j it
        // sits h off.
        let along = Vector3::new(50.0, 0.0, 0.0);
        let s = play.shift(&Vector3::x(), &Vector3::y(), &along, &Vector3::zeros(), 1e-3);
        assert!((s.axial_translation - Vector3::new(-0.5, 0.0, 0.0)).norm() < 1e-6);
        assert!((s.radial_translation - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-6);
        // A moment about n = x × y = z tilts by 4h/s against it: 4/0.024 rad per metre.
        let m = Vector3::new(0.0, 0.0, 2.0);
        let s = play.shift(&Vector3::x(), &Vector3::y(), &Vector3::zeros(), &m, 1e-6);
        assert!((s.radial_tilt + 4.0 / 0.024).abs() < 1e-6);
        // Below the load scale the joint floats: half a load scale gives 1/√5 of the shift.
        let s = play.shift(
            &Vector3::x(),
            &Vector3::y(),
            &Vector3::new(0.0, 0.0, 0.5),
            &Vector3::zeros(),
            1.0,
        );
        assert!((s.radial_translation.z + 2.0 / 5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_cross_heavier_than_the_pull_on_side_j_hangs_on_side_i() {
        let play = UniversalPlay::from_design(&BearingDesign::mr2120(1e-5, 2e-5, Damping::Elastic));
        let (x, y, zero) = (Vector3::x(), Vector3::y(), Vector3::zeros());
        // Side j pulled down by 0.3 N across horizontal axes: weightless, both pairs sit up
        // (+h each); a 0.5 N cross makes side i hold it up with 0.2 N, so side i's pair sits
        // down (−h) while side j's still sits up: the two cancel.
        let down = Vector3::new(0.0, 0.0, -0.3);
        let weight = Vector3::new(0.0, 0.0, -0.5);
        let weightless = play.shift(&x, &y, &down, &zero, 0.0);
        assert!((weightless.radial_translation - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-12);
        let heavy = play.shift_with_cross_weight(&x, &y, &down, &zero, &weight, 0.0);
        assert!(heavy.radial_translation.norm() < 1e-12);
        // Side i's axial contact follows its own load: 0.2 N along z_i with the cross's
        // weight along it, −0.3 N without.
        let (zi, zj) = (Vector3::z(), Vector3::x());
        let along = play.shift_with_cross_weight(&zi, &zj, &down, &zero, &weight, 0.0);
        assert!((along.axial_translation - Vector3::new(0.0, 0.0, -0.5)).norm() < 1e-12);
        let along = play.shift(&zi, &zj, &down, &zero, 0.0);
        assert!((along.axial_translation - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
        // A load well above the weight: the weight moves nothing but by its share.
        let up = Vector3::new(0.0, 0.0, 100.0);
        let heavy = play.shift_with_cross_weight(&x, &y, &up, &zero, &weight, 0.0);
        assert!((heavy.radial_translation - Vector3::new(0.0, 0.0, -2.0)).norm() < 1e-12);
    }
}
