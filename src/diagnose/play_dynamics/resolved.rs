//! Resolved substeps: semi-implicit (symplectic) Euler at a fifth of the fastest mode's
//! period, the dampings implicit where they would ask for many more ([`advance`]).

use super::balls::{
    contact_gram, contact_load, contact_load_and_damping, BallContact, Contact, Damping, JointPlay,
};
use super::dense::{gemv_two_blocks, largest_by_mass, step_positions, sym, two_blocks, PlaySchur};
use super::system::{forces_into, System};
use super::NP;
use nalgebra::DVector;

/// How one sample interval is integrated ([`substeps`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Substeps {
    /// Number of substeps.
    pub(super) n: usize,
    /// The dampings implicit (else explicit, resolved by the substep).
    pub(super) implicit: bool,
}

/// Cost of an implicit substep (a small LU) in explicit ones, for [`substeps`]' choice (set
/// when the implicit substep factorised all the unknowns; not re-measured since it factorises
/// only the play block's Schur complement, which is cheaper).
pub(super) const IMPLICIT_COST: usize = 4;

/// Substeps per period of the reduced model's fastest mode (every ball in contact).
///
/// Semi-implicit Euler is stable for dt·ω < 2; five per period is dt·ω = 1.26, a margin of
/// 1.6 (ten per period had 3.2) over the fastest mode estimated with Hertz's stiffness at four
/// times the joint's load: a load peak above that estimate reaches the limit sooner. Measured with
/// the example `play_dynamics` (session 52, suite truth, recording 5 unless named; what the
/// model leaves of the play's effect per drive and window, torque-noise units, and the
/// tracker's): joint F with 6 µm, Hertz balls, 20 N·s/m + 500 s/m × F, blended forces,
/// re-linearised once — 5 (fifth), 10 and 20 substeps per period give the same numbers to
/// 0.01 (drive A 2.77–3.10 s: 3.62 / 3.63 / 3.63), 3.3 per period too; joint D with 10 µm of
/// axial play and joint F on recording 3 (held forces, 200 N·s/m + 1 000 s/m × F): 5 and 10
/// agree to 0.01 on every channel and window. The reduced model's time halves from 10 to 5
/// (14.5 → 8.4 s for joint F's two runs; 3.1 → 1.6 s for the example `play_model_run`).
pub const SUBSTEPS_PER_PERIOD: f64 = 5.0;

/// Substeps for one sample interval of `h` s: [`SUBSTEPS_PER_PERIOD`] per period of the fastest mode
/// with every ball in contact (the largest eigenvalue of M⁻¹·(K + K_c), K_c = k·Σ JᵀJ, k the
/// contact's stiffness — Hertz's under four times the joint's `load`, at least 400 N), and
/// where the velocity products feed a mode (−C not negative semidefinite) dt·λ_max(M⁻¹·(−C))
/// ≤ 0.5. Explicit dampings must be resolved too, dt·λ_max(M⁻¹·(C + C_c)) ≤ 0.5 (C_c = c·Σ JᵀJ,
/// c the contact's damping under four times the load); where that asks for more than
/// [`IMPLICIT_COST`] times the substeps, they are taken implicitly instead ([`respond`](super::respond)).
/// At least 1, at most 100 000. None if the mass matrix is not positive definite.
pub(super) fn substeps(
    sys: &System,
    ks: &[Contact; 8],
    contact: &BallContact,
    load: f64,
    h: f64,
) -> Option<Substeps> {
    let jtj = contact_gram(ks, sys.mass.nrows());
    let largest = largest_by_mass(&sys.mass)?;
    let k_contact = contact.tangent_stiffness(4.0 * load.max(100.0));
    let c_contact = contact.damping + contact.load_damping * 4.0 * load.max(100.0);
    let omega = largest(sym(&sys.stiffness) + &jtj * k_contact).sqrt();
    let c = sym(&sys.damping);
    let growing = largest(-c.clone());
    let damped = largest(&jtj * c_contact + c);
    let dt =
        (2.0 * std::f64::consts::PI / SUBSTEPS_PER_PERIOD / omega.max(1e-300)).min(0.5 / growing.max(1e-300));
    let count = |dt: f64| ((h / dt).ceil() as usize).clamp(1, 100_000);
    let (implicit, explicit) = (count(dt), count(dt.min(0.5 / damped.max(1e-300))));
    Some(if explicit > IMPLICIT_COST * implicit {
        Substeps {
            n: implicit,
            implicit: true,
        }
    } else {
        Substeps {
            n: explicit,
            implicit: false,
        }
    })
}

