#!/usr/bin/env python3
"""Exudyn reference run of a lash MR2120 clearance-model export (JSON, schema below).

Builds the mechanism in Exudyn (rigid bodies with Euler-parameter nodes), drives every arm with an
ObjectJointGeneric whose rotation offset is a *symbolic* (C++-evaluated) offsetUserFunction, models every
bearing as an ObjectConnectorRigidBodySpringDamper whose springForceTorqueUserFunction is a *symbolic*
user function (Hertz contact with Hunt-Crossley type damping, radial clearance + one-sided axial stop),
integrates with Exudyn's implicit generalized-alpha solver and records the platform centre every
dt_output seconds with an internally stored SensorBody.

JSON schema (SI units; 3x3 matrices are lists of rows):
  gravity[3], t_end, dt_output, platform_body,
  bodies[]:   name, mass, inertia (3x3 about COM, body frame), position (COM, base), rotation (body->base),
              velocity (base), omega_body (body frame)
  drives[]:   name, body, point, axis, q_initial, arm_dir, w0, arm_length, forearm_length, q0,
              angle_table{t[], q[]}
  z_law:      t[3], z[3]
  bearings[]: name, ball_body, ball_centre (ball frame), socket_body (index or null = ground),
              socket_centre (socket frame), socket_axis (socket frame, unit, outwards),
              radial_clearance, axial_stop, k, n, alpha (radial law), k_axial, n_axial, alpha_axial
              (axial law; default: the radial one); contact force F = k*delta^n*(1 + 1.5*alpha*rate) >= 0

Frame conventions (verified numerically with exudyn 1.13.6 on rotated, moving test bodies):
  * RigidBodySpringDamper user function gets displacement = A_J0^T (p_m1 - p_m0) and
    velocity = A_J0^T (v_m1 - v_m0), A_J0 = global rotation of marker 0's frame (socket body * localHT).
    Marker 0 = socket body at socket centre with local z = socket axis, marker 1 = ball body at ball centre.
  * The returned force f (J0 frame) acts as -A_J0 f on marker 1 (ball) and +A_J0 f on marker 0 (socket),
    so returning +F n gives the ball -n F as required.
  * v_m0 is the velocity of the socket-body point at the socket centre, not at the ball centre:
    the relative velocity misses -omega_socket x (c - s0), |c - s0| ~ clearance; --python-uf --exact-vel adds it
    (prototype: platform changes by < 1e-9 m, far below the clearance-rattle noise of ~1e-6 m).
  * GenericJoint offset index 5 = rotation about the z axis of marker 0's frame (positive right-handed);
    index-3 constraints only (offsetUserFunction_t is not implemented for rotations at velocity level).

Robust settings for k=1e10 Hertz contact (prototype): --rho 0 with modified Newton and h <= ~1 ms, or
--full-newton (h up to ~5 ms).  Too large steps make modified Newton diverge; exudyn 1.13.6 then crashes
with "GeneralMatrixEXUdense::Solve(...): matrix is not factorized!" instead of reducing the step further.

usage: mr2120_exudyn.py MODEL.json [--steps N] [--rho 0] [--out result.json] ...  (see --help)
"""
import argparse
import json
import math
import sys
import time

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("model", help="JSON model written by lash (or make_test_model.py)")
ap.add_argument("--t-end", type=float, default=None, help="override t_end of the model")
ap.add_argument("--steps", type=int, default=None,
                help="number of (fixed) steps up to t_end; default: 100 steps per dt_output")
ap.add_argument("--dt", type=float, default=None, help="step size instead of --steps")
ap.add_argument("--rho", type=float, default=0.0, help="generalized-alpha spectral radius rho_inf")
ap.add_argument("--newmark", action="store_true", help="Newmark (newmarkBeta=0.25, newmarkGamma=0.5, i.e. trapezoidal; --rho ignored) instead of gen.-alpha")
ap.add_argument("--full-newton", action="store_true",
                help="full Newton (Jacobian every iteration) instead of Exudyn's default modified Newton")
ap.add_argument("--jac-per-step", action="store_true",
                help="modified Newton: newton.modifiedNewtonJacUpdatePerStep=True (fresh Jacobian every step)")
