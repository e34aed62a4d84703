//! The shipped MR2120 model files (`models/mr2120_ideal.toml`, `models/mr2120_clearance.toml`,
//! both including `models/mr2120_common.toml`) against lash's built-in MR2120
//! (`mechanisms::mr2120`): the same bodies (matched by name) with the same mass properties, the
//! same joints, drivers and contact elements, the same assembled configurations at M1 and at
//! driven points, the same drive torques along the paper's trajectory, the same sensor
//! readings, and for the clearance model the same 63 degrees of freedom and the same settling
//! over 0.05 s. A perturbed file (platform mass + 10 g) fails the torque comparison, so the
//! tolerances discriminate.

use lash::mechanisms::mr2120::accuracy::locked_clearance_model;
use lash::mechanisms::mr2120::clearance::clearance_set;
use lash::mechanisms::mr2120::kinematics::inverse;
use lash::mechanisms::mr2120::paper::{CLEARANCE_MODEL_DOF, TABLE2};
use lash::mechanisms::mr2120::trajectory::{clearance_options, drive_laws};
use lash::mechanisms::mr2120::{ideal_model, Geometry, MassProperties};
use lash::model_file::{simulate, BuildOptions, BuiltModel, ModelFile};
use lash::multibody::{
    Analysis, BodyHandle, Mechanism, MechanismData, MotionLaw, Sample, Simulation, SimulationOptions,
    Snapshot,
};
use nalgebra::Vector3;
use std::sync::Arc;

const IDEAL: &str = "models/mr2120_ideal.toml";
const CLEARANCE: &str = "models/mr2120_clearance.toml";
/// Positions and orientations of the two models must agree to this, m (and rad).
const POSE_TOL: f64 = 1e-12;

fn m1() -> Vector3<f64> {
    Vector3::from(TABLE2[0].m)
}

/// Built-in bodies paired with the file's bodies of the same name (every body of either model
/// has exactly one partner).
fn pair_bodies(builtin: &Mechanism, file: &Mechanism) -> Vec<(String, BodyHandle, BodyHandle)> {
    assert_eq!(builtin.bodies().len(), file.bodies().len(), "body count");
    let mut out = vec![];
    for (hb, b) in builtin.bodies().iter() {
        let found: Vec<BodyHandle> = file
            .bodies()
            .iter()
            .filter(|(_, f)| f.name == b.name)
            .map(|(h, _)| h)
            .collect();
        assert_eq!(found.len(), 1, "file bodies named '{}'", b.name);
        out.push((b.name.clone(), hb, found[0]));
    }
    out
}

/// Masses, inertia tensors (body frames) and build poses body by body; returns the largest
/// pose difference (m or rotation-matrix entry).
fn compare_bodies(builtin: &Mechanism, file: &Mechanism) -> f64 {
    let mut worst: f64 = 0.0;
    for (name, hb, hf) in pair_bodies(builtin, file) {
        let (b, f) = (builtin.body(hb).unwrap(), file.body(hf).unwrap());
        assert!(
            (b.mass - f.mass).abs() <= 1e-15 * b.mass,
            "{name}: mass {} kg (built-in) vs {} kg (file)",
            b.mass,
            f.mass
        );
        let di = (b.inertia - f.inertia).abs().max();
        assert!(
            di <= 1e-15 * b.inertia.abs().max(),
            "{name}: inertia differs by {di:e} kg m^2:\n{}\n{}",
            b.inertia,
            f.inertia
        );
        let rb = lash::multibody::rotation::rotation(&b.orientation);
        let rf = lash::multibody::rotation::rotation(&f.orientation);
        worst = worst
            .max((b.position - f.position).abs().max())
            .max((rb - rf).abs().max());
    }
    worst
}

