#!/usr/bin/env python3
"""Times fluid_sim_bench against SPlisHSPlasH (the speed yardstick) on the same dam break.

    PYENV_VERSION=system /usr/bin/python3 scripts/yardstick.py \
        --bench build/fluid_sim_bench \
        --sph-bin /path/to/SPlisHSPlasH/bin/SPHSimulator \
        --sph-scene-dir /path/to/SPlisHSPlasH/data/Scenes \
        [--case 0.031:300:3 --case 0.017:60:2] [--rounds 2] [--threads 2] [--out DIR]
        [--sph-fluid block|rest] [--cold-start zero|jacobi] [--set KEY=VALUE ...]
        [--sph-bin-cold /path/to/a/cold/SPHSimulator]

For every case (spacing S in m, N steps of 1 ms) and every round, it runs in turn
  1. ours, cold:  fluid_sim_bench SCENE --spacing S --method all --warmup 0 --steps N --threads T --json F
                  --set solver.cold_start=C   (C from --cold-start: zero, the default, or jacobi)
  2. ours, warm:  the same with --set solver.warm_start=true
     (each --set KEY=VALUE given to this script is passed on to both of our runs, e.g.
     solver.chebyshev_rho=0.95; the rows' start then names it)
  3. theirs:      OMP_NUM_THREADS=T SPHSimulator --no-gui --stopAt ... --output-dir D scene.json
so that rounds alternate ours-theirs-ours-theirs, and prints one table: ms per step, µs per
fluid particle-step, ours/theirs per particle-step against SPlisHSPlasH's run of the same round,
and the split of a step into neighbour search, divergence solve, density (pressure) solve and
the rest, in ms and %.

The SPlisHSPlasH scene is generated from our scene file (config/bench_dam_break.yaml by
default): the same tank box and the same water box sampled on the same lattice (particle
diameter = our spacing, the same count and positions per axis), y up in SPlisHSPlasH where we
have z up; DFSPH with Akinci boundary particles (boundaryHandlingMethod 0), a fixed 1 ms step
(cflMethod 0), and our solver tolerances in percent (maxError 0.05 %, maxErrorV 0.1 %). Its
box mesh is data/models/UnitBox.obj next to --sph-scene-dir.

SPlisHSPlasH's DFSPH always warm-starts both solves (half the previous step's pressure), so its
single row per round is compared with both our cold and our warm rows. With --sph-bin-cold, a
second SPlisHSPlasH binary built with that warm start compiled out (its TimeStepDFSPH with
USE_WARMSTART and USE_WARMSTART_V undefined; each solve then starts from one unrelaxed Jacobi
step) runs too, after the first in every round, and our cold rows are compared with it: cold
against cold, warm against warm. The summary then also gives our cold rows against its warm run.

SPlisHSPlasH gives a particle of diameter d the volume 0.8 d^3, so its block on our lattice
(the default, --sph-fluid block, the comparison the issue specified) starts at 0.8 of its rest
density and lands without pressure; ours starts at rest density. --sph-fluid rest gives it our
lattice points as a particle file (Partio PDA) with the diameter (1.0758 spacings) that puts that
lattice at its rest density: the same particles and mass per particle, its kernel then reaching
1.245x as many neighbours as ours.

Only the Python standard library and PyYAML are used (run with the system interpreter).
"""

import argparse
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import yaml

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ---------------------------------------------------------------------------------------------
# Scene translation


def lattice_axis(lo, hi, spacing):
    """Our cell-centred lattice on one axis (fluid_fill.cpp): n points, the first at `first`."""
    ext = hi - lo
    n = int(math.floor(ext / spacing + 1e-9))
    first = lo + 0.5 * (ext - n * spacing) + 0.5 * spacing
    return n, first


def our_to_theirs(v):
    """Our axes (x, y, z up) to SPlisHSPlasH's (x, y up, z)."""
    return [v[0], v[2], v[1]]