ap.add_argument("--num-diff", choices=["default", "connectors", "system"], default="default",
                help="Jacobian: default (Exudyn's connector derivative), numerical differentiation of connectors "
                     "(newton.numericalDifferentiation.forODE2Connectors) or of the whole ODE2 system")
ap.add_argument("--newton-max-it", type=int, default=None, help="newton.maxIterations (default 25)")
ap.add_argument("--rtol", type=float, default=None, help="newton.relativeTolerance (default 1e-8)")
ap.add_argument("--atol", type=float, default=None, help="newton.absoluteTolerance (default 1e-10)")
ap.add_argument("--no-adaptive", action="store_true", help="disable step reduction on Newton failure")
ap.add_argument("--node", choices=["ep", "rotvec", "rxyz"], default="ep",
                help="rigid-body node: Euler parameters (default), rotation vector (Lie group), Tait-Bryan Rxyz")
ap.add_argument("--threads", type=int, default=1, help="parallel.numberOfThreads")
ap.add_argument("--sparse", action="store_true", help="EigenSparse linear solver instead of EXUdense")
ap.add_argument("--fast", action="store_true", help="load exudynCPPfast (no range checks, AVX2)")
ap.add_argument("--python-uf", action="store_true",
                help="use the same force law as *Python* user functions (slow; for checking the symbolic ones)")
ap.add_argument("--exact-vel", action="store_true",
                help="with --python-uf: add the -omega_socket x (c - s0) term to the relative velocity (reads the "
                     "socket body's angular velocity in the Python function; diagnostic for the symbolic version)")
ap.add_argument("--no-sensor", action="store_true", help="no platform sensor (to measure its overhead)")
ap.add_argument("--diag", action="store_true",
                help="also store bearing displacements at output times and print penetrations (adds sensors)")
ap.add_argument("--repeat", type=int, default=1, help="solve this many times; report min/median wall time")
ap.add_argument("--verbose", type=int, default=0, help="timeIntegration.verboseMode")
ap.add_argument("--out", default=None, help="write results (timings, statistics, samples) to this JSON file")
args = ap.parse_args()

if args.fast:
    sys.exudynFast = True
import numpy as np  # noqa: E402
import exudyn as exu  # noqa: E402
from exudyn.itemInterface import (MarkerBodyRigid, ObjectConnectorRigidBodySpringDamper,  # noqa: E402
                                  ObjectJointGeneric, SensorBody, SensorObject)
from exudyn.rigidBodyUtilities import RigidBodyInertia  # noqa: E402
from exudyn.advancedUtilities import CreateSymbolicUserFunction  # noqa: E402

esym = exu.symbolic

with open(args.model) as f:
    M = json.load(f)
t_end = float(args.t_end if args.t_end is not None else M["t_end"])
dt_out = float(M["dt_output"])
if args.dt is not None:
    n_steps = int(round(t_end / args.dt))
elif args.steps is not None:
    n_steps = args.steps
else:
    n_steps = int(round(100 * t_end / dt_out))
# the sensor records at the first step end >= each output time, so make dt_output a multiple of h
n_out = int(round(t_end / dt_out))
if abs(n_out * dt_out - t_end) < 1e-12 * max(1.0, t_end) and n_steps % n_out:
    n_new = n_out * -(-n_steps // n_out)
    print("note: steps %d -> %d so that dt_output is a multiple of the step size" % (n_steps, n_new))
    n_steps = n_new


# ---------------------------------------------------------------- drive law (closed form)
def quintic_np(tau):
    tau = min(max(tau, 0.0), 1.0)
    return tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)


def drive_angle_np(d, zl, t):
    (t0, t1, t2), (z0, z1, z2) = zl["t"], zl["z"]
    z = z0 + (z1 - z0) * quintic_np((t - t0) / (t1 - t0)) + (z2 - z1) * quintic_np((t - t1) / (t2 - t1))
    w = np.array(d["w0"], float) + np.array([0.0, 0.0, z])
    a, b = float(w @ np.array(d["arm_dir"], float)), float(w[2])
    L1, L2 = d["arm_length"], d["forearm_length"]
    k = (w @ w + L1 * L1 - L2 * L2) / (2.0 * L1)
    return math.atan2(b, a) - math.acos(k / math.hypot(a, b)) - d["q0"]


