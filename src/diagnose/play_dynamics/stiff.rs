//! Stiff substeps: the Rosenbrock method ROS2 with the contacts' stiffness and damping in its
//! matrix, a substep taken again in halves where the balls touching change ([`advance_stiff`]).

use super::balls::{
    contact_load, contact_load_and_damping, touching, BallContact, Contact, Damping, JointPlay,
};
use super::dense::{gemv_block, gemv_two_blocks, largest_by_mass, sym, two_blocks, PlaySchur};
use super::resolved::SUBSTEPS_PER_PERIOD;
use super::system::{forces_into, System};
use super::NP;
use nalgebra::{DMatrix, DVector};

/// The stiff substeps per sample interval that `lash diagnose --play-stiff-substeps` takes
/// when it is given no count ([`Stepping::Stiff`](super::Stepping::Stiff)). Measured with the
/// example `play_dynamics` (joint F, 6 µm, recording 5, Hertz balls, 20 N·s/m + 500 s/m × F,
/// forces blended, re-linearised once; what the model leaves of the truth's play effect on
/// drives A/B/C, RMS 0.6–5 s in torque-noise units, and the time in the model's three runs):
/// resolved 0.36 / 0.30 / 0.59 in 4.82 s; 40 stiff substeps 0.38 / 0.32 / 0.59 in 1.14 s
/// (the window 3.1–5 s 0.19 / 0.24 / 0.31 against 0.15 / 0.20 / 0.27, the rattle 2.77–3.10 s
/// 1.19 / 0.87 / 1.86 against 1.15 / 0.85 / 1.91); 80 stiff substeps 0.36 / 0.30 / 0.58
/// in 2.24 s; 20: 0.45 / 0.39 / 0.68.
pub const STIFF_SUBSTEPS: usize = 40;

/// How far the contacts' load at a stiff substep's second stage may be from its linear
/// prediction (from the first stage's load, stiffness and damping), as a fraction of the
/// larger of the two stages' loads, before the substep is taken again in halves
/// ([`advance_stiff`]). Without it a ball that barely touched at a substep's start (Hertz's
/// stiffness is nearly zero there) and is pressed hard by its end takes its force explicitly
/// — the substeps blew up on the example `play_model_run` at 10 and 20 per sample interval;
/// at 0.1 none did, at 1.0 some still did (2026-12-07, session 77).
pub(super) const NONLINEAR_TOLERANCE: f64 = 0.1;

/// Stiff substeps (ROS2, [`advance_stiff`]) for one sample interval of `h` s: at least
/// `per_sample`, and [`SUBSTEPS_PER_PERIOD`] per period of the fastest mode without the
/// contacts (the largest eigenvalue of M⁻¹·K). None if the mass matrix is not positive definite.
pub(super) fn stiff_substeps(sys: &System, per_sample: usize, h: f64) -> Option<usize> {
    let largest = largest_by_mass(&sys.mass)?;
    let omega = largest(sym(&sys.stiffness)).sqrt();
    let growing = largest(-sym(&sys.damping));
    let dt = (2.0 * std::f64::consts::PI / SUBSTEPS_PER_PERIOD / omega.max(1e-300))
        .min(0.5 / growing.max(1e-300))
        .min(h / per_sample.max(1) as f64);
    Some(((h / dt).ceil() as usize).clamp(1, 100_000))
}

