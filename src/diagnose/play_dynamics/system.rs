//! The linearised mechanics at one sample ([`System`]): mass, stiffness, damping and load,
//! and the forces a substep sees.

use super::balls::cross_frame;
use super::dense::{gemv_block, leading_block};
use super::{PlaySample, CROSS, NP};
use crate::diagnose::model::PlayDynamics;
use nalgebra::{DMatrix, DVector};

/// The system at one sample: mass, stiffness (drives, play coordinates, then the cross), the
/// drives' dampings and the constant load g: M·ẍ + D·ẋ + K·x = g + [0; Λ_c(e, ė); cross load].
/// About the nominal motion g = [0; −Λ; 0]; about a point x₁ ([`PlaySample::about`])
/// g = f(x₁) + K₁·x₁, with f(x₁) = [Δτ(x₁); −Λ(x₁); 0] what the mechanism exerts there and K₁
/// its stiffness there (the transmissions' own aside): f(x) ≈ f(x₁) − K₁·(x − x₁).
pub(super) struct System {
    pub(super) mass: DMatrix<f64>,
    pub(super) stiffness: DMatrix<f64>,
    /// The transmissions' damping and the mechanism's velocity products linearised in the
    /// rates (where the coupling knows them).
    pub(super) damping: DMatrix<f64>,
    pub(super) load: DVector<f64>,
    /// The leading block of the stiffness and the damping outside of which both are zero
    /// ([`leading_block`]): the products with them skip the rest.
    pub(super) active: usize,
}

/// The play's coupling the sample expands about: the point's where given, else the sample's.
pub(super) fn coupling<'a>(s: &PlaySample<'a>) -> &'a PlayDynamics {
    s.about.map_or(s.play, |a| &a.dynamics)
}

