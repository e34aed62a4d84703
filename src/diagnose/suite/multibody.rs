//! The proof suite: MR2120 recordings simulated from multibody truths
//! ([`crate::mechanisms::mr2120::truth`]) that the diagnosis never evaluates in that form —
//! rotors on torsional springs (the nominal model's quasi-static wind-up is not how they
//! move), friction laws outside the library (Stribeck with its own scales and exponent,
//! friction that drifts, cogging), bearings with clearance and Hertz contact in chosen
//! universal joints, payload bodies, a tilted base, sensor offsets, scales and delays — each
//! diagnosed blind from the multibody nominal model ([`super::super::mr2120`]).
//!
//! No generator code path is shared with the candidate library: the library's forms (tanh
//! friction, the quasi-static play of `contact::play`, sensitivities of the ideal model) are
//! never used to make these recordings.
//!
//! Every case's recordings follow the same platform paths ([`super::lumped::excitation`] of
//! the suite seed: shaken and gentle, reaching towards the direct singularity), so the
//! nominal truth's noise-free signals, against which each hidden effect's concealment is
//! measured, are simulated once per path.

use super::super::mr2120::mr2120_model;
use super::super::Diagnosis;
use super::{
    diagnose_and_score, motion, BelowNoise, CaseKind, CaseResult, CaseSpec, Concealment, SuiteError,
    SuiteOptions, Truth,
};
use crate::contact::BearingDesign;
use crate::mechanisms::mr2120::clearance::LUBRICATED_DAMPING;
use crate::mechanisms::mr2120::lumped::{tilted_gravity, NOMINAL_COMPLIANCE};
use crate::mechanisms::mr2120::record::{RecordOptions, Recorded};
use crate::mechanisms::mr2120::truth::{
    simulate_run, ArmFriction, GearMesh, PayloadBody, PayloadMount, StribeckFriction, TruthRun, TruthSpec,
};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// The cases `lash diagnose --suite --reduced` runs (names matched as `--only` matches them:
/// "payload" also runs tilt-under-payload and sprung-payload; nineteen cases in all): the
/// null case, the pair, the three out-of-library cases and fourteen of the seventeen
/// concealed ones. Left out: the three whose bearings have clearance (clearance-F, axial-D,
/// clearance-under-length), whose play candidates, each a run of the reduced play model per
/// contact damping and size tried, take ~13 CPU minutes a case (axial-D's three 4 s fit
/// recordings do not carry its axial play's signature either); hertz-F's bearings have no
/// clearance and its case runs in seconds.
pub const REDUCED_CASES: [&str; 17] = [
    "null",
    "payload",
    "stribeck",
    "compliance",
    "cogging",
    "drifting",
    "pair",
    "torque-delay",
    "tracker-delay",
    "backlash",
    "forearm-length",
    "encoder-offset",
    "rotor-inertia",
    "coulomb-under-viscous",
    "scale-under-coulomb",
    "tracker-offset",
    "hertz-F",
];

/// A change to the nominal truth.
pub type Change = fn(&mut TruthSpec);

/// One case of the multibody suite.
#[derive(Debug, Clone)]
pub struct Case {
    /// Short name.
    pub name: String,
    /// How the effect is concealed.
    pub concealment: String,
    /// Kind.
    pub kind: CaseKind,
    /// The hidden effect (applied to the nominal truth).
    pub hidden: Change,
    /// A larger effect it hides under, if any.
    pub larger: Option<Change>,
    /// What the diagnosis should find.
    pub truth: Vec<Truth>,
    /// The rival of a pair case.
    pub rival: Option<String>,
    /// Record the drive torques.
    pub torques: bool,
}

fn t(candidate: &str, value: f64, hidden: bool) -> Truth {
    Truth::new(candidate, value, hidden)
}

/// Stribeck friction of level `coulomb` (N·m), breakaway `stiction`, Stribeck velocity 0.02
/// rad/s, exponent 1.4, regularised over 0.004 rad/s, viscous `viscous` (N·m·s/rad).
fn stribeck(coulomb: f64, stiction: f64, viscous: f64) -> ArmFriction {
    ArmFriction::Stribeck(StribeckFriction {
        coulomb,
        stiction,
        stribeck_velocity: 0.02,
        exponent: 1.4,
        regularisation: 0.004,
        viscous,
    })
}