# SPlisHSPlasH gives a fluid particle the volume 0.8 d^3 (d = 2 x particleRadius) and samples a
# fluid block on a cubic lattice of spacing d. Its cubic kernel (support 2d) sums to 1.0000 / d^3
# over that lattice (0.99997), so its block starts at 0.80 of the rest density and compacts by a
# fifth with no pressure at all (its density solve's error is exactly 0 through the landing).
SPH_VOLUME_FACTOR = 0.8


def cubic_lattice_sum(support):
    """sum_j W(x_i - x_j) d^3 over an infinite cubic lattice of spacing d = 1, for the cubic spline
    kernel with the given support (in lattice spacings), self term included; 1 for a kernel that
    integrates exactly on the lattice."""
    k = 8.0 / (math.pi * support ** 3)
    reach = int(support) + 1
    total = 0.0
    for i in range(-reach, reach + 1):
        for j in range(-reach, reach + 1):
            for l in range(-reach, reach + 1):
                q = math.sqrt(i * i + j * j + l * l) / support
                if q <= 0.5:
                    total += k * (6.0 * q ** 3 - 6.0 * q ** 2 + 1.0)
                elif q <= 1.0:
                    total += k * 2.0 * (1.0 - q) ** 3
    return total


def rest_density_diameter_factor():
    """f such that SPlisHSPlasH particles of diameter f s on our lattice of spacing s are at its
    rest density: 0.8 f^3 x cubic_lattice_sum(2 f) = 1 (bisection; f = 1.0758). Its kernel then
    reaches f^3 = 1.245 times as many neighbours as ours (support 2 s) at the same particle mass."""
    lo, hi = 1.0, 1.2
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if SPH_VOLUME_FACTOR * mid ** 3 * cubic_lattice_sum(2.0 * mid) < 1.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def our_lattice(water, spacing):
    """Our fluid block's lattice points (our axes), the order irrelevant."""
    axes = [lattice_axis(water["min"][a], water["max"][a], spacing) for a in range(3)]
    return [[axes[0][1] + i * spacing, axes[1][1] + j * spacing, axes[2][1] + k * spacing]
            for i in range(axes[0][0]) for j in range(axes[1][0]) for k in range(axes[2][0])]


def write_pda(path, points):
    """Points in Partio's ASCII PDA format (attribute "position"), which SPlisHSPlasH reads as a
    FluidModels particleFile."""
    with open(path, "w") as f:
        f.write(f"ATTRIBUTES\nposition\nTYPES\nV\nNUMBER_OF_PARTICLES: {len(points)}\nBEGIN DATA\n")
        for p in points:
            f.write(f"{p[0]!r} {p[1]!r} {p[2]!r}\n")