def make_drive_offset_function(d, zl, q_ref):
    """Python function with the ObjectJointGeneric offsetUserFunction interface; called once with symbolic
    arguments by CreateSymbolicUserFunction to record the expression tree (then evaluated in C++)."""
    (t0, t1, t2), (z0, z1, z2) = [float(x) for x in zl["t"]], [float(x) for x in zl["z"]]
    w0 = [float(x) for x in d["w0"]]
    ad = [float(x) for x in d["arm_dir"]]
    L1, L2, q0 = float(d["arm_length"]), float(d["forearm_length"]), float(d["q0"])

    def s(tau):  # rest-to-rest quintic, clamped to [0,1] (so the two legs can simply be added)
        tau = esym.min(esym.max(tau, 0.), 1.)
        return tau * tau * tau * (10. - 15. * tau + 6. * tau * tau)

    def offsetUF(mbs, t, itemNumber, offsetUserFunctionParameters):
        z = z0 + (z1 - z0) * s((t - t0) / (t1 - t0)) + (z2 - z1) * s((t - t1) / (t2 - t1))
        wz = w0[2] + z
        a = w0[0] * ad[0] + w0[1] * ad[1] + wz * ad[2]
        b = wz
        k = (w0[0] * w0[0] + w0[1] * w0[1] + wz * wz + L1 * L1 - L2 * L2) / (2. * L1)
        phi = esym.atan2(b, a) - esym.acos(k / esym.sqrt(a * a + b * b))
        return [0, 0, 0, 0, 0, phi - q0 - q_ref]
    return offsetUF


def make_bearing_function(bg, sock=None, RJ=None):
    """Contact law of one bearing in the RigidBodySpringDamper springForceTorqueUserFunction interface.
    displacement/velocity are in the socket joint frame J0 (local z = socket axis)."""
    cr, stop = float(bg["radial_clearance"]), float(bg["axial_stop"])
    kk, nn, c15 = float(bg["k"]), float(bg["n"]), 1.5 * float(bg["alpha"])
    # the axial (ball-on-face) contact has its own law; older exports carry one law for both
    ka = float(bg.get("k_axial", kk))
    na = float(bg.get("n_axial", nn))
    ca15 = 1.5 * float(bg.get("alpha_axial", bg["alpha"]))
    if args.python_uf:
        def bearingUF(mbs, t, itemNumber, displacement, rotation, velocity, angularVelocity,
                      stiffness, damping, rotJ0, rotJ1, offset):
            dx, dy, dz = displacement
            vx, vy, vz = velocity
            if args.exact_vel and sock is not None:   # velocity of the socket material point at c, not at s0
                cfg = exu.ConfigurationType.Current
                w = mbs.GetObjectOutputBody(sock, OV.AngularVelocity, [0., 0., 0.], cfg)
                Rs = mbs.GetObjectOutputBody(sock, OV.RotationMatrix, [0., 0., 0.], cfg).reshape(3, 3)
                wl = RJ.T @ (Rs.T @ w)                   # socket angular velocity in the J0 frame
                vx, vy, vz = np.array(velocity) - np.cross(wl, np.array(displacement))
            fx = fy = fz = 0.
            rho = math.sqrt(dx * dx + dy * dy)
            dr = rho - cr
            if dr > 0.:
                F = max(kk * dr ** nn * (1. + c15 * (vx * dx + vy * dy) / rho), 0.)
                fx, fy = F * dx / rho, F * dy / rho
            da = dz - stop
            if da > 0.:
                fz = max(ka * da ** na * (1. + ca15 * vz), 0.)
            return [fx, fy, fz, 0., 0., 0.]
        return bearingUF

    def bearingUF(mbs, t, itemNumber, displacement, rotation, velocity, angularVelocity,
                  stiffness, damping, rotJ0, rotJ1, offset):
        dx, dy, dz = displacement[0], displacement[1], displacement[2]
        vx, vy, vz = velocity[0], velocity[1], velocity[2]
        zero = esym.Real(0.)
        rho = esym.sqrt(dx * dx + dy * dy)
        dr = rho - cr
        # only the taken branch of IfThenElse is used: there rho > cr > 0 and dr**n is real
        Fr_rho = esym.IfThenElse(dr > 0.,
                                 esym.max(kk * dr ** nn * (1. + c15 * (vx * dx + vy * dy) / rho), 0.) / rho,
                                 zero)
        da = dz - stop
        Fa = esym.IfThenElse(da > 0., esym.max(ka * da ** na * (1. + ca15 * vz), 0.), zero)
        return [Fr_rho * dx, Fr_rho * dy, Fa, 0, 0, 0]
    return bearingUF


