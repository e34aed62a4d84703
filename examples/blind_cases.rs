//! Blind cases: hidden effects, sizes and places that no case of `lash diagnose --suite`
//! uses, simulated with the public multibody truth generator
//! ([`lash::mechanisms::mr2120::truth`]) and diagnosed and scored exactly as the suite does
//! its own ([`lash::diagnose::suite::multibody::run_case`]). A template for anyone who wants
//! to test the diagnosis on physics of their own choosing: add a [`Case`] below.
//!
//! ```sh
//! cargo run --release --example blind_cases                       # every case, full design, seed 2026
//! cargo run --release --example blind_cases -- --seed 31 --reduced arm-B viscous-C
//! ```
//!
//! The full design (four 5 s recordings fitted, two held out) takes 2–5 min per case without
//! bearings and 15–25 min with one (2 cores); `--reduced` (three 4 s recordings, one held
//! out) about half. Cases run two at a time.

use lash::contact::BearingDesign;
use lash::diagnose::suite::multibody::{run_case, Case};
use lash::diagnose::suite::{CaseKind, CaseResult, SuiteOptions, Truth};
use lash::mechanisms::mr2120::clearance::LUBRICATED_DAMPING;
use lash::mechanisms::mr2120::lumped::NOMINAL_COMPLIANCE;
use lash::mechanisms::mr2120::truth::{ArmFriction, PayloadBody, PayloadMount, StribeckFriction};
use nalgebra::Vector3;

/// Viscous friction alone (N·m·s/rad), as a Stribeck law with no Coulomb part.
fn viscous(c: f64) -> ArmFriction {
    ArmFriction::Stribeck(StribeckFriction {
        coulomb: 0.0,
        stiction: 0.0,
        stribeck_velocity: 0.02,
        exponent: 1.4,
        regularisation: 0.004,
        viscous: c,
    })
}

/// The blind cases (values in SI units). None of them is a suite case: other drives,
/// joints, axes, sizes, and a payload off the platform centre.
fn cases() -> Vec<Case> {
    let mk = |name: &str,
              concealment: &str,
              hidden: fn(&mut lash::mechanisms::mr2120::truth::TruthSpec),
              truth: Vec<Truth>| Case {
        name: name.into(),
        concealment: concealment.into(),
        kind: CaseKind::Concealed,
        hidden,
        larger: None,
        truth,
        rival: None,
        torques: true,
    };
    vec![
        mk(
            "arm-B",
            "arm B 6 µm long",
            |s| s.links.arm_length[1] += 6e-6,
            vec![Truth::new("error in arm B length", 6e-6, true)],
        ),
        mk(
            "forearm-C",
            "forearm C 5 µm short",
            |s| s.links.forearm_length[2] -= 5e-6,
            vec![Truth::new("error in forearm C length", -5e-6, true)],
        ),
        mk(
            "encoder-A",
            "drive A encoder 8 µrad off",
            |s| s.sensors.encoder_offset[0] = 8e-6,
            vec![Truth::new("joint-position sensor offset in drive A", 8e-6, true)],
        ),
        mk(
            "torque-offset-C",
            "drive C torque sensor reads 0.012 N m high (below its 0.02 N m noise)",
            |s| s.sensors.torque_offset[2] = 0.012,
            vec![Truth::new("torque-sensor offset in drive C", 0.012, true)],
        ),
        mk(
            "viscous-C",
            "viscous friction 0.03 N m s/rad in drive C",
            |s| s.drives[2].friction.push(viscous(0.03)),
            vec![Truth::new("viscous friction in drive C", 0.03, true)],
        ),
        mk(
            "stiffer-B",
            "drive B transmission 3 % stiffer",
            |s| s.drives[1].stiffness = 1.0 / (NOMINAL_COMPLIANCE - 3e-6),
            vec![Truth::new("error in drive B compliance", -3e-6, true)],
        ),
        mk(
            "rotor-A",
            "drive A rotor 3e-4 kg m² heavier",
            |s| s.drives[0].rotor_inertia += 3e-4,
            vec![Truth::new("reflected rotor inertia in drive A", 3e-4, true)],
        ),
        mk(
            "tracker-y",
            "tracker y reads 3 µm low",
            |s| s.sensors.tracker_offset[1] = -3e-6,
            vec![Truth::new("platform y sensor offset", -3e-6, true)],
        ),
        mk(
            "payload-off-centre",
            "an 8 g body 3 cm off the platform centre (x) and 1 cm above it",
            |s| {
                let (m, a) = (0.008, 0.01);
                s.payload_body = Some(PayloadBody {
                    mass: m,
                    offset: Vector3::new(0.03, 0.0, 0.01),
                    inertia: Vector3::repeat(m * a * a / 6.0),
                    mount: PayloadMount::Rigid,
                })
            },
            vec![Truth::new("error in payload on the platform", 0.008, true)],
        ),
        mk(
            "clearance-E",
            "5 µm radial clearance in the trunnion bearings of joint E (elbow of leg B), Hertz contact",
            |s| s.joints[1] = Some(BearingDesign::mr2120(5e-6, 0.0, LUBRICATED_DAMPING)),
            vec![
                Truth::new("radial clearance in joint E", 5e-6, true),
                Truth::named("error in joint compliance along leg B|contact compliance of joint E"),
            ],
        ),
    ]
}