/// Advances (x, v) over one sample interval of `h` s in `steps` substeps of semi-implicit
/// Euler, the mass held: the dampings explicit, v += M⁻¹·f(x, v)·dt, or implicit
/// (linearised in the rates), (M + dt·(C + C_c))·Δv = dt·f(x, v); then x += v·dt with the
/// new v. With `prev` (the previous sample's system, [`Interpolation::Linear`](super::Interpolation::Linear)) the linear
/// forces at each substep's midpoint are blended from its and this sample's; the contacts'
/// loads and the dampings' implicit part stay this sample's. None if a matrix is singular.
#[allow(clippy::too_many_arguments)]
pub(super) fn advance(
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
    steps: Substeps,
    h: f64,
    x: &mut DVector<f64>,
    v: &mut DVector<f64>,
    prev: Option<&System>,
) -> Option<()> {
    let nj = sys.mass.nrows() - NP;
    let dt = h / steps.n as f64;
    let prev = prev.filter(|p| p.mass.shape() == sys.mass.shape());
    if !steps.implicit {
        let minv = sys.mass.clone().try_inverse()?;
        // The mass couples the drives and the play, and the cross's coordinates among
        // themselves: M⁻¹ in two diagonal blocks (exact zeros between them).
        let mblock = two_blocks(&minv);
        // In place (~2 000 substeps per 2 ms sample interval on the unit tests' joint): rhs = g − K·x − C·v + loads.
        let mut rhs = DVector::zeros(x.len());
        for j in 0..steps.n {
            let lc = contact_load(ks, &x.as_slice()[nj..], &v.as_slice()[nj..], play, contact);
            forces_into(&mut rhs, sys, prev, (j as f64 + 0.5) / steps.n as f64, x, v, &lc);
            gemv_two_blocks(v.as_mut_slice(), dt, minv.as_slice(), mblock, rhs.as_slice(), 1.0);
            step_positions(x.as_mut_slice(), dt, v.as_slice());
        }
        return Some(());
    }
    let base = &sys.mass + &sys.damping * dt;
    let base_inv = base.clone().try_inverse()?;
    let bblock = two_blocks(&base_inv);
    // Built at the first substep in contact (an interval without contact never needs it).
    let mut schur: Option<PlaySchur> = None;
    // The contacts' damping, reused across the substeps.
    let mut damp = Damping::zero();
    // In place, as above: dt·(g − K·x − C·v + loads), then Δv.
    let (mut rhs, mut dv) = (DVector::zeros(x.len()), DVector::zeros(x.len()));
    for j in 0..steps.n {
        let lc = contact_load_and_damping(ks, x.as_slice(), v.as_slice(), play, contact, &mut damp);
        let cc = &damp.matrix;
        forces_into(&mut rhs, sys, prev, (j as f64 + 0.5) / steps.n as f64, x, v, &lc);
        rhs.as_mut_slice().iter_mut().for_each(|r| *r *= dt);
        if !damp.added || cc.iter().flatten().all(|&c| c == 0.0) {
            gemv_two_blocks(
                dv.as_mut_slice(),
                1.0,
                base_inv.as_slice(),
                bblock,
                rhs.as_slice(),
                0.0,
            );
        } else {
            PlaySchur::of(&mut schur, &base, nj)?.solve(cc, dt, &rhs, &mut dv)?;
        }
        for (vi, &d) in v.as_mut_slice().iter_mut().zip(dv.as_slice()) {
            *vi += d;
        }
        step_positions(x.as_mut_slice(), dt, v.as_slice());
    }
    Some(())
}