def frame_z(a):
    """rotation matrix whose third column is the unit vector a"""
    a = np.asarray(a, float)
    a = a / np.linalg.norm(a)
    t = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(t, a)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(a, x), a])


# ---------------------------------------------------------------- check the drive law
drive_table_err = 0.0
for d in M["drives"]:
    tab = d.get("angle_table")
    if tab:
        e = max(abs(drive_angle_np(d, M["z_law"], t) - q) for t, q in zip(tab["t"], tab["q"]))
        drive_table_err = max(drive_table_err, e)
    q_init_formula = drive_angle_np(d, M["z_law"], 0.0)
    if abs(q_init_formula - d["q_initial"]) > 1e-9:
        print("WARNING: drive %s: q_initial=%.12g but q(0)=%.12g" % (d["name"], d["q_initial"], q_init_formula))
print("drive law vs angle_table: max |dq| = %.3e rad" % drive_table_err)

# ---------------------------------------------------------------- build the Exudyn model
SC = exu.SystemContainer()
mbs = SC.AddSystem()
oGround = mbs.CreateGround()
g = [float(x) for x in M["gravity"]]

node_type = {"ep": exu.NodeType.RotationEulerParameters, "rotvec": exu.NodeType.RotationRotationVector,
             "rxyz": exu.NodeType.RotationRxyz}[args.node]
bodies, Rb, pb = [], [], []
for b in M["bodies"]:
    R = np.array(b["rotation"], float)
    p = np.array(b["position"], float)
    ob = mbs.CreateRigidBody(name=b["name"], referencePosition=p, referenceRotationMatrix=R,
                             initialVelocity=[float(x) for x in b["velocity"]],
                             initialAngularVelocity=R @ np.array(b["omega_body"], float),  # global
                             inertia=RigidBodyInertia(float(b["mass"]), np.array(b["inertia"], float)),
                             gravity=g, nodeType=node_type)
    bodies.append(ob)
    Rb.append(R)
    pb.append(p)

keep_alive = []      # symbolic user functions must outlive the simulation
drives = []
for d in M["drives"]:
    i = d["body"]
    axis = np.array(d["axis"], float)
    point = np.array(d["point"], float)
    RJ = frame_z(axis)
    m0 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=oGround, localHT=exu.HT(rotation=RJ, translation=point)))
    m1 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=bodies[i],
                                       localHT=exu.HT(rotation=Rb[i].T @ RJ, translation=Rb[i].T @ (point - pb[i]))))
    jo = mbs.AddObject(ObjectJointGeneric(name=d["name"], markerNumbers=[m0, m1], constrainedAxes=[1] * 6))
    fn = make_drive_offset_function(d, M["z_law"], float(d["q_initial"]))
    if args.python_uf:  # plain Python drive function (for cross-checking)
        zl = M["z_law"]
        mbs.SetObjectParameter(jo, "offsetUserFunction",
                               lambda mbs_, t, it, par, d=d, zl=zl: [0, 0, 0, 0, 0,
                                                                    drive_angle_np(d, zl, t) - d["q_initial"]])
    else:
        uf = CreateSymbolicUserFunction(mbs, fn, "offsetUserFunction", jo)
        mbs.SetObjectParameter(jo, "offsetUserFunction", uf)
        keep_alive.append(uf)
    drives.append(jo)

