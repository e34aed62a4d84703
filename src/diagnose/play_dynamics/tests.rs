//! The reduced play model's unit tests.

use super::dense::{gemv, gemv_two_blocks, lu_solve, two_blocks, PlaySchur};
use super::*;
use crate::diagnose::model::{PlayDynamics, PlayPoint};
use crate::diagnose::transmission::TransmissionDynamics;
use nalgebra::{DMatrix, DVector, SMatrix};

/// The substeps' own products and LU give nalgebra's numbers to the bit (the play
/// model's results, and so every diagnosis's, do not move with them): `gemv` at β = 0, 1
/// and another β, `gemv_two_blocks` on a matrix zero between its two diagonal blocks and
/// `lu_solve` against `LU::solve_mut`, including a zero column and row swaps. Random
/// numbers of mixed magnitudes, a fixed seed (CI reproduces a failure).
#[test]
fn the_substeps_products_and_lu_are_nalgebras_to_the_bit() {
    use proptest::collection::vec;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 200,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    );
    let strategy = (
        1usize..14,
        vec((-1.0f64..1.0, -8i32..8), 14 * 14),
        vec(-1.0f64..1.0, 14),
        -2.0f64..2.0,
        0usize..NP + 1,
    );
    runner
        .run(&strategy, |(n, entries, x, alpha, zero_col)| {
            let value = |k: usize| entries[k].0 * 10f64.powi(entries[k].1);
            let a = DMatrix::from_fn(n, n, |r, c| value(r * 14 + c));
            let xv = DVector::from_column_slice(&x[..n]);
            for beta in [0.0, 1.0, 0.37] {
                let mut want = DVector::from_fn(n, |r, _| x[(r + 3) % 14]);
                let mut got = want.clone();
                want.gemv(alpha, &a, &xv, beta);
                gemv(got.as_mut_slice(), alpha, a.as_slice(), xv.as_slice(), beta);
                let same = want
                    .iter()
                    .zip(got.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits());
                proptest::prop_assert!(same, "gemv, beta {beta}: {want} against {got}");
                // Zero between a leading block and the rest.
                let m = (n / 2).max(1);
                let blocks = DMatrix::from_fn(n, n, |r, c| if (r < m) == (c < m) { a[(r, c)] } else { 0.0 });
                if m < n {
                    proptest::prop_assert_eq!(two_blocks(&blocks), m);
                }
                let mut want = DVector::from_fn(n, |r, _| x[(r + 5) % 14]);
                let mut got = want.clone();
                want.gemv(alpha, &blocks, &xv, beta);
                gemv_two_blocks(
                    got.as_mut_slice(),
                    alpha,
                    blocks.as_slice(),
                    two_blocks(&blocks),
                    xv.as_slice(),
                    beta,
                );
                let same = want
                    .iter()
                    .zip(got.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits());
                proptest::prop_assert!(same, "two blocks, beta {beta}: {want} against {got}");
            }
            // The LU, on the play block's size; a column of zeros where asked.
            let s = SMatrix::<f64, NP, NP>::from_fn(|r, c| {
                if c == zero_col {
                    0.0
                } else {
                    value((r * NP + c) % (14 * 14))
                }
            });
            let mut want = SMatrix::<f64, NP, 1>::from_fn(|r, _| x[r]);
            let ok_want = s.lu().solve_mut(&mut want);
            let mut cols: [[f64; NP]; NP] = std::array::from_fn(|c| std::array::from_fn(|r| s[(r, c)]));
            let mut got: [f64; NP] = std::array::from_fn(|r| x[r]);
            let ok_got = lu_solve(&mut cols, &mut got);
            proptest::prop_assert_eq!(ok_want, ok_got);
            if ok_want {
                let same = want.iter().zip(&got).all(|(p, q)| p.to_bits() == q.to_bits());
                proptest::prop_assert!(same, "lu: {want} against {got:?}");
            }
            Ok(())
        })
        .unwrap();
}