def sph_scene(our_scene, spacing, unit_box_obj, fluid_mode="block", particle_file=None):
    """The SPlisHSPlasH scene (a dict) for our scene file at `spacing`.

    fluid_mode "block" (the issue's comparison): a FluidBlock on our lattice with particle
    diameter = our spacing, so the block starts at 0.8 rest density (SPH_VOLUME_FACTOR).
    fluid_mode "rest": our lattice points written to `particle_file` (PDA), with the particle
    diameter rest_density_diameter_factor() x spacing so that the block starts at rest density, as
    ours does: the same particles, positions and mass per particle, its kernel reaching 1.245x our
    neighbours."""
    boundaries = [b for b in our_scene.get("boundaries", []) if "box" in b and b.get("inside")]
    if len(boundaries) != 1 or len(our_scene.get("fluid", [])) != 1 or "box" not in our_scene["fluid"][0]:
        raise SystemExit("yardstick: the scene must have one container box and one fluid box")
    tank = boundaries[0]["box"]
    water = our_scene["fluid"][0]["box"]
    radius = 0.5 * spacing
    if fluid_mode == "rest":
        radius *= rest_density_diameter_factor()
    diam = spacing

    tank_min, tank_max = tank["min"], tank["max"]
    tank_centre = [0.5 * (a + b) for a, b in zip(tank_min, tank_max)]
    tank_size = [b - a for a, b in zip(tank_min, tank_max)]

    # SPlisHSPlasH (denseMode 0) puts round(L / d) - 1 particles per axis, the first at
    # min + d. Its block is chosen so that they land on our lattice points: min = first - d,
    # L = (n + 1) d.
    block_min, block_max, counts = [], [], []
    for a in range(3):
        n, first = lattice_axis(water["min"][a], water["max"][a], spacing)
        block_min.append(first - diam)
        block_max.append(first - diam + (n + 1) * diam)
        counts.append(n)

    solver = our_scene.get("solver", {})
    gravity = our_scene.get("gravity", [0.0, 0.0, -9.81])
    viscosity = our_scene.get("viscosity", {}).get("coefficient", 0.01)
    dt = our_scene["time_step"]["fixed"]
    scene = {
        "Configuration": {
            "particleRadius": radius,
            "simulationMethod": 4,  # DFSPH
            "gravitation": our_to_theirs(gravity),
            "timeStepSize": dt,
            "cflMethod": 0,  # fixed step
            "cflFactor": 1,
            "cflMaxTimeStepSize": dt,
            "boundaryHandlingMethod": 0,  # Akinci et al. 2012 boundary particles
            "enablePartioExport": False,
            "enableVTKExport": False,
            "DFSPH": {
                "minIterations": int(solver.get("min_iterations", 2)),
                "maxIterations": int(solver.get("max_iterations", 100)),
                "maxError": 100.0 * float(solver.get("density_error", 0.0005)),  # %
                "maxIterationsV": int(solver.get("max_iterations", 100)),
                "maxErrorV": 100.0 * float(solver.get("divergence_error", 0.001)),  # %
                "enableDivergenceSolver": True,
            },
        },
        "Materials": [
            {
                "id": "Fluid",
                "density0": 1000,
                "viscosityMethod": 1,  # its standard (Laplacian) viscosity; ours is XSPH
                "Standard viscosity": {"viscosity": viscosity},
            }
        ],
        "RigidBodies": [
            {
                "geometryFile": unit_box_obj,  # the box [-0.5, 0.5]^3
                "translation": our_to_theirs(tank_centre),
                "rotationAxis": [1, 0, 0],
                "rotationAngle": 0,
                "scale": our_to_theirs(tank_size),
                "color": [0.1, 0.4, 0.6, 1.0],
                "isDynamic": False,
                "isWall": True,
                "mapInvert": True,
                "mapThickness": 0.0,
                "mapResolution": [40, 30, 15],
            }
        ],
        "FluidBlocks": [
            {
                "denseMode": 0,
                "start": our_to_theirs(block_min),
                "end": our_to_theirs(block_max),
                "translation": [0, 0, 0],
                "scale": [1, 1, 1],
            }
        ],
    }
    if fluid_mode == "rest":
        points = [our_to_theirs(p) for p in our_lattice(water, spacing)]
        write_pda(particle_file, points)
        del scene["FluidBlocks"]
        scene["FluidModels"] = [{"id": "Fluid", "particleFile": os.path.abspath(particle_file),
                                 "translation": [0, 0, 0], "scale": [1, 1, 1]}]
    return scene, counts[0] * counts[1] * counts[2]


# ---------------------------------------------------------------------------------------------
# Runs


def load_average():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def children_cpu_s():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(cmd, env=None, log=None):
    """Runs cmd; returns its output, wall-clock s and CPU s (user + system, whole process)."""
    start = time.monotonic()
    cpu0 = children_cpu_s()
    proc = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.monotonic() - start
    cpu = children_cpu_s() - cpu0
    if log:
        with open(log, "w") as f:
            f.write(" ".join(cmd) + "\n" + proc.stdout)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-4000:])
        raise SystemExit(f"yardstick: {' '.join(cmd)} exited with {proc.returncode}")
    return proc.stdout, wall, cpu


