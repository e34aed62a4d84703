#!/usr/bin/env python3
"""lash against Exudyn on the 63-DOF MR2120 clearance model (L1, the 4 s trajectory), side by side.

One run of this script (through `bash benches/exudyn/run.sh`):
 1. runs `cargo run --release -- bench mr2120 --export DIR` (lash's BDF sweep, the tight-tolerance
    reference, the independent Dormand-Prince check that fixes the agreement horizon) and reads the
    exported model (model.json) and lash's results with the reference path (lash.json);
 2. checks that the two models agree before timing anything: Exudyn's platform path against the
    kinematic (ideal) trajectory and against lash's reference over the whole run -- the clearance
    errors (deviation from the ideal path) must be of the same size;
 3. runs Exudyn's implicit generalized-alpha solver (every bearing a symbolic, C++-evaluated contact
    law; see mr2120_exudyn.py) over a sweep of step sizes up to the agreement horizon, measures its
    error against lash's reference and its solve time;
 4. prints the comparison at equal accuracy (the cheapest setting of each engine whose platform stays
    within the target of the reference up to the horizon) as ratios to lash, writes
    DIR/exudyn-comparison.json and a work-precision diagram DIR/work-precision-exudyn.{png,svg}.

Every time quoted is measured in this one run on this machine.
"""
import argparse
import json
import math
import os
import subprocess
import sys

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(os.path.dirname(here))

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--dir", default=os.path.join(root, "out", "bench-exudyn"), help="output folder")
ap.add_argument("--reuse-lash", action="store_true",
                help="reuse DIR/model.json and DIR/lash.json from an earlier run instead of running lash")
ap.add_argument("--lash-args", default="--symplectic-steps= --diffsol-rtols= --explicit-budget 250",
                help="extra arguments of `lash bench mr2120` (default: lash's BDF sweep and the Dormand-Prince "
                     "horizon check only; the other peers are compared by `lash bench mr2120` itself)")
ap.add_argument("--steps", default="1e-4,5e-5,2.5e-5,1.25e-5",
                help="Exudyn step sizes to sweep, s, comma-separated")
ap.add_argument("--check-step", type=float, default=2.5e-5,
                help="Exudyn step of the whole-run model-agreement check, s")
ap.add_argument("--repeat", type=int, default=1, help="Exudyn solves per setting (the fastest counts)")
args = ap.parse_args()
os.makedirs(args.dir, exist_ok=True)
model_path = os.path.join(args.dir, "model.json")
lash_path = os.path.join(args.dir, "lash.json")


def say(msg):
    print(msg, flush=True)


# ------------------------------------------------------------------ 1. lash
if not args.reuse_lash:
    cmd = ["cargo", "run", "--release", "--quiet", "--", "bench", "mr2120", "--export", args.dir,
           "--out", args.dir, "--json"] + args.lash_args.split()
    say("== lash: " + " ".join(cmd))
    with open(os.path.join(args.dir, "lash-stdout.json"), "w") as out:
        r = subprocess.run(cmd, cwd=root, stdout=out)
    if r.returncode != 0:
        sys.exit("lash bench mr2120 failed (exit %d)" % r.returncode)
for p in (model_path, lash_path):
    if not os.path.exists(p):
        sys.exit("missing %s: run without --reuse-lash first" % p)
with open(model_path) as f:
    model = json.load(f)
with open(lash_path) as f:
    lash = json.load(f)

times = lash["times"]
ref = lash["reference_path"]
target = lash["target"]
# No independent run in lash's sweep: no horizon was measured, so compare over the whole run.
horizon = lash["horizon_s"] if lash["horizon_s"] is not None else lash["t_end"]
dt = model["dt_output"]
n_h = sum(1 for t in times if t <= horizon + 1e-9)
key = {round(t, 9): k for k, t in enumerate(times)}


def ideal(t):
    """platform centre on the kinematic path (the ideal mechanism), m"""
    (t0, t1, t2), (z0, z1, z2) = model["z_law"]["t"], model["z_law"]["z"]

    def s(tau):
        tau = min(max(tau, 0.0), 1.0)
        return tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
    return [0.0, 0.0, z0 + (z1 - z0) * s((t - t0) / (t1 - t0)) + (z2 - z1) * s((t - t1) / (t2 - t1))]