/// A bearing with Hertz contact in a joint, damped as lubricated steel joints are
/// ([`LUBRICATED_DAMPING`], the benchmark's). Its contact compliance is part of the hidden
/// physics too: every bearing case also names the joint compliance of its leg, or the
/// joint's own contact compliance (not sized, [`Truth::named`]). With the near-elastic contact of the paper's studies
/// (`clearance::DEFAULT_DAMPING`, α = 1 s/m) the contacts rattle at every load reversal and
/// the diagnosis leaves it unexplained (full design, 2026-11-26: hertz-F 1.38× the torque noise
/// held out against 1.11× here, axial-D 2.17× against 1.87×).
fn bearing(radial: f64, axial: f64) -> Option<BearingDesign> {
    Some(BearingDesign::mr2120(radial, axial, LUBRICATED_DAMPING))
}

fn payload(mass: f64, mount: PayloadMount) -> PayloadBody {
    let a = 0.04;
    PayloadBody {
        mass,
        offset: nalgebra::Vector3::new(0.0, 0.0, 0.02),
        inertia: nalgebra::Vector3::repeat(mass * a * a / 6.0),
        mount,
    }
}

/// The suite's cases (values in SI units).
pub fn cases() -> Vec<Case> {
    use CaseKind::*;
    let mk =
        |name: &str, concealment: &str, kind, hidden: Change, larger: Option<Change>, truth: Vec<Truth>| {
            Case {
                name: name.into(),
                concealment: concealment.into(),
                kind,
                hidden,
                larger,
                truth,
                rival: None,
                torques: true,
            }
        };
    let mut out = vec![
        mk(
            "payload",
            "a 6 g body 2 cm above the platform centre",
            Concealed,
            |s| s.payload_body = Some(payload(0.006, PayloadMount::Rigid)),
            None,
            vec![t("error in payload on the platform", 0.006, true)],
        ),
        mk(
            "forearm-length",
            "forearm B 4 µm long",
            Concealed,
            |s| s.links.forearm_length[1] += 4e-6,
            None,
            vec![t("error in forearm B length", 4e-6, true)],
        ),
        mk(
            "encoder-offset",
            "drive C encoder 10 µrad off",
            Concealed,
            |s| s.sensors.encoder_offset[2] = 1e-5,
            None,
            vec![t("joint-position sensor offset in drive C", 1e-5, true)],
        ),
        mk(
            "compliance",
            "drive A transmission 2 % softer (a spring, rotor on the motor side)",
            Concealed,
            |s| s.drives[0].stiffness = 1.0 / (NOMINAL_COMPLIANCE + 2e-6),
            None,
            vec![t("error in drive A compliance", 2e-6, true)],
        ),
        mk(
            "rotor-inertia",
            "drive C rotor 5e-4 kg m² heavier",
            Concealed,
            |s| s.drives[2].rotor_inertia += 5e-4,
            None,
            vec![t("reflected rotor inertia in drive C", 5e-4, true)],
        ),
        mk(
            "stribeck",
            "Stribeck friction in drive B (0.012 N m, breakaway 0.02 N m, exponent 1.4: not a library law)",
            Concealed,
            |s| s.drives[1].friction.push(stribeck(0.012, 0.02, 0.0)),
            None,
            vec![t(
                "Coulomb friction in drive B|Stribeck friction*in drive B|direction-asymmetric friction in drive B",
                0.012,
                true,
            )],
        ),
        mk(
            "clearance-F",
            "6 µm radial clearance in the trunnion bearings of joint F (elbow of leg C), Hertz contact",
            Concealed,
            |s| s.joints[2] = bearing(6e-6, 0.0),
            None,
            vec![
                t("radial clearance in joint F", 6e-6, true),
                Truth::named("error in joint compliance along leg C|contact compliance of joint F"),
            ],
        ),
        mk(
            "axial-D",
            "4 µm axial play in the trunnion bearings of joint D (elbow of leg A)",
            Concealed,
            |s| s.joints[0] = bearing(0.0, 4e-6),
            None,
            vec![
                t("axial play in joint D", 4e-6, true),
                Truth::named("error in joint compliance along leg A|contact compliance of joint D"),
            ],
        ),
        mk(
            "coulomb-under-viscous",
            "0.01 N m Coulomb friction in drive A (half the torque noise) under 0.5 N m s/rad viscous friction",
            Concealed,
            |s| s.drives[0].friction.push(stribeck(0.01, 0.01, 0.0)),
            Some(|s| s.drives[0].friction.push(stribeck(0.0, 0.0, 0.5))),
            vec![
                t("viscous friction in drive A", 0.5, false),
                t("Coulomb friction in drive A", 0.01, true),
            ],
        ),
        mk(
            "tilt-under-payload",
            "base tilted 3 mrad about x under a 0.5 kg payload body",
            Concealed,
            // (0.2 mrad, the lumped suite's tilt, moves no channel by more than 0.1 noise
            // floors here: not concealed but invisible.)
            |s| s.links.gravity = tilted_gravity(3e-3, 0.0),
            Some(|s| s.payload_body = Some(payload(0.5, PayloadMount::Rigid))),
            vec![
                t("error in payload on the platform", 0.5, false),
                t("error in base tilt about x", 3e-3, true),
            ],
        ),
        mk(
            "scale-under-coulomb",
            "drive B torque sensor 0.1 % off under 0.3 N m Coulomb friction",
            Concealed,
            |s| s.sensors.torque_scale[1] = 1e-3,
            Some(|s| s.drives[1].friction.push(stribeck(0.3, 0.3, 0.0))),
            vec![
                t("Coulomb friction in drive B", 0.3, false),
                t("torque-sensor scale error in drive B", 1e-3, true),
            ],
        ),
        mk(
            "clearance-under-length",
            "6 µm radial clearance in joint P (platform, leg A) under a 30 µm forearm A length error",
            Concealed,
            |s| s.joints[3] = bearing(6e-6, 0.0),
            Some(|s| s.links.forearm_length[0] += 3e-5),
            vec![
                t("error in forearm A length", 3e-5, false),
                t("radial clearance in joint P", 6e-6, true),
                Truth::named("error in joint compliance along leg A|contact compliance of joint P"),
            ],
        ),
        mk(
            "tracker-offset",
            "tracker z reads 3 µm high (below its 5 µm noise at every sample)",
            Concealed,
            |s| s.sensors.tracker_offset[2] = 3e-6,
            None,
            vec![t("platform z sensor offset", 3e-6, true)],
        ),
        mk("null", "nothing hidden", Null, |_| {}, None, vec![]),
        mk(
            "cogging",
            "out of library: cogging torque ripple 0.06 N m, 36 periods per revolution, in drive A",
            OutOfLibrary,
            |s| {
                s.drives[0].friction.push(ArmFriction::Cogging {
                    amplitude: 0.06,
                    periods: 36.0,
                    phase: 0.3,
                })
            },
            None,
            vec![],
        ),
        mk(
            "drifting",
            "out of library: Coulomb friction in drive C growing from 0.02 N m by 0.05 N m/s over the record",
            OutOfLibrary,
            |s| {
                s.drives[2].friction.push(ArmFriction::Drifting {
                    initial: 0.02,
                    growth: 0.05,
                    regularisation: 0.004,
                })
            },
            None,
            vec![],
        ),
        mk(
            "sprung-payload",
            "out of library: a 0.3 kg payload on a 12 Hz spring mount",
            OutOfLibrary,
            |s| {
                s.payload_body = Some(payload(
                    0.3,
                    PayloadMount::Spring {
                        frequency: 12.0,
                        damping_ratio: 0.05,
                    },
                ))
            },
            None,
            vec![],
        ),
    ];
    let mut pair = mk(
        "pair",
        "tracker only: 0.3 N m Stribeck friction in drive B winds up its transmission, which moves the platform like play in leg B",
        Pair,
        |s| s.drives[1].friction.push(stribeck(0.3, 0.3, 0.0)),
        None,
        vec![t(
            "Coulomb friction in drive B|Stribeck friction*in drive B|direction-asymmetric friction in drive B",
            0.3,
            true,
        )],
    );
    pair.rival = Some("radial clearance in joint E".into());
    pair.torques = false;
    out.push(pair);
    // Appended, so the cases before keep their noise seeds (seeded by position).
    out.push(mk(
            "hertz-F",
            "contact compliance of joint F (elbow of leg C): its trunnion bearings without clearance, Hertz ball contacts",
            Concealed,
            |s| s.joints[2] = bearing(0.0, 0.0),
            None,
            // A Hertz contact stiffens with its load: no single linear compliance is the
            // true one, so the case scores the name only. The name is a prefix: the leg's
            // joint compliance, isotropic or of its axial contacts, both count, and so does
            // the joint's own contact compliance (a play below its balls' compression,
            // `UnresolvedPlay`).
            vec![Truth::named("error in joint compliance along leg C|contact compliance of joint F")],
        ));
    // The truth shifts the torque channels exactly (the simulation's output at t − d); the
    // library's candidate is the first-order term −d·dτ/dt per drive.
    out.push(mk(
        "torque-delay",
        "the three torque channels read 0.1 ms late (one acquisition chain)",
        Concealed,
        |s| s.sensors.torque_delay = 1e-4,
        None,
        ["A", "B", "C"]
            .map(|d| t(&format!("torque-sensor delay in drive {d}"), 1e-4, true))
            .to_vec(),
    ));
    out.push(mk(
        "tracker-delay",
        "the tracker reads 10 µs late",
        Concealed,
        |s| s.sensors.tracker_delay = 1e-5,
        None,
        ["x", "y", "z"]
            .map(|a| t(&format!("platform {a} sensor delay"), 1e-5, true))
            .to_vec(),
    ));
    // The truth's backlash is a gear mesh: the transmission's spring and damper turn an
    // output gear (a body), whose teeth meet the arm's across ±b by Flores et al.'s impact
    // law on the flank (K·δ^1.5, hysteresis damping). The library's candidates are a smooth
    // lag b·tanh(τ/τ_b) of the arm behind its encoder and, in the second pass, a dead zone in
    // the transmission's own linear spring, damped only in contact: neither shares this form
    // (the transmission's dead zone, `DriveTruth::backlash`, would).
    out.push(mk(
        "backlash",
        "drive B gear mesh with 10 µrad backlash (half its play), Hertzian flanks",
        Concealed,
        |s| s.drives[1].gear = Some(GearMesh::example(1e-5)),
        None,
        vec![t("drive backlash in drive B", 1e-5, true)],
    ));
    out
}