/// Largest difference of body positions (m) and rotation matrices between two states, over
/// the bodies paired by name.
fn pose_difference<S: Pose>(builtin: &Mechanism, sb: &S, file: &Mechanism, sf: &S) -> f64 {
    pair_bodies(builtin, file)
        .into_iter()
        .map(|(_, hb, hf)| {
            let dp = (sb.position(hb) - sf.position(hf)).abs().max();
            let dr = (sb.rotation(hb) - sf.rotation(hf)).abs().max();
            dp.max(dr)
        })
        .fold(0.0, f64::max)
}

/// Body poses of a snapshot or a simulation sample.
trait Pose {
    fn position(&self, h: BodyHandle) -> Vector3<f64>;
    fn rotation(&self, h: BodyHandle) -> nalgebra::Matrix3<f64>;
}
impl Pose for Snapshot {
    fn position(&self, h: BodyHandle) -> Vector3<f64> {
        self.body_position(h)
    }
    fn rotation(&self, h: BodyHandle) -> nalgebra::Matrix3<f64> {
        self.body_rotation(h)
    }
}
impl Pose for Sample {
    fn position(&self, h: BodyHandle) -> Vector3<f64> {
        self.body_position(h)
    }
    fn rotation(&self, h: BodyHandle) -> nalgebra::Matrix3<f64> {
        self.body_rotation(h)
    }
}

fn assemble(m: &Mechanism) -> (Snapshot, MechanismData) {
    let an = Analysis::new(m).expect("analysis");
    let mut data = MechanismData::new(m);
    let s = an.initial_state(m, &mut data, 0.0).expect("assembles at t = 0");
    (s, data)
}

/// Joint names and kinds in order, driver names with their references, force names in order.
fn structure(m: &Mechanism) -> (Vec<String>, Vec<(String, f64)>, Vec<String>) {
    (
        m.joints()
            .map(|(_, j)| format!("{} {:?}", j.name, j.kind))
            .collect(),
        m.drivers().map(|(_, d)| (d.name.clone(), d.reference)).collect(),
        m.forces().map(|(_, f)| f.name().to_string()).collect(),
    )
}

fn assert_same_structure(builtin: &Mechanism, file: &Mechanism) {
    let (jb, db, fb) = structure(builtin);
    let (jf, df, ff) = structure(file);
    assert_eq!(jb, jf, "joints (name, kind) in order");
    assert_eq!(fb, ff, "force elements in order");
    assert_eq!(db.len(), df.len(), "drivers");
    for ((nb, rb), (nf, rf)) in db.iter().zip(&df) {
        assert_eq!(nb, nf);
        assert!((rb - rf).abs() <= 1e-15, "driver {nb} reference {rb} vs {rf} rad");
    }
    assert_eq!(builtin.degrees_of_freedom(), file.degrees_of_freedom());
    assert_eq!(builtin.constraint_count(), file.constraint_count());
    assert_eq!(builtin.gravity(), file.gravity());
}

/// The ideal file built with its drives left to the caller, driven by `laws` (rad) with the
/// file's own build coordinates as references.
fn file_driven(file: &ModelFile, values: &[f64], laws: [MotionLaw; 3]) -> BuiltModel {
    let opts = BuildOptions {
        measured_joints: vec!["A".into(), "B".into(), "C".into()],
        ..Default::default()
    };
    let mut built = file
        .build_with(values, &opts)
        .expect("builds without its drivers");
    assert_eq!(built.mechanism.drivers().count(), 0);
    for (k, law) in laws.into_iter().enumerate() {
        let joint = built.joint(["A", "B", "C"][k]).expect("drive joint").clone();
        built
            .mechanism
            .drive(
                &format!("q{}", k + 1),
                joint.handle.unwrap(),
                law,
                joint.coordinate0,
            )
            .unwrap();
    }
    built
}

