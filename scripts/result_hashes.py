#!/usr/bin/env python3
"""Fingerprints of every result the headless runner writes, for checking that a change to the code
leaves the physics bit-identical (a restructuring, a refactor, a build change).

For each scene (default: config/*.yaml), each boundary method and each thread count it runs
`fluid_sim_run` and hashes
  - every PLY frame (frames/NNNNNN.ply, byte for byte),
  - stats.csv without its timing columns (wall_ms, ms_neighbors, ms_divergence, ms_density) and
    the diagnostic columns added later (STATS_DIAGNOSTIC),
  - summary.json without its timings (wall_time_s, step_time_s, ms_per_step, real_time_factor).

  scripts/result_hashes.py record --runner build/fluid_sim_run --out before.json
  ... change the code, rebuild ...
  scripts/result_hashes.py record --runner build/fluid_sim_run --out after.json
  scripts/result_hashes.py compare before.json after.json     # exit 0 when identical

`--duration S` shortens every run (default: each scene's own duration); `--scenes` picks files.
Standard library only.
"""

import argparse
import concurrent.futures
import csv
import glob
import hashlib
import io
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
METHODS = ["mirroring", "sph", "mls"]
STATS_TIMING = {"wall_ms", "ms_neighbors", "ms_divergence", "ms_density"}
# Diagnostic columns added after the first records (derived from the state, not part of it):
# left out so that records before and after their addition compare.
STATS_DIAGNOSTIC = {"coefficient_min", "coefficient_max", "coefficient_abs_sum_max", "coefficient_abs_sum_mean",
                    "feedback_ratio_min", "feedback_ratio_max", "density_residual_first", "density_residual_peak",
                    "density_residual_last", "wall_guarded", "wall_guard_max_shift"}
SUMMARY_TIMING = {"wall_time_s", "step_time_s", "ms_per_step", "real_time_factor"}
# Summary keys added after the first records, left out for the same reason (where they report
# something, the stats and frames differ as well).
SUMMARY_DIAGNOSTIC = {"density_not_converged_steps", "divergence_not_converged_steps", "wall_guarded_steps",
                      "wall_guarded_particles", "wall_guard_max_shift_m"}


def sha(data):
    return hashlib.sha256(data).hexdigest()


def stats_hash(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    keep = [k for k, name in enumerate(rows[0]) if name not in STATS_TIMING | STATS_DIAGNOSTIC]
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    for row in rows:
        w.writerow([row[k] for k in keep])
    return sha(out.getvalue().encode()), len(rows) - 1


def summary_hash(path):
    with open(path) as f:
        summary = json.load(f)
    for key in SUMMARY_TIMING | SUMMARY_DIAGNOSTIC:
        summary.pop(key, None)
    summary.pop("scene", None)  # the path the scene was given by, not a result
    return sha(json.dumps(summary, sort_keys=True).encode()), summary.get("status", "?")


def run_one(runner, scene, method, threads, duration, workdir):
    name = os.path.splitext(os.path.basename(scene))[0]
    out = os.path.join(workdir, "%s_%s_t%d" % (name, method, threads))
    cmd = [runner, scene, "--out", out, "--threads", str(threads), "--set",
           "solver.boundary_pressure=" + method]
    if duration is not None:
        cmd += ["--duration", str(duration)]
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    entry = {"scene": os.path.relpath(scene, ROOT), "method": method, "threads": threads,
             "exit_code": proc.returncode}
    if not os.path.exists(os.path.join(out, "summary.json")):
        entry["error"] = proc.stdout[-2000:]
        return entry
    entry["stats"], entry["steps"] = stats_hash(os.path.join(out, "stats.csv"))
    entry["summary"], entry["status"] = summary_hash(os.path.join(out, "summary.json"))
    frames = sorted(glob.glob(os.path.join(out, "frames", "*.ply")))
    entry["frames"] = {os.path.basename(p): sha(open(p, "rb").read()) for p in frames}
    return entry


def key(e):
    return "%s %s t%d" % (e["scene"], e["method"], e["threads"])


def record(args):
    scenes = args.scenes or sorted(glob.glob(os.path.join(ROOT, "config", "*.yaml")))
    scenes = [os.path.abspath(s) for s in scenes]
    jobs = [(s, m, t) for s in scenes for m in METHODS for t in args.threads]
    results = []
    with tempfile.TemporaryDirectory(prefix="fluid_hashes_") as work:
        # Runs in parallel only when asked: a run with 2 threads beside another would still give
        # the same results (they do not depend on timing), it would only take longer.
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            futures = [pool.submit(run_one, args.runner, s, m, t, args.duration, work) for s, m, t in jobs]
            for f in futures:
                e = f.result()
                results.append(e)
                print("%-55s exit %d  %s  %d steps  %d frames  stats %s" % (
                    key(e), e["exit_code"], e.get("status", "-"), e.get("steps", 0), len(e.get("frames", {})),
                    e.get("stats", "-")[:12]), flush=True)
    with open(args.out, "w") as f:
        json.dump({"duration": args.duration, "runs": results}, f, indent=1, sort_keys=True)
    print("wrote", args.out)
    return 0


def compare(args):
    a = {key(e): e for e in json.load(open(args.before))["runs"]}
    b = {key(e): e for e in json.load(open(args.after))["runs"]}
    bad = 0
    keys = set(a) & set(b) if args.common else set(a) | set(b)
    for k in sorted(keys):
        if k not in a or k not in b:
            print("only in one file:", k)
            bad += 1
            continue
        ea, eb = a[k], b[k]
        diffs = [f for f in ("exit_code", "stats", "summary", "steps") if ea.get(f) != eb.get(f)]
        fa, fb = ea.get("frames", {}), eb.get("frames", {})
        frame_diffs = sorted(n for n in set(fa) | set(fb) if fa.get(n) != fb.get(n))
        if frame_diffs:
            diffs.append("frames (first %s, %d of %d)" % (frame_diffs[0], len(frame_diffs), len(fa)))
        if diffs:
            bad += 1
            print("DIFFERENT %s: %s" % (k, ", ".join(diffs)))
    total = len(keys)
    print("%d of %d runs identical" % (total - bad, total))
    return 1 if bad else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="run the scenes and write their fingerprints")
    r.add_argument("--runner", default=os.path.join(ROOT, "build", "fluid_sim_run"))
    r.add_argument("--out", required=True)
    r.add_argument("--scenes", nargs="*")
    r.add_argument("--duration", type=float, default=None, help="s; default: each scene's own")
    r.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    r.add_argument("--jobs", type=int, default=1, help="runs at once")
    c = sub.add_parser("compare", help="compare two fingerprint files")
    c.add_argument("before")
    c.add_argument("after")
    c.add_argument("--common", action="store_true", help="compare only the runs both files hold")
    args = ap.parse_args()
    sys.exit(record(args) if args.cmd == "record" else compare(args))


if __name__ == "__main__":
    main()