def run_ours(args, spacing, steps, warm, workdir, tag):
    json_path = os.path.join(workdir, f"ours_{tag}.json")
    cmd = [args.bench, args.scene, "--spacing", repr(spacing)]
    for method in args.methods:  # the bench's --method is repeatable, one value each
        cmd += ["--method", method]
    cmd += ["--warmup", "0", "--steps", str(steps), "--threads", str(args.threads), "--json", json_path]
    if warm:
        cmd += ["--set", "solver.warm_start=true"]
    else:  # named even when it is the scene default, so that the rows say what they ran
        cmd += ["--set", f"solver.cold_start={args.cold_start}"]
    for override in args.set:
        cmd += ["--set", override]
    _, wall, cpu = run(cmd, log=os.path.join(workdir, f"ours_{tag}.log"))
    print(f"    ours {tag}: {wall:.0f} s wall, {cpu:.0f} s CPU ({cpu / wall / args.threads:.0%} of {args.threads} cores)",
          flush=True)
    with open(json_path) as f:
        doc = json.load(f)
    rows = []
    for r in doc["rows"]:
        total = r["ms_per_step_mean"]
        nbr = r["ms_neighbors_per_step"]
        div = r["ms_divergence_per_step"]
        dens = r["ms_density_per_step"]
        rows.append({
            "code": "ours", "method": r["method"],
            "start": ("warm" if warm else ("cold" if args.cold_start == "zero" else f"cold ({args.cold_start})")) +
                     "".join(f" [{o}]" for o in args.set),
            "fluid": r["fluid_particles"], "boundary": r["boundary_particles"], "steps": r["steps"],
            "sim_time": r["sim_time_s"], "ms": total, "nbr": nbr, "div": div, "dens": dens,
            "rest": total - nbr - div - dens,
            "div_it": r["divergence_iterations_per_step"], "dens_it": r["density_iterations_per_step"],
            "flags": ("unstable" if r["steps_unstable"] else
                      (f"nc={r['steps_not_converged']}" if r["steps_not_converged"] else "ok")),
            "wall_s": wall, "cpu_s": cpu,
        })
    return rows


AVG_TIME = re.compile(r"Average time: (.+?): ([-+0-9.eE]+) ms")
TIME_SUM = re.compile(r"Time sum: (.+?): ([-+0-9.eE]+) ms")
AVG_NUMBER = re.compile(r"Average number: (.+?): ([-+0-9.eE]+)")
TOTAL_NUMBER = re.compile(r"Total number: (.+?): ([-+0-9.eE]+)")