/// Noise-free nominal-truth runs, per (suite seed, recording, duration, rate).
type RunKey = (u64, usize, u64, u64);

fn nominal_runs() -> &'static Mutex<HashMap<RunKey, TruthRun>> {
    static RUNS: OnceLock<Mutex<HashMap<RunKey, TruthRun>>> = OnceLock::new();
    RUNS.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Largest contribution of a hidden effect, per sample, in noise units over the channels the
/// diagnosis compares with its model, as (torques, tracker) — torques 0 when not recorded:
/// `with` − `without` as the sensors read them (offsets, scales and delays included),
/// noise-free. An encoder offset changes no compared channel (it moves the model's input, so
/// it shows only through the model): its case measures 0.
fn contribution(with: &Recorded, without: &Recorded, opts: &RecordOptions, torques: bool) -> Vec<(f64, f64)> {
    (0..with.t.len())
        .map(|k| {
            let (mut tau, mut pose) = (0.0f64, 0.0f64);
            for i in 0..3 {
                if torques {
                    tau = tau.max((with.tau[i][k] - without.tau[i][k]).abs() / opts.noise.torque);
                }
                pose = pose.max((with.pose[i][k] - without.pose[i][k]).abs() / opts.noise.tracker);
            }
            (tau, pose)
        })
        .collect()
}