connectors = []
for bg in M["bearings"]:
    ib, js = bg["ball_body"], bg["socket_body"]
    if js is None:
        sock, Rs, ps_ = oGround, np.eye(3), np.zeros(3)
    else:
        sock, Rs, ps_ = bodies[js], Rb[js], pb[js]
    RJ = frame_z(bg["socket_axis"])                       # socket-body frame, z = socket axis
    m0 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=sock,
                                       localHT=exu.HT(rotation=RJ, translation=np.array(bg["socket_centre"], float))))
    # marker 1 orientation is irrelevant (no rotational springs); align it with J0 at t=0
    m1 = mbs.AddMarker(MarkerBodyRigid(bodyNumber=bodies[ib],
                                       localHT=exu.HT(rotation=Rb[ib].T @ Rs @ RJ,
                                                      translation=np.array(bg["ball_centre"], float))))
    co = mbs.AddObject(ObjectConnectorRigidBodySpringDamper(name=bg["name"], markerNumbers=[m0, m1],
                                                            stiffness=np.zeros((6, 6)), damping=np.zeros((6, 6))))
    connectors.append((co, bg))

# one symbolic function per connector (needed for multithreading; also keeps parameters per bearing)
for co, bg in connectors:
    js = bg["socket_body"]
    fn = make_bearing_function(bg, None if js is None else bodies[js], frame_z(bg["socket_axis"]))
    if args.python_uf:
        mbs.SetObjectParameter(co, "springForceTorqueUserFunction", fn)
    else:
        uf = CreateSymbolicUserFunction(mbs, fn, "springForceTorqueUserFunction", co)
        mbs.SetObjectParameter(co, "springForceTorqueUserFunction", uf)
        keep_alive.append(uf)

OV = exu.OutputVariableType
sPlat = None
if not args.no_sensor:
    sPlat = mbs.AddSensor(SensorBody(bodyNumber=bodies[M["platform_body"]], localPosition=[0, 0, 0],
                                     outputVariableType=OV.Position, storeInternal=True, writeToFile=False))
diag_sensors = []
if args.diag:
    for co, bg in connectors:
        diag_sensors.append(mbs.AddSensor(SensorObject(objectNumber=co, outputVariableType=OV.DisplacementLocal,
                                                       storeInternal=True, writeToFile=False)))
    sArm = [mbs.AddSensor(SensorBody(bodyNumber=bodies[d["body"]], localPosition=[0, 0, 0],
                                     outputVariableType=OV.RotationMatrix, storeInternal=True, writeToFile=False))
            for d in M["drives"]]

mbs.Assemble()

# ---------------------------------------------------------------- solver settings
ss = exu.SimulationSettings()
ti = ss.timeIntegration
ti.endTime = t_end
ti.numberOfSteps = n_steps
ti.verboseMode = args.verbose
ti.stepInformation = 0
ga = ti.generalizedAlpha
ga.spectralRadius = args.rho
ga.useNewmark = args.newmark
ga.useIndex2Constraints = False          # rotation offsets of GenericJoint: index 3 only
ga.computeInitialAccelerations = True
ti.adaptiveStep = not args.no_adaptive
ti.newton.useModifiedNewton = not args.full_newton
ti.newton.modifiedNewtonJacUpdatePerStep = args.jac_per_step
if args.num_diff == "connectors":
    ti.newton.numericalDifferentiation.forODE2Connectors = True
elif args.num_diff == "system":
    ti.newton.numericalDifferentiation.forODE2 = True
    ti.newton.numericalDifferentiation.doSystemWideDifferentiation = True
if args.newton_max_it is not None:
    ti.newton.maxIterations = args.newton_max_it
if args.rtol is not None:
    ti.newton.relativeTolerance = args.rtol
if args.atol is not None:
    ti.newton.absoluteTolerance = args.atol
ss.solution.file.write = False
ss.solution.sensors.writePeriod = dt_out
ss.parallel.numberOfThreads = args.threads
if args.sparse:
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
ss.show.computationTime = args.verbose > 0

walls = []
for _rep in range(max(1, args.repeat)):      # every SolveDynamic restarts from the initial values
    t_wall = time.perf_counter()
    mbs.SolveDynamic(ss, storeSolver=True)
    walls.append(time.perf_counter() - t_wall)