def run_theirs(args, scene_path, steps, dt, workdir, tag, binary=None, start="warm (always)"):
    binary = binary or args.sph_bin
    outdir = os.path.join(workdir, f"sph_out_{tag}")
    os.makedirs(outdir, exist_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads))
    env.update(kv.split("=", 1) for kv in args.sph_env)
    # stopAt halfway into step N + 1: SPlisHSPlasH steps while time <= stopAt, so N steps.
    stop_at = (steps - 0.5) * dt
    cmd = [binary, "--no-gui", "--stopAt", repr(stop_at), "--output-dir", outdir, scene_path]
    out, wall, cpu = run(cmd, env=env, log=os.path.join(workdir, f"sph_{tag}.log"))
    print(f"    SPlisHSPlasH {start} {tag}: {wall:.0f} s wall, {cpu:.0f} s CPU ({cpu / wall / args.threads:.0%} of "
          f"{args.threads} cores; includes its boundary sampling unless cached)", flush=True)
    avg = {m.group(1): float(m.group(2)) for m in AVG_TIME.finditer(out)}
    sums = {m.group(1): float(m.group(2)) for m in TIME_SUM.finditer(out)}
    counts = {m.group(1): float(m.group(2)) for m in AVG_NUMBER.finditer(out)}
    totals = {m.group(1): float(m.group(2)) for m in TOTAL_NUMBER.finditer(out)}
    fluid = re.search(r"Number of fluid particles: (\d+)", out)
    boundary = re.search(r"Number of boundary particles: (\d+)", out)
    if "SimStep" not in avg or not fluid:
        raise SystemExit(f"yardstick: no 'Average time: SimStep' or particle count in {cmd}")
    total = avg["SimStep"]
    n_steps = round(sums["SimStep"] / total) if total > 0 else 0
    nbr = avg.get("neighborhood_search", 0.0)
    div = avg.get("divergenceSolve", 0.0)
    dens = avg.get("pressureSolve", 0.0)
    shutil.rmtree(outdir, ignore_errors=True)
    return [{
        "code": "SPlisHSPlasH", "method": "akinci", "start": start,
        "fluid": int(fluid.group(1)), "boundary": int(boundary.group(1)) if boundary else 0,
        "steps": n_steps, "sim_time": totals.get("Time step size", float("nan")),
        "ms": total, "nbr": nbr, "div": div, "dens": dens, "rest": total - nbr - div - dens,
        "div_it": counts.get("DFSPH - iterationsV", float("nan")),
        "dens_it": counts.get("DFSPH - iterations", float("nan")),
        "flags": "", "wall_s": wall, "cpu_s": cpu,
        "phases": {k: v for k, v in avg.items() if k != "SimStep"},
    }]


# ---------------------------------------------------------------------------------------------
# Output


def us_per_particle_step(row):
    return 1000.0 * row["ms"] / row["fluid"]


THEIRS_COLD = "cold (warm start compiled out)"


def reference(rows, row, like_for_like=True):
    """SPlisHSPlasH's row of the round that `row` (one of ours) is compared with: its cold run for
    our cold rows when there is one (and like_for_like), else its warm run."""
    theirs = [r for r in rows if r["code"] == "SPlisHSPlasH"]
    warm = next(r for r in theirs if r["start"] != THEIRS_COLD)
    cold = next((r for r in theirs if r["start"] == THEIRS_COLD), None)
    if like_for_like and cold is not None and row["start"].startswith("cold"):
        return cold
    return warm


def split(row, key):
    return f"{row[key]:.1f} ({100.0 * row[key] / row['ms']:.0f} %)" if row["ms"] > 0 else "-"


def print_table(results):
    header = ["particles (fluid)", "round", "code", "method", "start", "ms/step", "µs/particle-step",
              "ours/theirs", "neighbour search", "divergence solve", "density solve", "rest",
              "div. it./step", "dens. it./step"]
    print("| " + " | ".join(header) + " |")
    print("|" + " --- |" * len(header))
    for case in results:
        for rnd, rows in enumerate(case["rounds"], start=1):
            for r in rows:
                ratio = "" if r["code"] == "SPlisHSPlasH" else \
                    f"{us_per_particle_step(r) / us_per_particle_step(reference(rows, r)):.2f}"
                if r["flags"] not in ("", "ok"):
                    ratio += f" ({r['flags']})"
                print("| " + " | ".join([
                    f"{r['fluid']:,}", str(rnd), r["code"], r["method"], r["start"], f"{r['ms']:.1f}",
                    f"{us_per_particle_step(r):.3f}", ratio, split(r, "nbr"), split(r, "div"), split(r, "dens"),
                    split(r, "rest"), f"{r['div_it']:.2f}", f"{r['dens_it']:.2f}"]) + " |")