/// The implicit substep's elimination of the drives solves the same system as a dense LU
/// of all the unknowns, with three drives and with none, for a contact damping on a few
/// play coordinates (a symmetric positive definite B, not symmetric coupling blocks).
#[test]
fn the_play_blocks_schur_complement_solves_the_whole_implicit_system() {
    for nj in [3usize, 0] {
        let n = nj + NP;
        let b = DMatrix::from_fn(n, n, |r, c| {
            let off = 0.3 * ((r * 7 + c * 3) as f64).sin();
            if r == c {
                4.0 + r as f64
            } else {
                off
            }
        });
        let mut cc = [[0.0; NP]; NP];
        for (k, u) in [[1.0, 0.5, 0.0, -0.2], [0.0, 1.0, 2.0, 0.3]].iter().enumerate() {
            for r in 0..4 {
                for c in 0..4 {
                    cc[r + 2 * k][c + 2 * k] += 300.0 * u[r] * u[c];
                }
            }
        }
        let dt = 1e-4;
        let rhs = DVector::from_fn(n, |r, _| (r as f64 * 1.3).cos());
        let mut dv = DVector::zeros(n);
        let mut schur = PlaySchur::new(&b, nj).expect("regular drive block");
        schur.solve(&cc, dt, &rhs, &mut dv).expect("regular complement");
        let mut a = b.clone();
        for r in 0..NP {
            for c in 0..NP {
                a[(nj + r, nj + c)] += dt * cc[r][c];
            }
        }
        let dense = a.clone().lu().solve(&rhs).expect("regular");
        let err = (&dv - &dense).amax() / dense.amax();
        assert!(err < 1e-13, "nj = {nj}: relative difference {err:e}");
        // And it is a solution: A·Δv = rhs to round-off.
        assert!(
            (&a * &dv - &rhs).amax() < 1e-12 * rhs.amax() * a.amax(),
            "nj = {nj}"
        );
    }
}

/// `n` samples 2 ms apart, the joint at sample i `play(i)`.
fn every_2_ms<'a>(
    n: usize,
    play: impl Fn(usize) -> &'a PlayDynamics,
    transmission: &'a TransmissionDynamics,
) -> Vec<Option<PlaySample<'a>>> {
    sampled(0.002, n, play, transmission)
}

/// `n` samples `dt` s apart, the joint at sample i `play(i)`.
fn sampled<'a>(
    dt: f64,
    n: usize,
    play: impl Fn(usize) -> &'a PlayDynamics,
    transmission: &'a TransmissionDynamics,
) -> Vec<Option<PlaySample<'a>>> {
    (0..n)
        .map(|i| {
            Some(PlaySample {
                t: dt * i as f64,
                play: play(i),
                transmission,
                about: None,
            })
        })
        .collect()
}

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
    let samples = every_2_ms(400, |i| if i < 200 { &up } else { &down }, &transmission);
    let r = respond(
        &samples,
        &JointPlay::radial(h),
        &BALL_CONTACT,
        Interpolation::Held,
    );
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