#[test]
fn the_ideal_file_is_the_built_in_ideal_model_at_m1() {
    let (g, mp) = (Geometry::default(), MassProperties::default());
    let q = inverse(&g, m1()).unwrap();
    let builtin = ideal_model(&g, &mp, m1(), Some(q.map(MotionLaw::Constant))).unwrap();
    let file = ModelFile::load(IDEAL).expect("loads");
    let built = file.build().expect("builds");
    let (bm, fm) = (&builtin.mechanism, &built.mechanism);

    assert_eq!(fm.bodies().len(), 7);
    assert_eq!(fm.joints().count(), 9);
    assert_eq!(fm.degrees_of_freedom(), 3);
    assert_same_structure(bm, fm);
    // The file's drivers hold M1 with the built-in's drive angles.
    for (k, (_, d)) in fm.drivers().enumerate() {
        let v = d.law.value(0.0);
        assert!(
            (v - q[k]).abs() <= 1e-15,
            "q{} = {v} rad, built-in {} rad",
            k + 1,
            q[k]
        );
    }
    let build_pose = compare_bodies(bm, fm);
    assert!(build_pose <= POSE_TOL, "build poses differ by {build_pose:e}");
    // The initial guesses (the whole state layout) agree.
    let ((qb, wb), (qf, wf)) = (bm.initial_guess(), fm.initial_guess());
    let dq = qb.iter().zip(&qf).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(dq <= POSE_TOL && wb == wf, "initial guesses differ by {dq:e}");

    let ((sb, db), (sf, _)) = (assemble(bm), assemble(fm));
    let d = pose_difference(bm, &sb, fm, &sf);
    assert!(d <= POSE_TOL, "assembled poses differ by {d:e}");
    assert!((sf.body_position(built.body("platform").unwrap()) - m1()).norm() < 1e-10);

    // The file's sensors at t = 0 read the built-in's drive angles, static drive torques and
    // platform centre.
    let (_, record) = simulate(built, 1e-3, 1e-3, SimulationOptions::default(), |_| {}).unwrap();
    let col = |name: &str| record.columns.iter().position(|(c, _)| c == name).unwrap();
    let row = &record.rows[0];
    for (k, (h, _)) in bm.drivers().enumerate() {
        let tau = db.driver_effort(h).unwrap();
        let read = row[col(&format!("tau{}", k + 1))];
        assert!(
            (read - tau).abs() <= 1e-9 * tau.abs().max(1.0),
            "tau{}: file {read} N m, built-in {tau} N m",
            k + 1
        );
        assert!(tau.abs() > 1.0, "gravity loads the drives ({tau} N m)");
        assert!((row[col(&format!("q{}", k + 1))] - q[k]).abs() < 1e-12);
    }
    let m = Vector3::new(row[col("M_x")], row[col("M_y")], row[col("M_z")]);
    assert!((m - m1()).norm() < 1e-10, "M = {m:?} m");
}

#[test]
fn the_ideal_file_assembles_like_the_built_in_model_at_driven_points() {
    let (g, mp) = (Geometry::default(), MassProperties::default());
    let file = ModelFile::load(IDEAL).unwrap();
    let values: Vec<f64> = file.parameters.iter().map(|p| p.nominal).collect();
    let targets = [
        Vector3::from(TABLE2[1].m),
        Vector3::from(TABLE2[2].m),
        Vector3::new(0.06, -0.04, 0.6),
        Vector3::new(-0.1, 0.08, 0.42),
    ];
    for target in targets {
        let qt = inverse(&g, target).unwrap();
        let builtin = ideal_model(&g, &mp, m1(), Some(qt.map(MotionLaw::Constant))).unwrap();
        let built = file_driven(&file, &values, qt.map(MotionLaw::Constant));
        let (bm, fm) = (&builtin.mechanism, &built.mechanism);
        assert_same_structure(bm, fm);
        let ((sb, _), (sf, _)) = (assemble(bm), assemble(fm));
        let d = pose_difference(bm, &sb, fm, &sf);
        assert!(d <= POSE_TOL, "at {target:?} m the poses differ by {d:e}");
        // The drives moved the platform to the target (M3 lies near a singular position,
        // where an assembly residual of 1e-12 leaves the platform ~1e-7 m off).
        let p = sf.body_position(built.body("platform").unwrap());
        assert!(
            (p - target).norm() < 1e-6,
            "platform at {p:?}, target {target:?} m"
        );
    }
}