def print_summary(results, target):
    has_cold = any(r["start"] == THEIRS_COLD for case in results for rows in case["rounds"] for r in rows)
    readings = [(True, "cold against its cold run, warm against its warm run")] if has_cold else []
    readings.append((False, "every row against its warm-started run"))
    for like_for_like, what in readings:
        print(f"\nours/theirs per particle-step, over the rounds, {what} (target: at most {target}):")
        for case in results:
            ratios = {}
            for rows in case["rounds"]:
                for r in rows:
                    if r["code"] != "SPlisHSPlasH":
                        ref = reference(rows, r, like_for_like)
                        ratios.setdefault((r["method"], r["start"]), []).append(
                            us_per_particle_step(r) / us_per_particle_step(ref))
            worst = max(max(v) for v in ratios.values())
            print(f"  spacing {case['spacing']} m ({case['steps']} steps): " + ", ".join(
                f"{m} {s} {min(v):.2f}-{max(v):.2f}" for (m, s), v in ratios.items()) +
                f"; worst {worst:.2f}: {'holds' if worst <= target else 'does NOT hold'}")
    for case in results:
        theirs_phases = [r["phases"] for rows in case["rounds"] for r in rows if r["code"] == "SPlisHSPlasH"]
        if theirs_phases:
            keys = sorted(set().union(*theirs_phases), key=lambda k: -theirs_phases[0].get(k, 0.0))
            print(f"  spacing {case['spacing']} m: SPlisHSPlasH's phases, ms/step by run: " + "; ".join(
                f"{k} " + "/".join(f"{p.get(k, 0.0):.2f}" for p in theirs_phases) for k in keys))


def read_pda_positions(path):
    """The positions of a PDA file as written by write_pda (for the self-test)."""
    with open(path) as f:
        words = f.read().split()
    count = int(words[words.index("NUMBER_OF_PARTICLES:") + 1])
    data = [float(w) for w in words[words.index("DATA") + 1:]]
    if len(data) != 3 * count:
        raise ValueError(f"{path}: {len(data)} numbers for {count} particles")
    return [data[3 * i:3 * i + 3] for i in range(count)]


def self_test(our_scene_path):
    """Checks the scene translation without SPlisHSPlasH; returns a list of failures."""
    failures = []
    # The cubic spline integrates to 1, and on a lattice with support 2 spacings sums to it within
    # 3e-5: SPlisHSPlasH's block at volume 0.8 d^3 is then at 0.8 of its rest density.
    total = cubic_lattice_sum(2.0)
    if abs(total - 1.0) > 1e-4:
        failures.append(f"cubic_lattice_sum(2) = {total}, expected 1 within 1e-4")
    f = rest_density_diameter_factor()
    density = SPH_VOLUME_FACTOR * f ** 3 * cubic_lattice_sum(2.0 * f)
    if abs(density - 1.0) > 1e-9 or not 1.07 < f < 1.08:
        failures.append(f"rest_density_diameter_factor() = {f} gives density {density}, expected 1")
    # The pairing of rows: our cold rows against its cold run when there is one, else its warm run.
    ours_cold = {"code": "ours", "start": "cold"}
    ours_cold_jacobi = {"code": "ours", "start": "cold (jacobi) [solver.chebyshev_rho=0.95]"}
    ours_warm = {"code": "ours", "start": "warm"}
    theirs_warm = {"code": "SPlisHSPlasH", "start": "warm (always)"}
    theirs_cold = {"code": "SPlisHSPlasH", "start": THEIRS_COLD}
    both = [ours_cold, ours_cold_jacobi, ours_warm, theirs_warm, theirs_cold]
    pairs = [(reference(both, ours_cold), theirs_cold), (reference(both, ours_cold_jacobi), theirs_cold),
             (reference(both, ours_warm), theirs_warm), (reference(both, ours_cold, False), theirs_warm),
             (reference(both[:4], ours_cold), theirs_warm)]
    for k, (got, expected) in enumerate(pairs):
        if got is not expected:
            failures.append(f"reference() case {k}: {got['start']}, expected {expected['start']}")
    with open(our_scene_path) as fh:
        our_scene = yaml.safe_load(fh)
    spacing = 0.031
    with tempfile.TemporaryDirectory() as tmp:
        block, n_block = sph_scene(our_scene, spacing, "box.obj")
        pda = os.path.join(tmp, "fluid.pda")
        rest, n_rest = sph_scene(our_scene, spacing, "box.obj", "rest", pda)
        points = read_pda_positions(pda)
        if n_rest != n_block or len(points) != n_block:
            failures.append(f"rest mode: {len(points)} points in the file, {n_block} in the block")
        radius = rest["Configuration"]["particleRadius"]
        if abs(radius - 0.5 * spacing * f) > 1e-12:
            failures.append(f"rest mode: particle radius {radius}, expected {0.5 * spacing * f}")
        if "FluidBlocks" in rest or rest["FluidModels"][0]["particleFile"] != os.path.abspath(pda):
            failures.append("rest mode: the fluid is not the particle file")
        # The block's lattice (SPlisHSPlasH's points start at min + d) and the file's points agree.
        lo = [min(p[a] for p in points) for a in range(3)]
        start = [block["FluidBlocks"][0]["start"][a] + spacing for a in range(3)]
        if max(abs(lo[a] - start[a]) for a in range(3)) > 1e-9:
            failures.append(f"rest mode: lowest point {lo}, the block's first point {start}")
    return failures