/// A load that swings within sample intervals, as near the direct singularity: the
/// hanging joint's 200 N from t₀ = 0.2013 s (between two samples) swung as
/// 200·cos(2π·20 Hz·(t − t₀)), so the joint crosses its play every 25 ms. The reference is
/// the held model sampled every 20 µs (what held and blended both tend to as the sampling
/// refines). Sampled every 2 ms, the blended forces follow it far more closely than the
/// held ones, which lead by up to a sample; held, the error shrinks with the sampling.
#[test]
fn blended_forces_follow_a_swinging_load_as_a_finely_sampled_model_does() {
    let h = 5e-6;
    let start = 0.2013;
    let load = |t: f64| 200.0 * (2.0 * std::f64::consts::PI * 20.0 * (t - start).max(0.0)).cos();
    let transmission = fixtures::one_drive();
    // The joint's shift along z every 2 ms over 0.3 s, sampled every `dt` s.
    let shift = |dt: f64, interpolation: Interpolation| -> Vec<f64> {
        let every = (2e-3 / dt).round() as usize;
        let n = 150 * every;
        let t: Vec<f64> = (0..n).map(|i| dt * i as f64).collect();
        let joints: Vec<PlayDynamics> = t
            .iter()
            .map(|&t| fixtures::hanging_joint(load(t), 1000.0))
            .collect();
        let samples = sampled(dt, n, |i| &joints[i], &transmission);
        let r = respond(&samples, &JointPlay::radial(h), &BALL_CONTACT, interpolation);
        r.iter()
            .step_by(every)
            .map(|x| x.as_ref().unwrap().offset[2])
            .collect()
    };
    // The largest difference from the reference, in units of the wall-to-wall travel
    // (2h either way, and the balls' compression under 200 N on each wall).
    let travel = 4.0 * h + 2.0 * 200.0 / BALL_CONTACT.stiffness;
    let reference = shift(2e-5, Interpolation::Held);
    let apart = |z: &[f64]| {
        z.iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / travel
    };
    let (fine_held, fine_blended) = (
        apart(&shift(2e-4, Interpolation::Held)),
        apart(&shift(2e-4, Interpolation::Linear)),
    );
    let (held, blended) = (
        apart(&shift(2e-3, Interpolation::Held)),
        apart(&shift(2e-3, Interpolation::Linear)),
    );
    // (Measured, in wall-to-wall travels: every 0.2 ms held 0.075, blended 0.0085; every
    // 2 ms held 0.72 — a whole sample early at a crossing — and blended 0.013.)
    // The joint does cross: it sits on the lower wall, then swings to the upper one.
    let (low, high) = reference
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    assert!(low < -1.5 * h && high > 1.5 * h, "{low:e} .. {high:e} m");
    assert!(
        fine_held < 0.5 * held,
        "held every 0.2 ms {fine_held}, every 2 ms {held}"
    );
    assert!(
        blended < 0.05 && blended < 0.05 * held,
        "blended {blended}, held {held}"
    );
    assert!(
        fine_blended < 0.2 * fine_held.max(1e-3),
        "{fine_blended} vs {fine_held}"
    );
}

/// Load-proportional damping (γ·F, Hunt–Crossley's form) takes the ringing out of the
/// landing after the load reverses, where the undamped contact keeps ringing; it changes
/// nothing at rest (the joint sits where it did). A damping 500× critical for the
/// kilogram on the balls stays stable on the stiffness's substeps (the dampings are
/// implicit) and creeps onto the far wall without a bounce.
#[test]
fn load_proportional_damping_settles_the_landing_and_a_stiff_damping_stays_stable() {
    let h = 5e-6;
    let k = BALL_CONTACT.stiffness;
    let transmission = fixtures::one_drive();
    let (up, down) = (
        fixtures::hanging_joint(200.0, 1000.0),
        fixtures::hanging_joint(-200.0, 1000.0),
    );
    let samples = every_2_ms(300, |i| if i < 100 { &up } else { &down }, &transmission);
    let sits = 2.0 * h + 200.0 / k;
    // The ringing about the far wall over the last 100 samples, m RMS.
    let ringing = |d: ContactDamping| {
        let r = respond(
            &samples,
            &JointPlay::radial(h),
            &BALL_CONTACT.with_damping(d),
            Interpolation::Held,
        );
        assert!(
            (r[0].as_ref().unwrap().offset[2] + sits).abs() < 1e-3 * sits,
            "{d}: {:?}",
            r[0].as_ref().unwrap().offset
        );
        let late: Vec<f64> = r[200..]
            .iter()
            .map(|x| x.as_ref().unwrap().offset[2] - sits)
            .collect();
        (late.iter().map(|x| x * x).sum::<f64>() / late.len() as f64).sqrt()
    };
    let undamped = ringing(ContactDamping::constant(0.0));
    let load = ringing(ContactDamping {
        constant: 0.0,
        load: 100.0,
    });
    let stiff = ringing(ContactDamping::constant(1e7));
    // (Measured: 8.4e-6, 1e-20 and 1.1e-7 m: the stiff damping creeps onto the wall,
    // its time constant c/k = 0.1 s.)
    assert!(undamped > 0.5 * h, "the undamped landing rings: {undamped:e} m");
    assert!(load < 1e-3 * undamped, "{load:e} against {undamped:e} m");
    assert!(stiff.is_finite() && stiff < 0.05 * h, "{stiff:e} m");
}

