//! A reduced dynamic model of a universal joint's play along a recording: what the
//! quasi-static play candidates leave out — the joint tilting and shifting across its
//! clearance when its load changes, and the ringing of the drives that excites.
//!
//! The unknowns are small deviations from the nominal motion: the drives' wind-up δw (one per
//! drive, rad or m) and the joint's four play coordinates e = (shift of side j from side i
//! along base x, y, z in m; tilt of side j about n = z_i × z_j in rad). The mechanics are
//! linearised about the nominal model at each sample ([`PlayDynamics`],
//! [`TransmissionDynamics`]); the contact of the play stays nonlinear:
//!
//! ```text
//! M_d·δẅ − T_ë·ë + D·δẇ + (K + S)·δw − T_e·e = 0            the drives
//! −A_ẅ·δẅ + A_ë·ë − A_w·δw + A_e·e = Λ_c(e, ė) − Λ           the joint
//! ```
//!
//! with T_e, T_ë the joint-side torques' derivatives by the play coordinates and their
//! accelerations, A_e, A_ë, A_w, A_ẅ the joint's generalised reaction's by the same and by the
//! arms' positions and accelerations (an arm lags its encoder by δw), Λ the reaction the
//! nominal (ideal) joint carries and Λ_c what the joint's contacts give: the reaction the
//! motion asks of the joint must be what its contacts give — nothing inside the play.
//!
//! **Contacts**: the four trunnion balls, two per pair a ball spacing s apart, each in a bore
//! with radial clearance h, on a linear penalty law ([`BallContact`]: stiffness on the
//! penetration, damping on its rate, never pulling; the same damping along the bore's wall
//! while in contact). The cross is rigid between its pairs:
//! each pair takes half the shift along n and half the tilt, all the shift across its own axis
//! within the plane of the other, so the balls of the side-i pair (axis z_i) sit at
//! (e·z_j ± (s/4)·φ, ½·e·n) in their bores' plane, those of the side-j pair at
//! (e·z_i ∓ (s/4)·φ, ½·e·n). Axial play is not modelled. This is not the contact law of the
//! suite's truths (Hertz balls with Hunt–Crossley damping, a cross with its own mass, the
//! whole 63-DOF model): it is a model of the same geometry, reduced.
//!
//! **Outputs**: the torque sensors read K·δw + D·δẇ more.
//!
//! **Integration**: semi-implicit (symplectic) Euler over substeps of each sample interval,
//! the matrices held at the interval's end, the substep a tenth of the period of the fastest
//! mode with every ball in contact. A recording's first sample, and the first after a
//! gap longer than [`transmission::MAX_GAP`](super::transmission::MAX_GAP) or a sample without
//! the model's data, starts quasi-statically: the joint against the wall its nominal reaction
//! pushes it to ([`UniversalPlay::shift`](crate::contact::play::UniversalPlay::shift)), the
//! transmissions wound up by the torques that shift asks for.
//!
//! Measured on the suite's truth (README, "What the play leaves in the torques"): with 6 µm of
//! radial clearance in joint F, on the shaken recording of the suite's design, it takes the
//! play's effect on the drive torques from 11.2 to 3.9 torque-noise units RMS over the record
//! (drive A): the torque swing after the load peak near the direct singularity and the rattle
//! while the joint is nearly unloaded, in amplitude and, for a few periods, in phase. Where the
//! truth's effect is about one noise unit it adds about as much of its own.

use super::model::PlayDynamics;
use super::transmission::{TransmissionDynamics, MAX_GAP};
use nalgebra::{DMatrix, DVector, Vector3};

/// The trunnion balls' contact in the reduced play model: a linear penalty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallContact {
    /// Stiffness on a ball's penetration of its bore's clearance, N/m.
    pub stiffness: f64,
    /// Damping on the penetration's rate, and on the ball's sliding along the wall while in
    /// contact, N·s/m (the contact never pulls).
    pub damping: f64,
}