def exudyn_run(h, t_end, tag):
    out = os.path.join(args.dir, "exudyn-%s.json" % tag)
    cmd = [sys.executable, "-W", "ignore::DeprecationWarning", os.path.join(here, "mr2120_exudyn.py"),
           model_path, "--dt", repr(h), "--t-end", repr(t_end), "--repeat", str(args.repeat), "--out", out]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 or not os.path.exists(out):
        tail = (r.stdout + r.stderr).strip().splitlines()[-3:]
        return {"h": h, "failure": " | ".join(tail) or "exit %d" % r.returncode}
    with open(out) as f:
        res = json.load(f)
    os.remove(out)
    path = {}
    for t, x in zip(res["platform"]["t"], res["platform"]["x"]):
        k = key.get(round(t, 9))
        if k is not None:
            path[k] = x
    st = res["stats"]
    return {"h": h, "wall_s": st["solve_wall_s"], "steps": st["steps"], "newton_iters": st["newton_iterations"],
            "jacobians": st["jacobian_evaluations"], "reached_t": st["end_time_reached"], "path": path,
            "failure": None if st["end_time_reached"] >= t_end - 1e-9 else
            "stopped at t = %.4f s" % st["end_time_reached"]}


def max_dist(path, ks):
    ds = [math.dist(path[k], ref[k]) for k in ks if k in path]
    return max(ds) if len(ds) == len(ks) else float("nan")


# ------------------------------------------------------------------ 2. do the models agree?
say("== Exudyn: whole-run model check at h = %g s" % args.check_step)
chk = exudyn_run(args.check_step, model["t_end"], "check")
if chk.get("failure") and not chk.get("path"):
    sys.exit("the Exudyn check run failed: %s" % chk["failure"])
all_k = sorted(chk["path"])
dev_lash = [math.dist(ref[k], ideal(times[k])) for k in all_k]
dev_exu = [math.dist(chk["path"][k], ideal(times[k])) for k in all_k]
rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v))  # noqa: E731
windows = [(a, min(b, model["t_end"])) for a, b in [(0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 3.5), (3.5, 4.0)]
           if a < model["t_end"]]
agreement = {
    "exudyn_step_s": args.check_step,
    "exudyn_reached_t": chk["reached_t"],
    "clearance_error_rms_m": {"lash": rms(dev_lash), "exudyn": rms(dev_exu)},
    "clearance_error_max_m": {"lash": max(dev_lash), "exudyn": max(dev_exu)},
    "difference_by_window_m": [
        (a, b, max([math.dist(chk["path"][k], ref[k]) for k in all_k if a < times[k] <= b + 1e-9] or [float("nan")]))
        for a, b in windows],
    "difference_to_horizon_m": max_dist(chk["path"], list(range(n_h))),
}
say("platform deviation from the ideal (kinematic) path over the run -- the clearance error:")
say("  lash reference: RMS %.2f um, max %.2f um" % (1e6 * rms(dev_lash), 1e6 * max(dev_lash)))
say("  Exudyn:         RMS %.2f um, max %.2f um" % (1e6 * rms(dev_exu), 1e6 * max(dev_exu)))
agreement["clearance_error_max_by_window_m"] = [
    (a, b, max([dev_lash[i] for i, k in enumerate(all_k) if a < times[k] <= b + 1e-9] or [float("nan")]),
     max([dev_exu[i] for i, k in enumerate(all_k) if a < times[k] <= b + 1e-9] or [float("nan")]))
    for a, b in windows]
say("  largest by window, lash / Exudyn: " + ", ".join(
    "%g-%g s: %.0f / %.0f um" % (a, b, 1e6 * x, 1e6 * y) for a, b, x, y in agreement["clearance_error_max_by_window_m"]))
say("largest distance Exudyn - lash reference by window: " + ", ".join(
    "%g-%g s: %.2g um" % (a, b, 1e6 * d) for a, b, d in agreement["difference_by_window_m"]))
ratio = rms(dev_exu) / rms(dev_lash)
agreement["same_size"] = 0.5 <= ratio <= 2.0
say("clearance errors of the same size (RMS ratio %.2f, accepted 0.5-2): %s"
    % (ratio, "yes" if agreement["same_size"] else "NO"))
if not agreement["same_size"]:
    sys.exit("the two models disagree; no timing is compared")

# ------------------------------------------------------------------ 3. Exudyn sweep to the horizon
t_h = times[n_h - 1]
runs = []
for h in [float(x) for x in args.steps.split(",") if x.strip()]:
    say("== Exudyn: generalized-alpha, h = %g s, to the horizon t = %.2f s" % (h, t_h))
    r = exudyn_run(h, t_h, "h%g" % h)
    if r.get("path"):
        r["error_to_horizon"] = max_dist(r["path"], list(range(n_h)))
    runs.append(r)
    say("   " + ("failed: " + r["failure"] if r.get("failure") else
                 "error %.3g m, solve %.2f s, %d steps, %d Newton iterations, %d Jacobians"
                 % (r["error_to_horizon"], r["wall_s"], r["steps"], r["newton_iters"], r["jacobians"])))

# ------------------------------------------------------------------ 4. equal accuracy
lash_pts = [p for p in lash["points"] if p["solver"].startswith("lash")]


def cheapest(pts, tol, err_key, wall_key):
    ok = [p for p in pts if p.get(err_key) is not None and p[err_key] == p[err_key] and p[err_key] <= tol]
    return min(ok, key=lambda p: p[wall_key]) if ok else None