/// Expanded about a point x₁ of its own motion, a model whose mechanics is linear (the
/// fixture's coefficients do not change with the configuration) answers as about the
/// sample: the point's torque change T_e·e₁ and reaction Λ carry exactly what the
/// expansion about the sample does (the constant load g = f(x₁) + K₁·x₁ and its signs).
/// With the drive's load stiffness S at the point, the drive's stiffness is K + S there.
#[test]
fn expanded_about_a_point_of_a_linear_mechanism_the_response_is_the_same() {
    let (h, tau_per_m) = (5e-6, 1000.0);
    let joint = fixtures::hanging_joint(200.0, tau_per_m);
    let transmission = fixtures::one_drive();
    let plain = every_2_ms(300, |_| &joint, &transmission);
    let at = respond(&plain, &JointPlay::radial(h), &BALL_CONTACT, Interpolation::Held);
    let (e1, w1) = (-7e-6, 3e-5);
    let point = PlayPoint {
        windup: vec![w1],
        offset: [0.0, 0.0, e1, 0.0],
        dynamics: joint.clone(),
        torque: vec![tau_per_m * e1],
        load_stiffness: DMatrix::zeros(1, 1),
        mass: transmission.mass.clone(),
        outputs: vec![],
    };
    // The samples expanded about `point`, answered.
    let about = |point: &PlayPoint| {
        let samples: Vec<Option<PlaySample>> = plain
            .iter()
            .map(|s| {
                s.map(|s| PlaySample {
                    about: Some(point),
                    ..s
                })
            })
            .collect();
        respond(
            &samples,
            &JointPlay::radial(h),
            &BALL_CONTACT,
            Interpolation::Held,
        )
    };
    let expanded = about(&point);
    for i in [0, 150, 299] {
        let (a, b) = (at[i].as_ref().unwrap(), expanded[i].as_ref().unwrap());
        assert!(
            (a.offset[2] - b.offset[2]).abs() < 1e-9 * h,
            "{i}: {:?} vs {:?}",
            a.offset,
            b.offset
        );
        assert!(
            (a.torque[0] - b.torque[0]).abs() < 1e-9 * a.torque[0].abs() + 1e-12,
            "{i}: {:?} vs {:?}",
            a.torque,
            b.torque
        );
    }
    // With a load stiffness at the point (and the point at the sample) the drive is
    // stiffer: the same torque over K + S instead of K.
    let stiff = PlayPoint {
        load_stiffness: DMatrix::from_element(1, 1, 1e4),
        windup: vec![0.0],
        offset: [0.0; 4],
        torque: vec![0.0],
        ..point.clone()
    };
    let stiffer = about(&stiff);
    let (a, b) = (at[299].as_ref().unwrap(), stiffer[299].as_ref().unwrap());
    let k = transmission.stiffness()[0];
    let ratio = b.windup[0] / a.windup[0];
    assert!(
        (ratio - k / (k + 1e4)).abs() < 1e-3,
        "{ratio} vs {}",
        k / (k + 1e4)
    );
}

/// Without play the joint hangs on its balls' stiffness alone: 200 N / k below the centre.
#[test]
fn without_play_a_hanging_joint_sits_on_its_balls_compliance() {
    let joint = fixtures::hanging_joint(200.0, 0.0);
    let transmission = fixtures::one_drive();
    let samples = every_2_ms(50, |_| &joint, &transmission);
    let r = respond(
        &samples,
        &JointPlay::default(),
        &BALL_CONTACT,
        Interpolation::Held,
    );
    let sits = -200.0 / BALL_CONTACT.stiffness;
    for at in [&r[0], &r[49]] {
        let at = at.as_ref().expect("a response");
        assert!((at.offset[2] - sits).abs() < 0.02 * sits.abs(), "{:?}", at.offset);
    }
}