/// Advances (x, v) over one sample interval of `h` s in stiff substeps: the two-stage
/// Rosenbrock method ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999, SIAM J. Sci. Comput.
/// 20(4):1456–1480; γ = 1 + 1/√2: second order, L-stable) on y = (x, v), ẏ = (v, M⁻¹·f(x, v)),
/// its matrix I − γ·dt·J from the contacts' stiffness and damping at each substep's start:
/// (I − γ·dt·J)·k₁ = F(y), (I − γ·dt·J)·k₂ = F(y + dt·k₁) − 2·k₁, y += dt·(3/2·k₁ + 1/2·k₂).
/// Each solve is (M + g·(C + C_c) + g²·(K + K_c))·k_v = f − g·(K + K_c)·u, k_x = u + g·k_v
/// with g = γ·dt and F = (u, M⁻¹·f), so a contact's own modes need not be resolved while the
/// balls that touch stay the same. A substep across which a ball starts or stops touching
/// (at its second stage or its end) is taken again in halves, down to `finest` substeps per
/// interval (the resolved substeps' length, [`substeps`](super::resolved::substeps)), where it is kept; after a kept
/// substep the length doubles again where the grid allows, up to `n` per interval. The linear
/// forces at each stage's time, blended with `prev`'s as [`forces_into`] does.
#[allow(clippy::too_many_arguments)]
pub(super) fn advance_stiff(
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
    n: usize,
    finest: &dyn Fn() -> Option<usize>,
    h: f64,
    x: &mut DVector<f64>,
    v: &mut DVector<f64>,
    prev: Option<&System>,
) -> Option<()> {
    let size = x.len();
    let nj = size - NP;
    let prev = prev.filter(|p| p.mass.shape() == sys.mass.shape());
    let m = sys.active;
    // Per level k (substeps of h / (n·2^k)): the matrix B = M + g·C + g²·K, its inverse, its
    // blocks and its Schur complement on the play, made on first use.
    struct Level {
        g: f64,
        base: DMatrix<f64>,
        base_inv: DMatrix<f64>,
        bblock: usize,
        schur: Option<PlaySchur>,
    }
    let level = |k: usize| -> Option<Level> {
        let dt = h / (n as f64 * (1u64 << k) as f64);
        let g = (1.0 + std::f64::consts::FRAC_1_SQRT_2) * dt;
        let base = &sys.mass + &sys.damping * g + &sys.stiffness * (g * g);
        let base_inv = base.clone().try_inverse()?;
        Some(Level {
            g,
            bblock: two_blocks(&base_inv),
            base,
            base_inv,
            schur: None,
        })
    };
    let mut levels: Vec<Option<Level>> = Vec::new();
    // The deepest level, found at the first substep taken again.
    let mut deepest: Option<usize> = None;
    let mut damp = Damping::weighted(0.0);
    let (mut f, mut rhs) = (DVector::zeros(size), DVector::zeros(size));
    let (mut k1x, mut k1v) = (DVector::zeros(size), DVector::zeros(size));
    let (mut k2v, mut u) = (DVector::zeros(size), DVector::zeros(size));
    let (mut x2, mut v2) = (DVector::zeros(size), DVector::zeros(size));
    let (mut x0, mut v0) = (x.clone(), v.clone());
    // Solves a stage, rhs = f − g·(K + K_c)·u, into kv.
    let solve = |lv: &mut Level,
                 f: &DVector<f64>,
                 u: &DVector<f64>,
                 damp: &Damping,
                 contact_on: bool,
                 rhs: &mut DVector<f64>,
                 kv: &mut DVector<f64>|
     -> Option<()> {
        let g = lv.g;
        rhs.copy_from(f);
        let r = rhs.as_mut_slice();
        gemv_block(
            &mut r[..m],
            -g,
            sys.stiffness.as_slice(),
            size,
            &u.as_slice()[..m],
            1.0,
        );
        if contact_on {
            let uu = &u.as_slice()[nj..];
            for (row, ri) in damp.stiffness.iter().zip(r[nj..].iter_mut()) {
                *ri -= g * row.iter().zip(uu).map(|(a, b)| a * b).sum::<f64>();
            }
            lv.schur.as_mut()?.solve_factored(rhs, kv)
        } else {
            gemv_two_blocks(kv.as_mut_slice(), 1.0, lv.base_inv.as_slice(), lv.bblock, r, 0.0);
            Some(())
        }
    };
    // Position and length in units of the deepest level's substep (as deep as 2^MAX_DEPTH).
    const MAX_DEPTH: usize = 12;
    let unit = |k: usize| 1u64 << (MAX_DEPTH - k);
    let end = n as u64 * unit(0);
    let (mut pos, mut k) = (0u64, 0usize);
    // The balls touching at the substep's start (the last kept substep's end).
    let mut start = touching(ks, &x.as_slice()[nj..], play);
    while pos < end {
        while levels.len() <= k {
            levels.push(None);
        }
        if levels[k].is_none() {
            levels[k] = Some(level(k)?);
        }
        let lv = levels[k].as_mut()?;
        let span = unit(k);
        let dt = h * span as f64 / end as f64;
        let (t1, t2) = (pos as f64 / end as f64, (pos + span) as f64 / end as f64);
        x0.copy_from(x);
        v0.copy_from(v);
        // Stage 1 at (x, v), the matrix from there.
        damp.stiffness_weight = lv.g;
        let lc = contact_load_and_damping(ks, x.as_slice(), v.as_slice(), play, contact, &mut damp);
        let contact_on = damp.added && damp.matrix.iter().flatten().any(|&c| c != 0.0);
        if contact_on {
            // (S as the implicit substeps', with C_c + g·K_c and the weight g.)
            PlaySchur::of(&mut lv.schur, &lv.base, nj)?.factor(&damp.matrix, lv.g);
        }
        forces_into(&mut f, sys, prev, t1, x, v, &lc);
        solve(lv, &f, v, &damp, contact_on, &mut rhs, &mut k1v)?;
        k1x.copy_from(v);
        k1x.axpy(lv.g, &k1v, 1.0);
        // Stage 2 at y + dt·k₁: F there less 2·k₁.
        x2.copy_from(x);
        x2.axpy(dt, &k1x, 1.0);
        v2.copy_from(v);
        v2.axpy(dt, &k1v, 1.0);
        let lc2 = contact_load(ks, &x2.as_slice()[nj..], &v2.as_slice()[nj..], play, contact);
        // The contacts' load at the second stage against its linear prediction from the
        // first, lc₁ − K_c·Δx − C_c·Δv (C_c = the matrix less g·K_c): a contact far from
        // linear over the substep (a ball that barely touched, pressed hard) is resolved.
        let nonlinear = contact_on && {
            let (dx, dvv) = (&k1x.as_slice()[nj..], &k1v.as_slice()[nj..]);
            let mut miss = 0.0f64;
            let mut size = 0.0f64;
            for r in 0..NP {
                let mut pred = lc[r];
                for c in 0..NP {
                    let kc = damp.stiffness[r][c];
                    let cc = damp.matrix[r][c] - lv.g * kc;
                    pred -= dt * (kc * dx[c] + cc * dvv[c]);
                }
                miss = miss.max((lc2[r] - pred).abs());
                size = size.max(lc[r].abs()).max(lc2[r].abs());
            }
            miss > NONLINEAR_TOLERANCE * size
        };
        forces_into(&mut f, sys, prev, t2, &x2, &v2, &lc2);
        f.gemv(-2.0, &sys.mass, &k1v, 1.0);
        u.copy_from(&v2);
        u.axpy(-2.0, &k1x, 1.0);
        solve(lv, &f, &u, &damp, contact_on, &mut rhs, &mut k2v)?;
        // y += dt·(3/2·k₁ + 1/2·k₂), k₂ₓ = u + g·k₂ᵥ.
        x.axpy(1.5 * dt, &k1x, 1.0);
        x.axpy(0.5 * dt, &u, 1.0);
        x.axpy(0.5 * dt * lv.g, &k2v, 1.0);
        v.axpy(1.5 * dt, &k1v, 1.0);
        v.axpy(0.5 * dt, &k2v, 1.0);
        let at_end = touching(ks, &x.as_slice()[nj..], play);
        let changed = nonlinear || touching(ks, &x2.as_slice()[nj..], play) != start || at_end != start;
        if changed {
            let deepest = match deepest {
                Some(d) => d,
                None => {
                    let finest = finest()?.max(n);
                    let d = ((finest as f64 / n as f64).log2().ceil().max(0.0) as usize).min(MAX_DEPTH);
                    *deepest.insert(d)
                }
            };
            if k < deepest {
                // Again, in halves.
                x.copy_from(&x0);
                v.copy_from(&v0);
                k += 1;
                continue;
            }
        }
        start = at_end;
        pos += span;
        // Longer again where the grid allows.
        while k > 0 && pos % unit(k - 1) == 0 && !changed {
            k -= 1;
        }
    }
    Some(())
}