/// The contact the README's measurements used: 1e8 N/m, about the secant stiffness F/δ of the
/// MR2120 bearing design's Hertz contact (a 4 mm steel ball in a bore 6 µm larger:
/// K = 1.12e11 N/m^1.5 from [`crate::contact::stiffness::ball_in_bore`], so F/δ = 0.85e8 N/m
/// at 50 N, 1.08e8 at 100 N, 1.55e8 at 300 N), and 2e3 N·s/m, a tenth of critical for a
/// kilogram on it, across and along the wall. Chosen, not fitted. Measured in the example
/// (joint F, 6 µm, torque-noise units RMS over the record, drive A): damping only across the
/// wall leaves the joint rocking along its walls in quiet stretches (gentle recording 6: the
/// effect 0.49, left 1.18; along the wall too: 0.68); 2e4 N·s/m quiets that (0.33) but damps
/// the rattle (shaken recording 5: 3.9 → 5.7 left); 1e9 N/m did worse in the loaded window
/// and 1e7 N/m diverged (both before the reactions followed the arms).
pub const BALL_CONTACT: BallContact = BallContact {
    stiffness: 1e8,
    damping: 2e3,
};

/// One sample of a recording for the reduced play model: its time and the nominal model's
/// linearisation there.
#[derive(Debug, Clone, Copy)]
pub struct PlaySample<'a> {
    /// Time, s.
    pub t: f64,
    /// The joint's coupling to the drives.
    pub play: &'a PlayDynamics,
    /// The drives' transmissions.
    pub transmission: &'a TransmissionDynamics,
}

/// The reduced play model's state at one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayResponse {
    /// Change of each drive's sensed torque, K·δw + D·δẇ (N·m, or N).
    pub torque: Vec<f64>,
    /// The play coordinates e: shift along base x, y, z (m), tilt about n (rad).
    pub offset: [f64; 4],
}

/// The four balls' displacement maps: per ball, the two rows of J_b (ball displacement in
/// its bore's plane per play coordinate).
fn ball_maps(p: &PlayDynamics) -> Option<[[[f64; 4]; 2]; 4]> {
    let u1 = p.z_i.try_normalize(1e-12)?;
    let u2 = (p.z_j - u1 * p.z_j.dot(&u1)).try_normalize(1e-12)?;
    let u3 = u1.cross(&u2);
    let q = p.play.ball_spacing / 4.0;
    let row = |u: &Vector3<f64>, f: f64, tilt: f64| [f * u.x, f * u.y, f * u.z, tilt];
    Some([
        [row(&u2, 1.0, q), row(&u3, 0.5, 0.0)],
        [row(&u2, 1.0, -q), row(&u3, 0.5, 0.0)],
        [row(&u1, 1.0, -q), row(&u3, 0.5, 0.0)],
        [row(&u1, 1.0, q), row(&u3, 0.5, 0.0)],
    ])
}

/// Λ_c: the generalised load of the balls' contacts at (e, ė) for radial clearance `h`.
fn contact_load(maps: &[[[f64; 4]; 2]; 4], e: &[f64], ed: &[f64], h: f64, c: &BallContact) -> [f64; 4] {
    let mut out = [0.0; 4];
    for jb in maps {
        let at = |x: &[f64], r: usize| (0..4).map(|k| jb[r][k] * x[k]).sum::<f64>();
        let (b, bd) = ([at(e, 0), at(e, 1)], [at(ed, 0), at(ed, 1)]);
        let r = b[0].hypot(b[1]);
        if r > h {
            // Normal: the penalty and its damping, never pulling; tangential (along the
            // bore's wall): the same damping, while in contact.
            let (nb, tb) = ([b[0] / r, b[1] / r], [-b[1] / r, b[0] / r]);
            let f = (-c.stiffness * (r - h) - c.damping * (bd[0] * nb[0] + bd[1] * nb[1])).min(0.0);
            let ft = -c.damping * (bd[0] * tb[0] + bd[1] * tb[1]);
            for (k, o) in out.iter_mut().enumerate() {
                *o += f * (nb[0] * jb[0][k] + nb[1] * jb[1][k]) + ft * (tb[0] * jb[0][k] + tb[1] * jb[1][k]);
            }
        }
    }
    out
}