good = [r for r in runs if not r.get("failure") and r.get("error_to_horizon") == r.get("error_to_horizon")]
rows = []
for tol in sorted({target, *(r["error_to_horizon"] for r in good)}):
    lp = cheapest(lash_pts, tol, "error_to_horizon", "wall_to_horizon_s")
    ep = cheapest(good, tol, "error_to_horizon", "wall_s")
    if lp and ep:
        rows.append({"accuracy_m": tol, "lash_rtol": lp["rtol"], "lash_error_m": lp["error_to_horizon"],
                     "lash_wall_s": lp["wall_to_horizon_s"], "exudyn_step_s": ep["h"],
                     "exudyn_error_m": ep["error_to_horizon"], "exudyn_wall_s": ep["wall_s"],
                     "time_ratio": ep["wall_s"] / lp["wall_to_horizon_s"]})
say("\nMR2120 %s clearance model up to the agreement horizon t = %.2f s; accuracy = largest platform-centre "
    "distance from lash's reference (rtol %.0e)" % (model["description"].split(",")[1].strip(), t_h,
                                                      lash["reference"]["rtol"]))
say("%-34s %-10s %11s %9s %8s %8s %9s" % ("engine", "setting", "error [m]", "wall [s]", "steps", "Newton", "Jacobians"))
for p in lash_pts:
    say("%-34s %-10s %11.3g %9.2f %8s %8s %9s" % ("lash BDF (GGL index 2)", "rtol %.0e" % p["rtol"],
                                                 p["error_to_horizon"], p["wall_to_horizon_s"], "-", "-", "-"))
for r in runs:
    if r.get("failure"):
        say("%-34s %-10s  failed: %s" % ("Exudyn generalized-alpha", "h %g" % r["h"], r["failure"]))
    else:
        say("%-34s %-10s %11.3g %9.2f %8d %8d %9d" % ("Exudyn generalized-alpha", "h %g" % r["h"],
                                                     r["error_to_horizon"], r["wall_s"], r["steps"],
                                                     r["newton_iters"], r["jacobians"]))
say("(lash: wall time to the horizon within its whole run; whole-run steps and iterations are in lash.json.\n"
    " Exudyn: solve time of a run that ends at the horizon, set-up excluded.)")
say("\nat equal accuracy, the cheapest setting of each engine:")
for row in rows:
    say("  within %.2g m: lash rtol %.0e %.2f s, Exudyn h %g %.2f s -> Exudyn takes %.1fx lash's time"
        % (row["accuracy_m"], row["lash_rtol"], row["lash_wall_s"], row["exudyn_step_s"], row["exudyn_wall_s"],
           row["time_ratio"]))
if not any(abs(r["accuracy_m"] - target) < 1e-15 for r in rows):
    say("  within the target %.0e m: %s" % (target, "no Exudyn step of the sweep reached it"
                                            if not any(r["error_to_horizon"] <= target for r in good)
                                            else "no lash tolerance of the sweep reached it"))

out = {"set": model["description"], "horizon_s": t_h, "target_m": target, "model_agreement": agreement,
       "lash": [{k: p[k] for k in ("rtol", "error_to_horizon", "wall_to_horizon_s", "steps", "wall_s")}
                for p in lash_pts],
       "exudyn": [{k: v for k, v in r.items() if k != "path"} for r in runs], "equal_accuracy": rows}
with open(os.path.join(args.dir, "exudyn-comparison.json"), "w") as f:
    json.dump(out, f, indent=1)

# ------------------------------------------------------------------ work-precision diagram
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 5.5))
    series = {}
    for p in lash["points"]:
        e, w = p.get("error_to_horizon"), p.get("wall_to_horizon_s")
        if e is not None and w is not None and e == e and w == w:
            series.setdefault(p["solver"], []).append((w, max(e, 1e-12)))
    series["Exudyn 1.13 generalized-alpha (symbolic contact)"] = [(r["wall_s"], r["error_to_horizon"]) for r in good]
    for name, pts in series.items():
        pts.sort()
        ax.loglog([x for x, _ in pts], [y for _, y in pts], "o-", label=name)
    ax.axhline(target, color="grey", ls="--", lw=1, label="target %.0e m" % target)
    ax.set_xlabel("wall time to the horizon t = %.2f s [s]" % t_h)
    ax.set_ylabel("largest platform-centre error vs reference [m]")
    ax.set_title("MR2120 L1 clearance model: work-precision, lash and Exudyn (one run)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(args.dir, "work-precision-exudyn." + ext), dpi=120)
    say("work-precision diagram: %s/work-precision-exudyn.png / .svg" % args.dir)
except ImportError:
    say("(matplotlib missing: no diagram)")
say("results: %s" % os.path.join(args.dir, "exudyn-comparison.json"))