/// Axial play: pressed by 60 N along z_i = x, the cross sits against one end of side
/// i's pair (h_a/2 and 60 N on one ball's end) and side j's pair carries the force across
/// its axis (y) on both balls, 30 N each, with no radial clearance: side j sits
/// h_a/2 + 60/k + 30/k away along −x. Reversed, it crosses the axial play to the other end.
#[test]
fn a_joint_pressed_along_a_trunnion_axis_sits_against_the_end_of_its_axial_play() {
    let (h_a, k) = (1e-5, BALL_CONTACT.stiffness);
    let mut push = fixtures::hanging_joint(0.0, 0.0);
    push.reaction = [60.0, 0.0, 0.0, 0.0];
    let mut pull = push.clone();
    pull.reaction = [-60.0, 0.0, 0.0, 0.0];
    let transmission = fixtures::one_drive();
    let samples = every_2_ms(400, |i| if i < 200 { &push } else { &pull }, &transmission);
    let r = respond(
        &samples,
        &JointPlay::axial(h_a),
        &BALL_CONTACT,
        Interpolation::Held,
    );
    let sits = -(0.5 * h_a + 90.0 / k);
    for (at, sign) in [(&r[0], 1.0), (&r[199], 1.0), (&r[399], -1.0)] {
        let at = at.as_ref().unwrap();
        assert!(
            (at.offset[0] - sign * sits).abs() < 0.02 * sits.abs(),
            "{:?}",
            at.offset
        );
        assert!(
            at.offset[1].abs() < 0.02 * sits.abs() && at.offset[2].abs() < 0.02 * sits.abs(),
            "{:?}",
            at.offset
        );
        for ball in &at.radial_forces[2..] {
            assert!((ball - 30.0).abs() < 0.6, "{:?}", at.radial_forces);
        }
    }
}

/// Side j's offset `coordinate` sits at `sits` (within 2 %) at the first and last of 50
/// samples of `joint` with `play` on `contact`.
fn assert_sits(contact: &BallContact, joint: &PlayDynamics, play: &JointPlay, coordinate: usize, sits: f64) {
    let transmission = fixtures::one_drive();
    let samples = every_2_ms(50, |_| joint, &transmission);
    let r = respond(&samples, play, contact, Interpolation::Held);
    for at in [&r[0], &r[49]] {
        let at = at.as_ref().expect("a response");
        assert!(
            (at.offset[coordinate] - sits).abs() < 0.02 * sits.abs(),
            "{:?} vs {sits:e}",
            at.offset
        );
    }
}

/// The linear law per direction: pressed along x by 60 N against the end of a 10 µm
/// axial play, with the end faces five times softer than the walls, side j sits
/// h_a/2 + 60/k_a + 30/k away (the end face's compression, then a wall's); hanging
/// without play on 200 N, 2·100/k lower whatever the end faces' stiffness.
#[test]
fn with_linear_balls_each_direction_has_its_own_stiffness() {
    let (k, k_a, h_a) = (BALL_CONTACT.stiffness, BALL_CONTACT.stiffness / 5.0, 1e-5);
    let contact = BallContact {
        axial_stiffness: k_a,
        ..BALL_CONTACT
    };
    let sits_at = |joint: &PlayDynamics, play: &JointPlay, coordinate: usize, sits: f64| {
        assert_sits(&contact, joint, play, coordinate, sits)
    };
    let mut push = fixtures::hanging_joint(0.0, 0.0);
    push.reaction = [60.0, 0.0, 0.0, 0.0];
    sits_at(
        &push,
        &JointPlay::axial(h_a),
        0,
        -(0.5 * h_a + 60.0 / k_a + 30.0 / k),
    );
    sits_at(
        &fixtures::hanging_joint(200.0, 0.0),
        &JointPlay::default(),
        2,
        -2.0 * 100.0 / k,
    );
}