/// Runs one case; `progress` receives its stages and fraction done (the truths' simulations
/// up to [`TRUTH_SHARE`](super::TRUTH_SHARE), then the diagnosis's stages).
pub fn run_case(
    case: &Case,
    opts: &SuiteOptions,
    case_index: usize,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<(CaseResult, Diagnosis), SuiteError> {
    let model = mr2120_model(
        &crate::mechanisms::mr2120::Geometry::default(),
        &crate::mechanisms::mr2120::MassProperties::default(),
    )
    .map_err(|e| SuiteError::Model(Box::new(e)))?;
    let ropts = RecordOptions {
        torques: case.torques,
        tracker: true,
        ..opts.record
    };
    let err = |source| SuiteError::Truth {
        case: case.name.clone(),
        source: Box::new(source),
    };
    let mut hidden_spec = TruthSpec::nominal();
    (case.hidden)(&mut hidden_spec);
    let mut full = hidden_spec.clone();
    if let Some(l) = case.larger {
        l(&mut full);
    }
    let noise_seed = opts.seed.wrapping_add(case_index as u64 * 7919);
    let (mut fit, mut held) = (vec![], vec![]);
    let (mut below, mut total, mut peak) = (0usize, 0usize, 0.0f64);
    let (mut below_tau, mut below_pose) = (0usize, 0usize);
    let n_rec = opts.fit_recordings + opts.holdout_recordings;
    for r in 0..n_rec {
        progress(
            "truth simulation",
            super::TRUTH_SHARE * r as f64 / n_rec.max(1) as f64,
        );
        let path = super::lumped::excitation(opts.seed, r);
        let key = (
            opts.seed,
            r,
            opts.record.duration.to_bits(),
            opts.record.rate.to_bits(),
        );
        let cached = nominal_runs().lock().ok().and_then(|m| m.get(&key).cloned());
        let nominal = match cached {
            Some(n) => n,
            None => {
                let n = simulate_run(&TruthSpec::nominal(), &path, &ropts).map_err(err)?;
                if let Ok(mut m) = nominal_runs().lock() {
                    m.insert(key, n.clone());
                }
                n
            }
        };
        let run = simulate_run(&full, &path, &ropts).map_err(err)?;
        let hidden_run = if case.larger.is_some() {
            simulate_run(&hidden_spec, &path, &ropts).map_err(err)?
        } else {
            run.clone()
        };
        let sensed_hidden = hidden_run.sensed(&hidden_spec, &path, &ropts, None);
        let sensed_nominal = nominal.sensed(&TruthSpec::nominal(), &path, &ropts, None);
        for (tau, pose) in contribution(&sensed_hidden, &sensed_nominal, &ropts, case.torques) {
            let c = tau.max(pose);
            peak = peak.max(c);
            below += usize::from(c < 1.0);
            below_tau += usize::from(tau < 1.0);
            below_pose += usize::from(pose < 1.0);
            total += 1;
        }
        let rec: Recorded = run.sensed(&full, &path, &ropts, Some(noise_seed.wrapping_add(r as u64)));
        super::keep(opts, &case.name, r, &rec)?;
        let d = motion(
            &rec,
            format!("{}-{}", case.name, r + 1),
            opts.derivative_window,
            case.torques,
        );
        if r < opts.fit_recordings {
            fit.push(d);
        } else {
            held.push(d);
        }
    }
    let concealment = Concealment {
        below_noise_fraction: below as f64 / total.max(1) as f64,
        peak_snr: peak,
        below_noise_by_channel: Some(BelowNoise {
            torques: case.torques.then(|| below_tau as f64 / total.max(1) as f64),
            tracker: below_pose as f64 / total.max(1) as f64,
        }),
    };
    let spec = CaseSpec {
        name: &case.name,
        kind: case.kind,
        concealment: &case.concealment,
        truth: &case.truth,
        rival: case.rival.as_deref(),
    };
    diagnose_and_score(&model, &fit, &held, &spec, concealment, opts, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recorded(tau: f64, pose: f64) -> Recorded {
        let v = |x: f64| [vec![x, 0.0], vec![0.0, 0.0], vec![0.0, 0.0]];
        Recorded {
            t: vec![0.0, 0.002],
            q: v(0.0),
            qd: v(0.0),
            tau: v(tau),
            pose: v(pose),
            contribution: Default::default(),
            min_direct_measure: 1.0,
            torque_reversals: [0; 3],
            tension_reversals: [0; 3],
            velocity_reversals: [0; 3],
        }
    }

    /// Each group of channels is measured in its own noise; torques only when recorded.
    #[test]
    fn a_hidden_effect_is_measured_per_group_of_channels() {
        let opts = RecordOptions::default();
        let (nt, np) = (opts.noise.torque, opts.noise.tracker);
        let with = recorded(3.0 * nt, 0.5 * np);
        let without = recorded(0.0, 0.0);
        let c = contribution(&with, &without, &opts, true);
        assert!(
            (c[0].0 - 3.0).abs() < 1e-12 && (c[0].1 - 0.5).abs() < 1e-12,
            "{c:?}"
        );
        assert_eq!(c[1], (0.0, 0.0));
        let c = contribution(&with, &without, &opts, false);
        assert_eq!(c[0].0, 0.0);
    }
}
