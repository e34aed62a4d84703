//! The static start of a recording, or after a gap: the joint against the walls its load
//! pushes it to, then Newton's method on the statics ([`static_start`]).

use super::balls::{contact_load, cross_frame, BallContact, Contact, JointPlay};
use super::system::{coupling, System};
use super::{PlaySample, CROSS, NP};
use nalgebra::{DVector, Vector3};

/// The static state at sample `s`: K·x = g + [0; Λ_c(x, 0); cross load] ([`System`]) by
/// Newton's method (minimum-norm steps) from the joint against the walls and ends its
/// reaction pushes it to (the cross half-way across n, turned by half the tilt), the
/// transmissions wound up by the torques that asks for.
pub(super) fn static_start(
    s: &PlaySample,
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
) -> Option<DVector<f64>> {
    let (p, kk) = (coupling(s), &sys.stiffness);
    let nj = s.transmission.compliance.len();
    let [u1, u2, n] = cross_frame(p)?;
    // The reaction the joint carries, where its load pushes it (about a point, the point's
    // own: −g there is the expansion's reaction at the sample, which near a singular position
    // can point elsewhere).
    let reaction = p.reaction;
    let force = Vector3::new(reaction[0], reaction[1], reaction[2]);
    // Side i's pair carries the cross besides (as the system solved below does).
    let shift = p.play.shift_with_cross_weight(
        &p.z_i,
        &p.z_j,
        &force,
        &(n * reaction[3]),
        &Vector3::from(p.cross_load),
        1e-6,
    );
    // A tenth beyond the walls and ends, so that the loaded balls start in contact
    // (Newton's method sees no stiffness inside the play).
    // (Without radial clearance, a tenth of the axial play's half, or of a nanometre.)
    let beyond = 1.1 * play.radial + 0.1 * play.scale();
    let radial = shift.radial_translation * beyond;
    let phi = shift.radial_tilt * beyond;
    // The axial shift per pair: the cross along u1 from side i, side j along u2 from the cross.
    let axial = shift.axial_translation * (1.1 * play.axial + 0.2 * play.scale());
    let (axial_i, axial_j) = (axial.dot(&u1), axial.dot(&u2));
    let e = radial + u1 * axial_i + u2 * axial_j;
    // Radially the cross moves with side j across u1 (it rides side j's trunnions axially),
    // with side i along u1, and half-way along n.
    let c = radial - u1 * radial.dot(&u1) - n * (0.5 * radial.dot(&n)) + u1 * axial_i;
    let mut x = DVector::zeros(nj + NP);
    for k in 0..3 {
        x[nj + k] = e[k];
        x[nj + CROSS + k] = c[k];
        x[nj + CROSS + 3 + k] = 0.5 * phi * n[k];
    }
    x[nj + 3] = phi;
    let zero = [0.0; NP];
    let residual = |x: &DVector<f64>| {
        let lc = contact_load(ks, &x.as_slice()[nj..], &zero, play, contact);
        let mut r = kk * x - &sys.load;
        for k in 0..NP {
            r[nj + k] -= lc[k];
        }
        r
    };
    // The load (N, or N·m), and how far it presses the balls.
    let load = reaction.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for _ in 0..100 {
        let r = residual(&x);
        let mut jac = kk.clone();
        for c in 0..NP {
            let rotation = c == 3 || c >= CROSS + 3;
            let step = 1e-9 * play.scale() / if rotation { p.play.ball_spacing } else { 1.0 };
            let mut xp = x.clone();
            xp[nj + c] += step;
            let dr = (residual(&xp) - &r) / step;
            jac.set_column(nj + c, &dr);
        }
        // Least squares: a joint pressed in one direction floats in the others (a tangential
        // shift of a ball on its wall is free to first order), so the Jacobian may be
        // singular there; the minimum-norm step leaves those coordinates where they are.
        let tol = 1e-12 * jac.amax();
        let mut dx = jac.svd(true, true).solve(&r, tol).ok()?;
        // No step moves a ball by more than the clearance (or, without play, than the load
        // presses it): where the balls lose contact the Jacobian loses their stiffness, and a
        // full step would fly off.
        let reach = (0..NP)
            .map(|c| {
                let rotation = c == 3 || c >= CROSS + 3;
                dx[nj + c].abs() * if rotation { p.play.ball_spacing / 2.0 } else { 1.0 }
            })
            .fold(0.0, f64::max);
        let limit = play.scale().max(contact.compression(load));
        if reach > limit {
            dx *= limit / reach;
        }
        x -= &dx;
        if reach < 1e-9 * limit {
            break;
        }
    }
    // Converged: the joint's and the cross's loads balance to a millionth of the load.
    let r = residual(&x);
    (x.iter().all(|v| v.is_finite()) && r.rows(nj, NP).amax() <= 1e-6 * load).then_some(x)
}