/// With Hertz's law per direction the same statics hold with δ = (F/K)^(2/3): hanging
/// without play on 200 N, side j sits two balls' compressions under 100 N lower (one
/// ball of each pair in series); pressed along x by 60 N against the end of a 10 µm axial
/// play, it sits h_a/2 + δ_axial(60 N) + δ_radial(30 N) away.
#[test]
fn with_hertz_balls_the_joint_sits_on_each_directions_own_compression() {
    let hertz = HertzBalls {
        radial: 1e10,
        axial: 2e9,
    };
    let contact = BallContact {
        hertz: Some(hertz),
        ..BALL_CONTACT
    };
    let delta = |f: f64, k: f64| (f / k).powf(2.0 / 3.0);
    let sits_at = |joint: &PlayDynamics, play: &JointPlay, coordinate: usize, sits: f64| {
        assert_sits(&contact, joint, play, coordinate, sits)
    };
    let hanging = fixtures::hanging_joint(200.0, 0.0);
    sits_at(
        &hanging,
        &JointPlay::default(),
        2,
        -2.0 * delta(100.0, hertz.radial),
    );
    let h_a = 1e-5;
    let mut push = fixtures::hanging_joint(0.0, 0.0);
    push.reaction = [60.0, 0.0, 0.0, 0.0];
    let sits = -(0.5 * h_a + delta(60.0, hertz.axial) + delta(30.0, hertz.radial));
    sits_at(&push, &JointPlay::axial(h_a), 0, sits);
    // From the MR2120 design: a 4 mm steel ball in a bore 6 µm larger is some ten times
    // stiffer than on a flat end face (1.12e11 against ~1e10 N/m^1.5).
    let design = crate::contact::BearingDesign::mr2120(6e-6, 0.0, crate::contact::Damping::Elastic);
    let k = HertzBalls::from_design(&design).unwrap();
    assert!((k.radial / 1.12e11 - 1.0).abs() < 0.05, "{k:?}");
    assert!(k.radial > 5.0 * k.axial, "{k:?}");
}