/// The system's matrices at one sample: mass, stiffness (drives then play coordinates) and
/// the drives' dampings.
fn matrices(s: &PlaySample) -> Option<(DMatrix<f64>, DMatrix<f64>, DVector<f64>)> {
    let (p, td) = (s.play, s.transmission);
    let nj = td.compliance.len();
    let n = nj + 4;
    if td.mass.shape() != (nj, nj)
        || p.reaction_by_drive.len() != nj
        || p.reaction_by_drive_acceleration.len() != nj
        || p.torque_by_offset
            .iter()
            .chain(&p.torque_by_offset_acceleration)
            .any(|v| v.len() != nj)
    {
        return None;
    }
    let kr = td.response_stiffness();
    let mut mm = DMatrix::zeros(n, n);
    let mut kk = DMatrix::zeros(n, n);
    for a in 0..nj {
        for b in 0..nj {
            mm[(a, b)] = td.mass[(a, b)];
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
    let mut damping = DVector::zeros(n);
    for a in 0..nj {
        damping[a] = td.damping[a];
    }
    mm.iter()
        .chain(kk.iter())
        .chain(damping.iter())
        .all(|v| v.is_finite())
        .then_some((mm, kk, damping))
}

/// Substeps for one sample interval of `h` s: a tenth of the period of the fastest mode
/// with every ball in contact (the largest eigenvalue of M⁻¹·(K + K_c), K_c = k·Σ J_bᵀJ_b),
/// and the contacts' damping resolved (dt·λ_max(M⁻¹·C_c) ≤ 0.5); at least 1, at most
/// 100 000. None if the mass matrix is not positive definite.
fn substeps(
    mass: &DMatrix<f64>,
    stiffness: &DMatrix<f64>,
    maps: &[[[f64; 4]; 2]; 4],
    contact: &BallContact,
    h: f64,
) -> Option<usize> {
    let n = mass.nrows();
    let nj = n - 4;
    let mut jtj = DMatrix::zeros(n, n);
    for jb in maps {
        for row in jb {
            for r in 0..4 {
                for c in 0..4 {
                    jtj[(nj + r, nj + c)] += row[r] * row[c];
                }
            }
        }
    }
    let sym = |m: &DMatrix<f64>| (m + m.transpose()) * 0.5;
    let l = sym(mass).cholesky()?.l();
    let linv = l.try_inverse()?;
    let largest = |m: DMatrix<f64>| {
        let a = sym(&(&linv * m * linv.transpose()));
        a.symmetric_eigenvalues().iter().fold(0.0f64, |x, &v| x.max(v))
    };
    let omega = largest(sym(stiffness) + &jtj * contact.stiffness).sqrt();
    let gamma = largest(&jtj * contact.damping);
    let dt = (0.2 * std::f64::consts::PI / omega.max(1e-300)).min(0.5 / gamma.max(1e-300));
    Some(((h / dt).ceil() as usize).clamp(1, 100_000))
}

/// The static state at sample `s`: KK·x = [0; Λ_c(e, 0) − Λ] by Newton's method (minimum-norm
/// steps) from the joint against the wall its nominal reaction pushes it to, the
/// transmissions wound up by the torques that asks for.
fn static_start(
    s: &PlaySample,
    kk: &DMatrix<f64>,
    maps: &[[[f64; 4]; 2]; 4],
    h: f64,
    contact: &BallContact,
) -> Option<DVector<f64>> {
    let p = s.play;
    let nj = s.transmission.compliance.len();
    let n = p.z_i.cross(&p.z_j).try_normalize(1e-12)?;
    let force = Vector3::new(p.reaction[0], p.reaction[1], p.reaction[2]);
    let shift = p.play.shift(&p.z_i, &p.z_j, &force, &(n * p.reaction[3]), 1e-6);
    // A tenth beyond the wall, so that the loaded balls start in contact (Newton's method
    // sees no stiffness inside the play).
    let start = 1.1 * h;
    let mut x = DVector::zeros(nj + 4);
    x[nj] = start * shift.radial_translation.x;
    x[nj + 1] = start * shift.radial_translation.y;
    x[nj + 2] = start * shift.radial_translation.z;
    x[nj + 3] = start * shift.radial_tilt;
    let zero = [0.0; 4];
    let residual = |x: &DVector<f64>| {
        let lc = contact_load(maps, &x.as_slice()[nj..], &zero, h, contact);
        let mut r = kk * x;
        for k in 0..4 {
            r[nj + k] -= lc[k] - p.reaction[k];
        }
        r
    };
    for _ in 0..30 {
        let r = residual(&x);
        let mut jac = kk.clone();
        for c in 0..4 {
            let step = 1e-9 * h.max(1e-9) / if c == 3 { p.play.ball_spacing } else { 1.0 };
            let mut xp = x.clone();
            xp[nj + c] += step;
            let dr = (residual(&xp) - &r) / step;
            jac.set_column(nj + c, &dr);
        }
        // Least squares: a joint pressed in one direction floats in the others (a tangential
        // shift of a ball on its wall is free to first order), so the Jacobian may be
        // singular there; the minimum-norm step leaves those coordinates where they are.
        let tol = 1e-12 * jac.amax();
        let dx = jac.svd(true, true).solve(&r, tol).ok()?;
        x -= &dx;
        if dx.rows(nj, 4).amax() < 1e-9 * h.max(1e-12) {
            break;
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The reduced play model along one recording's samples (in time order; None where the
/// nominal model gave no data, which restarts it) for radial clearance `h` (m). None at the
/// samples without data or where a matrix is singular.
pub fn respond(
    samples: &[Option<PlaySample<'_>>],
    h: f64,
    contact: &BallContact,
) -> Vec<Option<PlayResponse>> {
    let mut out = vec![None; samples.len()];
    // (time, x, v) of the last sample reached.
    let mut state: Option<(f64, DVector<f64>, DVector<f64>)> = None;
    for (i, s) in samples.iter().enumerate() {
        let Some(s) = s else {
            state = None;
            continue;
        };
        let (Some((mm, kk, damping)), Some(maps)) = (matrices(s), ball_maps(s.play)) else {
            state = None;
            continue;
        };
        let nj = s.transmission.compliance.len();
        let Some(minv) = mm.clone().try_inverse() else {
            state = None;
            continue;
        };
        let reaction = s.play.reaction;
        let next = match state.take() {
            Some((t0, mut x, mut v)) if s.t > t0 && s.t - t0 <= MAX_GAP => {
                let Some(n_sub) = substeps(&mm, &kk, &maps, contact, s.t - t0) else {
                    continue;
                };
                let dt = (s.t - t0) / n_sub as f64;
                for _ in 0..n_sub {
                    let lc = contact_load(&maps, &x.as_slice()[nj..], &v.as_slice()[nj..], h, contact);
                    let mut rhs = -(&kk * &x) - damping.component_mul(&v);
                    for r in 0..4 {
                        rhs[nj + r] += lc[r] - reaction[r];
                    }
                    v += &minv * rhs * dt;
                    x += &v * dt;
                }
                (x, v)
            }
            _ => match static_start(s, &kk, &maps, h, contact) {
                Some(x) => (x, DVector::zeros(nj + 4)),
                None => continue,
            },
        };
        let (x, v) = next;
        if !x.iter().chain(v.iter()).all(|a| a.is_finite()) {
            continue;
        }
        let k = s.transmission.stiffness();
        out[i] = Some(PlayResponse {
            torque: (0..nj)
                .map(|a| k[a] * x[a] + s.transmission.damping[a] * v[a])
                .collect(),
            offset: [x[nj], x[nj + 1], x[nj + 2], x[nj + 3]],
        });
        state = Some((s.t, x, v));
    }
    out
}

/// Test fixtures: one compliant drive carrying a joint of 1 kg (side j) on axes x and y,
/// n = z, loaded along z, whose shift along z moves the drive's torque.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;
    use crate::contact::play::UniversalPlay;

    /// The joint under `load` N along z, the drive's torque moving by `tau_per_m` N·m per m
    /// of its shift along z; 1 kg on each shift coordinate, 1e-4 kg·m² on the tilt.
    pub(crate) fn hanging_joint(load: f64, tau_per_m: f64) -> PlayDynamics {
        PlayDynamics {
            z_i: Vector3::x(),
            z_j: Vector3::y(),
            play: UniversalPlay { ball_spacing: 0.024 },
            reaction: [0.0, 0.0, load, 0.0],
            torque_by_offset: [vec![0.0], vec![0.0], vec![tau_per_m], vec![0.0]],
            torque_by_offset_acceleration: [vec![0.0], vec![0.0], vec![0.0], vec![0.0]],
            reaction_by_offset: [[0.0; 4]; 4],
            reaction_by_offset_acceleration: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1e-4],
            ],
            reaction_by_drive: vec![[0.0; 4]],
            reaction_by_drive_acceleration: vec![[0.0; 4]],
        }
    }

    /// The drive: 0.01 kg·m² on 1e-4 rad/(N·m), damped by 5 N·m·s/rad.
    pub(crate) fn one_drive() -> TransmissionDynamics {
        TransmissionDynamics {
            mass: DMatrix::from_element(1, 1, 0.01),
            compliance: vec![1e-4],
            damping: vec![5.0],
            windup_rate: vec![0.0],
            load_stiffness: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One drive, a joint whose side j weighs 1 kg and hangs on it: axes x and y, n = z. The
    /// nominal joint holds side j up with 200 N; with play, side j sits 2h lower (each pair
    /// takes half the drop) plus 200 N over the four balls' stiffness along n (4·k·¼ = k),
    /// and the drive's torque follows by T_e. Reversed, the load sends it across the play to
    /// the other wall, without blowing up on the way.
    #[test]
    fn a_hanging_joint_sits_on_its_wall_and_crosses_the_play_when_the_load_reverses() {
        let h = 5e-6;
        let k = BALL_CONTACT.stiffness;
        let tau_per_m = 1000.0;
        let dynamics = |load: f64| fixtures::hanging_joint(load, tau_per_m);
        let transmission = fixtures::one_drive();
        let (up, down) = (dynamics(200.0), dynamics(-200.0));
        let samples: Vec<Option<PlaySample>> = (0..400)
            .map(|i| {
                Some(PlaySample {
                    t: 0.002 * i as f64,
                    play: if i < 200 { &up } else { &down },
                    transmission: &transmission,
                })
            })
            .collect();
        let r = respond(&samples, h, &BALL_CONTACT);
        let sits = -2.0 * h - 200.0 / k;
        let first = r[0].as_ref().unwrap();
        assert!(
            (first.offset[2] - sits).abs() < 1e-3 * sits.abs(),
            "{:?}",
            first.offset
        );
        assert!((first.torque[0] - tau_per_m * sits).abs() < 1e-3 * (tau_per_m * sits).abs());
        let before = r[199].as_ref().unwrap();
        assert!(
            (before.offset[2] - sits).abs() < 1e-3 * sits.abs(),
            "{:?}",
            before.offset
        );
        let last = r[399].as_ref().unwrap();
        assert!(
            (last.offset[2] + sits).abs() < 1e-2 * sits.abs(),
            "{:?}",
            last.offset
        );
        assert!((last.torque[0] + tau_per_m * sits).abs() < 1e-2 * (tau_per_m * sits).abs());
        let widest = r.iter().flatten().map(|x| x.offset[2].abs()).fold(0.0, f64::max);
        assert!(widest < 2.0 * h + 5.0 * 200.0 / k, "{widest}");
    }
}