def main():
    if "--self-test" in sys.argv[1:]:
        scene = os.path.join(REPO, "config", "bench_dam_break.yaml")
        failures = self_test(scene)
        for f in failures:
            print("FAIL: " + f)
        print("yardstick self-test: " + ("failed" if failures else "passed"))
        sys.exit(1 if failures else 0)
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bench", default=os.path.join(REPO, "build", "fluid_sim_bench"), help="our fluid_sim_bench")
    p.add_argument("--scene", default=os.path.join(REPO, "config", "bench_dam_break.yaml"), help="our scene")
    p.add_argument("--sph-bin", required=True, help="SPlisHSPlasH's bin/SPHSimulator")
    p.add_argument("--sph-scene-dir", required=True,
                   help="SPlisHSPlasH's data/Scenes (its box mesh is ../models/UnitBox.obj)")
    p.add_argument("--sph-bin-cold",
                   help="a second SPHSimulator built with its DFSPH warm start compiled out (USE_WARMSTART, "
                        "USE_WARMSTART_V undefined): run after the first in every round, our cold rows "
                        "compared with it")
    p.add_argument("--sph-env", action="append", default=[],
                   help="KEY=VALUE for SPlisHSPlasH's environment, repeatable (e.g. OMP_WAIT_POLICY=PASSIVE)")
    p.add_argument("--case", action="append", default=[],
                   help="SPACING:STEPS[:ROUNDS], repeatable (default 0.031:300, i.e. 32,768 fluid over 0.3 s)")
    p.add_argument("--methods", nargs="+", default=["all"], help="our boundary pressure methods (default all)")
    p.add_argument("--rounds", type=int, default=2, help="rounds per case unless the case gives its own")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--target", type=float, default=0.25, help="ours/theirs per particle-step to meet")
    p.add_argument("--out", help="directory for the scenes, logs and JSON (default: a temporary one)")
    p.add_argument("--cold-start", choices=["zero", "jacobi"], default="zero",
                   help="our cold rows' solver.cold_start (default zero, the paper's start and the scene "
                        "default; jacobi: the Jacobi first guess, Eq. A10a)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="scene override for our runs, cold and warm (repeatable), e.g. solver.chebyshev_rho=0.95")
    p.add_argument("--sph-fluid", choices=["block", "rest"], default="block",
                   help="SPlisHSPlasH's water: 'block' (default, the issue's setup: a FluidBlock on our "
                        "lattice, starting at 0.8 of its rest density) or 'rest' (the same particles at its "
                        "rest density, diameter 1.0758 spacings)")
    p.add_argument("--self-test", action="store_true",
                   help="check the scene translation (no SPlisHSPlasH needed) and stop")
    p.add_argument("--scenes-only", action="store_true", help="write the SPlisHSPlasH scenes and stop")
    args = p.parse_args()
    args.bench = os.path.abspath(args.bench)
    args.scene = os.path.abspath(args.scene)
    args.sph_bin = os.path.abspath(args.sph_bin)
    if args.sph_bin_cold:
        args.sph_bin_cold = os.path.abspath(args.sph_bin_cold)
    cases = []
    for c in args.case or ["0.031:300"]:
        parts = c.split(":")
        cases.append((float(parts[0]), int(parts[1]), int(parts[2]) if len(parts) > 2 else args.rounds))

    unit_box = os.path.abspath(os.path.join(args.sph_scene_dir, "..", "models", "UnitBox.obj"))
    if not os.path.isfile(unit_box):
        raise SystemExit(f"yardstick: no {unit_box}")
    workdir = os.path.abspath(args.out) if args.out else tempfile.mkdtemp(prefix="yardstick_")
    os.makedirs(workdir, exist_ok=True)
    with open(args.scene) as f:
        our_scene = yaml.safe_load(f)
    dt = float(our_scene["time_step"]["fixed"])

    scene_paths = {}
    for spacing, _, _ in cases:
        suffix = "" if args.sph_fluid == "block" else "_rest"
        path = os.path.join(workdir, f"sph_dam_break_{spacing}{suffix}.json")
        scene, n = sph_scene(our_scene, spacing, unit_box, args.sph_fluid,
                             os.path.join(workdir, f"sph_fluid_{spacing}.pda"))
        with open(path, "w") as f:
            json.dump(scene, f, indent=2)
        scene_paths[spacing] = path
        radius = scene["Configuration"]["particleRadius"]
        print(f"scene {path}: particle radius {radius:.6g} m, {n:,} fluid particles expected, its fluid "
              + ("a block at 0.8 of its rest density (particle volume 0.8 d^3)" if args.sph_fluid == "block"
                 else "our lattice at its rest density (kernel support 2.15 spacings)"))
    if args.scenes_only:
        return

    print(f"workdir {workdir}; {args.threads} threads each; load average at start {load_average()}")
    if args.sph_env:
        print("SPlisHSPlasH's extra environment: " + " ".join(args.sph_env))
    if args.sph_bin_cold:
        print(f"SPlisHSPlasH warm ({args.sph_bin}) and with its warm start compiled out ({args.sph_bin_cold}): "
              "our cold rows against its cold run, our warm rows against its warm run.\n")
    else:
        print("SPlisHSPlasH's DFSPH always warm-starts both solves; its row is compared with our cold and warm "
              "rows.\n")
    results = []
    t0 = time.monotonic()
    for spacing, steps, rounds in cases:
        case = {"spacing": spacing, "steps": steps, "rounds": [], "load": []}
        for rnd in range(1, rounds + 1):
            tag = f"{spacing}_{rnd}"
            rows = run_ours(args, spacing, steps, False, workdir, tag + "_cold")
            rows += run_ours(args, spacing, steps, True, workdir, tag + "_warm")
            rows += run_theirs(args, scene_paths[spacing], steps, dt, workdir, tag)
            if args.sph_bin_cold:
                rows += run_theirs(args, scene_paths[spacing], steps, dt, workdir, tag + "_cold", args.sph_bin_cold,
                                   THEIRS_COLD)
            case["rounds"].append(rows)
            case["load"].append(load_average())
            print(f"  spacing {spacing} round {rnd} done after {time.monotonic() - t0:.0f} s, "
                  f"load average {case['load'][-1]}", flush=True)
        results.append(case)

    print(f"\nload average at the end {load_average()}\n")
    print_table(results)
    print_summary(results, args.target)
    with open(os.path.join(workdir, "yardstick.json"), "w") as f:
        json.dump(results, f, indent=1)
    print(f"\nrows as JSON: {os.path.join(workdir, 'yardstick.json')}")


if __name__ == "__main__":
    main()