/// The stiff substeps ([`Stepping::Stiff`]) against the resolved ones on the hanging
/// joint with the MR2120's Hertz balls (6 µm, 20 N·s/m + 500 s/m × F, the bearing
/// preset's kind of damping), its 200 N swung at 20 Hz along z so that it crosses its
/// play every 25 ms, the forces blended: every sample answered, the joint on the same
/// wall, its shift along z within a small part of the wall-to-wall travel and the drive's
/// torque within a small part of its swing, at 10 and 40 substeps per sample interval.
/// (Before a substep was taken again where a contact's load is far from linear over it,
/// the example `play_model_run`'s joint blew up at 10 and 20 per interval.)
#[test]
fn stiff_substeps_follow_the_resolved_ones_across_the_play() {
    let h = 6e-6;
    let design = crate::contact::BearingDesign::mr2120(h, 0.0, crate::contact::Damping::Elastic);
    let contact = BallContact {
        hertz: Some(HertzBalls::from_design(&design).unwrap()),
        ..BALL_CONTACT.with_damping(ContactDamping::load_proportional(500.0))
    };
    let load = |t: f64| 200.0 * (2.0 * std::f64::consts::PI * 20.0 * t).cos();
    let transmission = fixtures::one_drive();
    let joints: Vec<PlayDynamics> = (0..250)
        .map(|i| fixtures::hanging_joint(load(0.002 * i as f64), 1000.0))
        .collect();
    let samples = every_2_ms(250, |i| &joints[i], &transmission);
    let run = |stepping: Stepping| {
        respond_stepped(
            &samples,
            &JointPlay::radial(h),
            &contact,
            Interpolation::Linear,
            stepping,
        )
    };
    let resolved = run(Stepping::Resolved);
    let swing = |r: &[Option<PlayResponse>], f: &dyn Fn(&PlayResponse) -> f64| {
        let v: Vec<f64> = r.iter().flatten().map(f).collect();
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    let travel = swing(&resolved, &|x| x.offset[2]);
    let torque_swing = swing(&resolved, &|x| x.torque[0]);
    // The joint does cross its play: about 2h either way and the balls' compression.
    assert!(travel > 3.0 * h, "{travel:e} m");
    for per_sample in [10, 40] {
        let stiff = run(Stepping::Stiff { per_sample });
        assert!(
            stiff.iter().all(Option::is_some),
            "{per_sample}: a sample unanswered"
        );
        let apart = |f: &dyn Fn(&PlayResponse) -> f64| {
            stiff
                .iter()
                .zip(&resolved)
                .map(|(a, b)| (f(a.as_ref().unwrap()) - f(b.as_ref().unwrap())).abs())
                .fold(0.0, f64::max)
        };
        let (shift, torque) = (
            apart(&|x| x.offset[2]) / travel,
            apart(&|x| x.torque[0]) / torque_swing,
        );
        // (Measured: at 10 per interval 0.0033 of the travel and 0.022 of the torque's
        // swing, at 40 0.0046 and 0.0027.)
        assert!(
            shift < 0.05 && torque < 0.05,
            "{per_sample}: shift {shift}, torque {torque}"
        );
    }
}

/// Both trunnion pairs carry the joint's load in series, through the cross: pressed by
/// Λ = (0, 60, 80) N (axes x and y, n = z), the side-i pair (bores along x) carries the
/// whole 100 N across its axis, 50 N per ball along −(0.6, 0.8); the side-j pair (bores
/// along y) the 80 N along n, 40 N per ball, and the 60 N along y on one axial end. Side j
/// then sits below side i by both pairs' displacements added: along n by
/// 0.8·(h + 50/k) plus h + 40/k, along y by 0.6·(h + 50/k) plus 60/k. (Statics of the cross, not the model's
/// maps; a cross placed half-way between its sides could not load both pairs so.)
#[test]
fn the_crosss_two_pairs_carry_the_load_in_series_all_four_balls_on_their_walls() {
    let (h, k) = (5e-6, BALL_CONTACT.stiffness);
    let mut joint = fixtures::hanging_joint(80.0, 0.0);
    joint.reaction = [0.0, 60.0, 80.0, 0.0];
    let transmission = fixtures::one_drive();
    let samples = every_2_ms(200, |_| &joint, &transmission);
    let r = respond(
        &samples,
        &JointPlay::radial(h),
        &BALL_CONTACT,
        Interpolation::Held,
    );
    for at in [&r[0], &r[199]] {
        let at = at.as_ref().unwrap();
        for (ball, expected) in at.radial_forces.iter().zip([50.0, 50.0, 40.0, 40.0]) {
            assert!(
                (ball - expected).abs() < 0.02 * expected,
                "{:?}",
                at.radial_forces
            );
        }
        let along_n = -(0.8 * (h + 50.0 / k) + h + 40.0 / k);
        let along_y = -(0.6 * (h + 50.0 / k) + 60.0 / k);
        assert!(
            (at.offset[2] - along_n).abs() < 0.02 * along_n.abs(),
            "{:?}",
            at.offset
        );
        assert!(
            (at.offset[1] - along_y).abs() < 0.02 * along_y.abs(),
            "{:?}",
            at.offset
        );
        assert!(
            at.offset[0].abs() < 0.02 * h && at.offset[3].abs() < 0.02 * h / 0.024,
            "{:?}",
            at.offset
        );
    }
}

/// The cross's own load (its weight and what carries it along with side i) goes to side
/// i's balls only: side j's carry the joint's reaction Λ as before, side i's Λ − m_x·(g −
/// a_i) — here Λ = (0, 60, 80) N on side j and the cross pulled by 20 N along −z, so side
/// i's pair carries |(60, 100)| = 116.6 N, side j's 80 N.
#[test]
fn the_crosss_own_load_rides_on_side_is_balls_only() {
    let mut joint = fixtures::hanging_joint(80.0, 0.0);
    joint.reaction = [0.0, 60.0, 80.0, 0.0];
    joint.cross_load = [0.0, 0.0, -20.0];
    let transmission = fixtures::one_drive();
    let samples = every_2_ms(200, |_| &joint, &transmission);
    let r = respond(
        &samples,
        &JointPlay::radial(5e-6),
        &BALL_CONTACT,
        Interpolation::Held,
    );
    let side_i = 0.5 * (60.0f64.hypot(100.0));
    for at in [&r[0], &r[199]] {
        let at = at.as_ref().unwrap();
        for (ball, expected) in at.radial_forces.iter().zip([side_i, side_i, 40.0, 40.0]) {
            assert!(
                (ball - expected).abs() < 0.02 * expected,
                "{:?}",
                at.radial_forces
            );
        }
    }
}