/// Simulates `m` from t = 0 and samples it at `times`.
fn simulate_at(m: Mechanism, times: &[f64], opts: SimulationOptions) -> (Arc<Mechanism>, Vec<Sample>) {
    let mech = Arc::new(m);
    let traj = Simulation::new(mech.clone(), 0.0, opts)
        .unwrap()
        .run(times, |_| {})
        .unwrap();
    (mech, traj.samples)
}

/// Largest drive-torque difference (N m) and platform-position difference (m) between the
/// built-in ideal model and the file's, both driven along the paper's trajectory for 0.3 s.
fn trajectory_difference(platform_mass: f64) -> (f64, f64) {
    let (g, mp) = (Geometry::default(), MassProperties::default());
    let builtin = ideal_model(&g, &mp, m1(), Some(drive_laws(&g))).unwrap();
    let file = ModelFile::load(IDEAL).unwrap();
    assert_eq!(file.parameters[0].name, "platform_mass");
    let built = file_driven(&file, &[platform_mass], drive_laws(&g));
    let times: Vec<f64> = (1..=6).map(|k| k as f64 * 0.05).collect();
    let opts = SimulationOptions::with_tolerances(1e-8, 1e-10);
    let run = |m: Mechanism| simulate_at(m, &times, opts.clone());
    let hb = builtin.platform;
    let hf = built.body("platform").unwrap();
    let (bm, sb) = run(builtin.mechanism);
    let (fm, sf) = run(built.mechanism);
    assert_eq!(sb.len(), times.len());
    let (mut dtau, mut dpos): (f64, f64) = (0.0, 0.0);
    for (b, f) in sb.iter().zip(&sf) {
        for ((h1, _), (h2, _)) in bm.drivers().zip(fm.drivers()) {
            let (t1, t2) = (
                b.driver_effort(&bm, h1).unwrap(),
                f.driver_effort(&fm, h2).unwrap(),
            );
            dtau = dtau.max((t1 - t2).abs());
        }
        dpos = dpos
            .max((b.body_position(hb) - f.body_position(hf)).norm())
            .max(pose_difference(&bm, b, &fm, f));
    }
    // The platform moved along the path (z from 0.5 m towards M2).
    assert!(sb.last().unwrap().body_position(hb).z > 0.505);
    (dtau, dpos)
}

#[test]
fn the_ideal_file_needs_the_built_in_drive_torques_along_the_trajectory() {
    let (dtau, dpos) = trajectory_difference(1.5);
    eprintln!("trajectory: torques differ by {dtau:e} N m, poses by {dpos:e} (m, rad)");
    assert!(dtau <= 1e-8, "drive torques differ by {dtau:e} N m");
    assert!(dpos <= 1e-10, "poses differ by {dpos:e}");
    // 10 g more on the platform: the comparison sees it (about 0.03 N m).
    let (dtau, _) = trajectory_difference(1.51);
    eprintln!("trajectory, platform 10 g heavier in the file: torques differ by {dtau:e} N m");
    assert!(
        dtau > 1e-3,
        "a 10 g heavier platform changed the torques by only {dtau:e} N m"
    );
}