t_wall = min(walls)
solver = mbs.sys["dynamicSolver"]
it = solver.it
stats = {
    "solve_wall_s": t_wall,                     # min over --repeat
    "solve_wall_all_s": walls,
    "steps": int(it.currentStepIndex) - 1,      # currentStepIndex is one past the last accepted step
    "steps_requested": n_steps,
    "newton_iterations": int(it.newtonStepsCount),
    "jacobian_evaluations": int(it.newtonJacobiCount),
    "rejected_modified_newton_steps": int(it.rejectedModifiedNewtonSteps),
    "discontinuous_iterations": int(it.discontinuousIterationsCount),
    "rejected_automatic_steps": int(it.rejectedAutomaticStepSizeSteps),
    "h_nominal": t_end / n_steps,
    "end_time_reached": float(it.currentTime),
    "n_ode2": int(mbs.systemData.ODE2Size()),
    "n_ae": int(mbs.systemData.AEsize()),
    "settings": {"rho": args.rho, "newmark": args.newmark, "modified_newton": not args.full_newton,
                 "jac_per_step": args.jac_per_step, "node": args.node, "num_diff": args.num_diff, "threads": args.threads, "fast": args.fast, "symbolic": not args.python_uf,
                 "sparse": args.sparse, "adaptive": not args.no_adaptive},
}
print("exudyn %s  ODE2=%d AE=%d  bearings=%d drives=%d" % (exu.__version__, stats["n_ode2"], stats["n_ae"],
                                                          len(connectors), len(drives)))
print("solve %.3f s (min of %d, median %.3f)  steps %d (requested %d, h = %.3g)  newton its %d  jacobians %d  t_end %.6g"
      % (t_wall, len(walls), float(np.median(walls)), stats["steps"], n_steps, stats["h_nominal"],
         stats["newton_iterations"], stats["jacobian_evaluations"], stats["end_time_reached"]))

result = {"model": args.model, "exudyn_version": exu.__version__, "stats": stats,
          "drive_table_max_err": drive_table_err}
if sPlat is not None:
    data = mbs.GetSensorStoredData(sPlat)
    result["platform"] = {"t": data[:, 0].tolist(), "x": data[:, 1:4].tolist()}
    print("platform centre at t=%.4g: %s" % (data[-1, 0], np.array2string(data[-1, 1:4], precision=9)))

if args.diag:
    pen = []
    for (co, bg), s in zip(connectors, diag_sensors):
        dd = mbs.GetSensorStoredData(s)
        rho = np.hypot(dd[:, 1], dd[:, 2])
        pr = rho - bg["radial_clearance"]
        pa = dd[:, 3] - bg["axial_stop"]
        pen.append({"name": bg["name"], "t": dd[:, 0].tolist(), "radial": pr.tolist(), "axial": pa.tolist()})
        print("  %-14s radial pen: final %+.3e max %+.3e | axial pen: final %+.3e max %+.3e | "
              "contact at %3d/%d samples" % (bg["name"], pr[-1], pr.max(), pa[-1], pa.max(),
                                             int((pr > 0).sum()), len(pr)))
    result["penetrations"] = pen
    # drive tracking: rotation of the arm about the drive axis vs. closed form
    for d, s in zip(M["drives"], sArm):
        dd = mbs.GetSensorStoredData(s)
        i = d["body"]
        RJ = frame_z(d["axis"])
        err = 0.0
        for row in dd:
            R = row[1:10].reshape(3, 3)
            Rrel = RJ.T @ R @ Rb[i].T @ RJ          # rotation about local z of the drive frame
            ang = math.atan2(Rrel[1, 0], Rrel[0, 0])
            qd = drive_angle_np(d, M["z_law"], row[0]) - d["q_initial"]
            err = max(err, abs(math.remainder(ang - qd, 2 * math.pi)))
        print("  drive %s: max |angle - (q(t)-q(0))| at outputs = %.3e rad" % (d["name"], err))

if args.out:
    with open(args.out, "w") as f:
        json.dump(result, f)
    print("wrote", args.out)