/// The system's matrices at one sample ([`System`]).
pub(super) fn matrices(s: &PlaySample) -> Option<System> {
    let (p, td) = (coupling(s), s.transmission);
    let nj = td.compliance.len();
    let n = nj + NP;
    let (drive_mass, load_stiffness) = match s.about {
        Some(a) => (&a.mass, Some(&a.load_stiffness)),
        None => (&td.mass, td.load_stiffness.as_ref()),
    };
    if drive_mass.shape() != (nj, nj)
        || p.reaction_by_drive.len() != nj
        || p.reaction_by_drive_acceleration.len() != nj
        || p.torque_by_offset
            .iter()
            .chain(&p.torque_by_offset_acceleration)
            .any(|v| v.len() != nj)
    {
        return None;
    }
    let kr = td.response_stiffness_with(load_stiffness);
    let mut mm = DMatrix::zeros(n, n);
    let mut kk = DMatrix::zeros(n, n);
    for a in 0..nj {
        for b in 0..nj {
            mm[(a, b)] = drive_mass[(a, b)];
            kk[(a, b)] = kr[(a, b)];
        }
        for c in 0..4 {
            mm[(a, nj + c)] = -p.torque_by_offset_acceleration[c][a];
            kk[(a, nj + c)] = -p.torque_by_offset[c][a];
            mm[(nj + c, a)] = -p.reaction_by_drive_acceleration[a][c];
            kk[(nj + c, a)] = -p.reaction_by_drive[a][c];
        }
    }
    for r in 0..4 {
        for c in 0..4 {
            mm[(nj + r, nj + c)] = p.reaction_by_offset_acceleration[c][r];
            kk[(nj + r, nj + c)] = p.reaction_by_offset[c][r];
        }
    }
    // The cross: its mass, and two perpendicular rods' inertia (s/2 either side) about u1,
    // u2, twice that about u3.
    let frame = nalgebra::Matrix3::from_columns(&cross_frame(p)?);
    let principal = crate::contact::joints::cross_inertia(p.cross_mass, p.play.ball_spacing);
    let inertia = frame * nalgebra::Matrix3::from_diagonal(&principal) * frame.transpose();
    let cross_mass = p.cross_mass;
    for r in 0..3 {
        mm[(nj + CROSS + r, nj + CROSS + r)] = cross_mass;
        for c in 0..3 {
            mm[(nj + CROSS + 3 + r, nj + CROSS + 3 + c)] = inertia[(r, c)];
        }
    }
    let mut damping = DMatrix::zeros(n, n);
    for a in 0..nj {
        damping[(a, a)] = td.damping[a];
    }
    // The velocity products, laid out as the stiffness: ∂τ_s/∂q̇ as S, the offsets' rates as
    // their positions.
    if p.torque_by_drive_rate.len() == nj && p.torque_by_drive_rate.iter().all(|v| v.len() == nj) {
        for k in 0..nj {
            for j in 0..nj {
                damping[(j, k)] += p.torque_by_drive_rate[k][j];
            }
        }
    }
    if p.torque_by_offset_rate.len() == 4
        && p.torque_by_offset_rate.iter().all(|v| v.len() == nj)
        && p.reaction_by_offset_rate.len() == 4
        && p.reaction_by_drive_rate.len() == nj
    {
        for a in 0..nj {
            for c in 0..4 {
                damping[(a, nj + c)] = -p.torque_by_offset_rate[c][a];
                damping[(nj + c, a)] = -p.reaction_by_drive_rate[a][c];
            }
        }
        for r in 0..4 {
            for c in 0..4 {
                damping[(nj + r, nj + c)] = p.reaction_by_offset_rate[c][r];
            }
        }
    }
    // The constant load: −Λ on the joint's rows; about a point x₁ also the torques' change
    // there, and K₁·x₁.
    let mut load = DVector::zeros(n);
    for r in 0..4 {
        load[nj + r] = -p.reaction[r];
    }
    // The cross's weight and what carries it along with side i, on its balls.
    for r in 0..3 {
        load[nj + CROSS + r] = p.cross_load[r];
    }
    if let Some(a) = s.about {
        if a.windup.len() != nj || a.torque.len() != nj {
            return None;
        }
        let mut x1 = DVector::zeros(n);
        for k in 0..nj {
            x1[k] = a.windup[k];
        }
        for c in 0..4 {
            x1[nj + c] = a.offset[c];
        }
        let mut k_mech = kk.clone();
        for (k, stiffness) in td.stiffness().iter().enumerate() {
            k_mech[(k, k)] -= stiffness;
        }
        load += &k_mech * &x1;
        for k in 0..nj {
            load[k] += a.torque[k];
        }
    }
    mm.iter()
        .chain(kk.iter())
        .chain(damping.iter())
        .chain(load.iter())
        .all(|v| v.is_finite())
        .then_some(System {
            active: leading_block(n, &[&kk, &damping]),
            mass: mm,
            stiffness: kk,
            damping,
            load,
        })
}

/// The forces of substep `j` of `n` into `rhs`, in place: g − K·x − C·v of `sys`, blended
/// at the substep's midpoint with `prev`'s where given ([`Interpolation::Linear`](super::Interpolation::Linear)), plus the
/// contacts' loads `lc` on the play coordinates (the last [`NP`] rows).
pub(super) fn forces_into(
    rhs: &mut DVector<f64>,
    sys: &System,
    prev: Option<&System>,
    at: f64,
    x: &DVector<f64>,
    v: &DVector<f64>,
    lc: &[f64; NP],
) {
    let (r, x, v) = (rhs.as_mut_slice(), x.as_slice(), v.as_slice());
    let size = r.len();
    r.copy_from_slice(sys.load.as_slice());
    // Only the leading blocks where the stiffness and damping are not zero (β = 1: the
    // rest would add zeros).
    let m = sys.active;
    gemv_block(&mut r[..m], -1.0, sys.stiffness.as_slice(), size, &x[..m], 1.0);
    gemv_block(&mut r[..m], -1.0, sys.damping.as_slice(), size, &v[..m], 1.0);
    if let Some(p) = prev {
        let w = 1.0 - at;
        let keep = 1.0 - w;
        for (ri, &pl) in r.iter_mut().zip(p.load.as_slice()) {
            *ri = w * pl + keep * *ri;
        }
        let m = p.active;
        gemv_block(&mut r[..m], -w, p.stiffness.as_slice(), size, &x[..m], 1.0);
        gemv_block(&mut r[..m], -w, p.damping.as_slice(), size, &v[..m], 1.0);
    }
    let nj = r.len() - NP;
    for (ri, &l) in r[nj..].iter_mut().zip(lc) {
        *ri += l;
    }
}