#[test]
fn the_clearance_file_is_the_built_in_63_dof_clearance_model() {
    let (g, mp) = (Geometry::default(), MassProperties::default());
    let set = clearance_set("L1").unwrap();
    let builtin = locked_clearance_model(&g, &mp, &TABLE2[0], &set).unwrap();
    let file = ModelFile::load(CLEARANCE).expect("loads");
    // Without --clearance the same file is the ideal model.
    let ideal = file.check().expect("checks ideal");
    assert_eq!((ideal.dof, ideal.joints.len(), ideal.bodies.len()), (3, 9, 7));
    let report = file
        .check_with(&BuildOptions {
            clearance: true,
            ..Default::default()
        })
        .expect("checks with clearance");
    assert_eq!(report.dof, CLEARANCE_MODEL_DOF as isize);
    assert_eq!(report.dof_driven, 60);
    assert_eq!(report.bodies.len(), 13, "7 links and 6 crosses");
    assert!(report
        .bodies
        .iter()
        .any(|b| b.name == "cross R" && b.mass_kg == 0.05));
    assert_eq!(report.forces.len(), 24, "4 ball contacts in each of 6 joints");
    assert!(report.forces.iter().all(|f| f.kind == "contact"));
    for j in report.joints.iter().filter(|j| j.kind == "universal") {
        assert_eq!(j.clearance_m, Some([set.radial, set.axial]), "joint {}", j.name);
    }
    let built = file
        .build_with(
            &file.parameters.iter().map(|p| p.nominal).collect::<Vec<_>>(),
            &BuildOptions {
                clearance: true,
                ..Default::default()
            },
        )
        .unwrap();
    let (bm, fm) = (&builtin.mechanism, &built.mechanism);
    assert_eq!(fm.bodies().len(), 13);
    assert_eq!(fm.degrees_of_freedom(), CLEARANCE_MODEL_DOF as isize);
    assert_eq!(fm.forces().count(), 24);
    assert_same_structure(bm, fm);
    // Crosses included: masses, inertias and build poses by name.
    let build_pose = compare_bodies(bm, fm);
    assert!(build_pose <= POSE_TOL, "build poses differ by {build_pose:e}");

    // Settling from the build configuration: the platform sags into the clearances (gravity
    // pulls it through 12 bearings' play) the same way in both models.
    let times: Vec<f64> = (1..=5).map(|k| k as f64 * 0.01).collect();
    let run = |m: Mechanism| simulate_at(m, &times, clearance_options());
    let hb = builtin.platform;
    let hf = built.body("platform").unwrap();
    let started = std::time::Instant::now();
    let (bm, sb) = run(builtin.mechanism);
    let (fm, sf) = run(built.mechanism);
    let wall = started.elapsed().as_secs_f64();
    assert_eq!((sb.len(), sf.len()), (times.len(), times.len()));
    let (bm, fm) = (&*bm, &*fm);
    let mut worst: f64 = 0.0;
    for (b, f) in sb.iter().zip(&sf) {
        worst = worst.max(pose_difference(bm, b, fm, f));
    }
    let sag = (sb.last().unwrap().body_position(hb) - m1()).norm();
    let pf = sf.last().unwrap().body_position(hf);
    eprintln!(
        "clearance: platform sag {sag:e} m, largest pose difference {worst:e} (m, rad), file M {pf:?} m, both runs {wall:.1} s"
    );
    assert!(sag > 1e-6, "the platform settled into its clearances ({sag:e} m)");
    // The settling rattle amplifies differences: written with axis-angle orientations (equal
    // to 1e-16) the two models drifted 1e-4 rad apart within 0.04 s. The file's orientations
    // are given as the built-in's own axis vectors, so the models are equal to the last bit.
    assert!(
        worst <= POSE_TOL,
        "the two clearance models differ by {worst:e} after settling"
    );

    // The file's clearance parameters reach the bearings: set L2 (axial 1 um) settles
    // differently.
    let values: Vec<f64> = file
        .parameters
        .iter()
        .map(|p| if p.name == "h_LW" { 1e-6 } else { p.nominal })
        .collect();
    let l2 = file
        .build_with(
            &values,
            &BuildOptions {
                clearance: true,
                ..Default::default()
            },
        )
        .unwrap();
    let hl = l2.body("platform").unwrap();
    let (_, sl) = run(l2.mechanism);
    let d = (sl.last().unwrap().body_position(hl) - pf).norm();
    assert!(
        d > 1e-6,
        "axial clearance 1 um instead of 20 um moved the platform by only {d:e} m"
    );
}