fn row(r: &CaseResult) -> String {
    let est: Vec<String> = r
        .estimates
        .iter()
        .zip(&r.truth)
        .filter(|(_, t)| t.sized())
        .map(|(e, t)| match e {
            Some((v, _)) => format!("{:.1} %", 100.0 * (v - t.value).abs() / t.value.abs()),
            None => "not found".into(),
        })
        .collect();
    format!(
        "{:<20} {:>5.0}% {:<6} {:<18} {:>7.2} {:>8.0}%  {:<5} {}",
        r.case,
        100.0 * r.below_noise_fraction,
        if r.ranked_first { "yes" } else { "no" },
        est.join(", "),
        r.holdout_noise_ratio,
        100.0 * r.explained_fraction,
        if r.pass { "yes" } else { "NO" },
        r.found_text()
    )
}

fn main() {
    let mut opts = SuiteOptions::default();
    let mut names = vec![];
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--reduced" => {
                let seed = opts.seed;
                opts = SuiteOptions {
                    only: vec![],
                    seed,
                    ..SuiteOptions::reduced()
                };
            }
            "--seed" => match args.next().and_then(|s| s.parse().ok()) {
                Some(s) => opts.seed = s,
                None => {
                    eprintln!("--seed needs an unsigned integer");
                    std::process::exit(2);
                }
            },
            _ => names.push(a),
        }
    }
    let all = cases();
    if let Some(n) = names.iter().find(|n| !all.iter().any(|c| &c.name == *n)) {
        let known: Vec<&str> = all.iter().map(|c| c.name.as_str()).collect();
        eprintln!("no blind case '{n}' (cases: {})", known.join(", "));
        std::process::exit(2);
    }
    let chosen: Vec<(usize, &Case)> = all
        .iter()
        .enumerate()
        .filter(|(_, c)| names.is_empty() || names.contains(&c.name))
        .collect();
    println!(
        "Blind cases on the MR2120 (multibody truths, {} recordings fitted, {} held out, {} s at {} Hz; seed {})\n",
        opts.fit_recordings, opts.holdout_recordings, opts.record.duration, opts.record.rate, opts.seed
    );
    println!(
        "{:<20} {:>6} {:<6} {:<18} {:>7} {:>9}  {:<5} found first",
        "case", "<noise", "ranked", "estimate error", "held/σ", "explained", "pass"
    );
    let mut passed = 0;
    for pair in chosen.chunks(2) {
        let out: Vec<_> = std::thread::scope(|scope| {
            let handles: Vec<_> = pair
                .iter()
                // Case indices past the suite's, so no blind case shares a suite case's noise.
                .map(|&(i, c)| {
                    let opts = &opts;
                    scope.spawn(move || run_case(c, opts, 100 + i, &mut |_, _| {}))
                })
                .collect();
            handles.into_iter().map(|h| h.join()).collect()
        });
        for ((_, c), o) in pair.iter().zip(out) {
            match o {
                Ok(Ok((r, _))) => {
                    passed += usize::from(r.pass);
                    println!("{}", row(&r));
                    println!("    verdict: {}", r.verdict.lines().next().unwrap_or(""));
                }
                Ok(Err(e)) => println!("{:<20} failed: {e}", c.name),
                Err(_) => println!("{:<20} panicked", c.name),
            }
        }
    }
    println!("\npassed {passed}/{}", chosen.len());
}
