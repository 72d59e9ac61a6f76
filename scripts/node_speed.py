#!/usr/bin/env python3
"""How fast the fluid_sim node runs a robot scene while it publishes, as a user sees it.

Runs the ROS demo (launch/demo.launch: the paddle robot posed through tf, its scene
config/demo_scene.yaml, or --scene) on a master of its own, with a subscriber to the fluid
cloud (`/fluid_sim/particles`, as rviz subscribes: without one roscpp does not serialise the
clouds, and their cost would be missing) and to `/fluid_sim/stats`. After --warmup s of wall
time it measures over --seconds s:

  rtf          simulated s per wall s (from the stats' sim_time). The node is paced at the factor
               asked for (--real-time-factor F, default 1 as in the demo) and the robot moves
               F times as fast (the demo's motion_speed:=F), so the water sees the demo's motion
               at any F: the rtf reached is min(F, what the node can do). F = 1 and rtf 1.00:
               it keeps up with the robot; a larger F measures the margin (the capacity when it
               falls behind). Not factor 0 ("as fast as it can"): a scene posed from tf cannot
               run ahead of its tf, so after the start's catch-up it waits for the robot
  behind       the node's "cannot keep up" warnings in the run's log (paced runs; throttled to one per 10 s)
  clouds/s     fluid clouds received per wall s (the node publishes at publish_rate, 30 Hz)
  cpu          the node's CPU time per wall s, in cores (2 = both cores of this machine)
  it/step      density and divergence iterations per step (stats samples)

One row per --spacing (the scene's spacing changed, nothing else; default: the scene's own). The
changed copy is written to --out-dir, so file names in such a scene must not be relative.

  PYENV_VERSION=system /usr/bin/python3 scripts/node_speed.py                    # the demo, paced
  PYENV_VERSION=system /usr/bin/python3 scripts/node_speed.py --real-time-factor 3 \\
      --spacing 0.02 --spacing 0.015 --spacing 0.011 --json out/node_speed.json     # capacities

Needs the build (build/devel/setup.bash sourced, as scripts/ros_env.sh does) and a free port.
Prints the rows; exits 1 when a run did not start, published no stats or no cloud, or its status
was not ok. ctest runs a short version (`ros_node_speed`, test/ros/node_speed_smoke.sh).
"""
import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

import rospy
from fluid_msgs.msg import SolverStats
from sensor_msgs.msg import PointCloud2

from free_port import free_port  # this folder: a master port outside the kernel's ephemeral range

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def scene_with_spacing(scene, spacing, folder):
    """A copy of the scene file with its top-level `spacing:` key replaced (its other lines as they are)."""
    with open(scene) as f:
        text = f.read()
    new, count = re.subn(r"^spacing:[^\n#]*", "spacing: %r " % spacing, text, count=1, flags=re.M)
    if count != 1:
        raise SystemExit("%s: no top-level 'spacing:' key to change" % scene)
    path = os.path.join(folder, "scene_%g.yaml" % spacing)
    with open(path, "w") as f:
        f.write(new)
    return path


def node_cpu_seconds(pid):
    """utime + stime of a process (s), from /proc/PID/stat."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def find_node_pid(launch_pid):
    """The fluid_sim_node process started by the launch (a descendant of it), from /proc."""
    parent = {}
    nodes = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % entry) as f:
                parent[int(entry)] = int(f.read().rsplit(")", 1)[1].split()[1])
            with open("/proc/%s/cmdline" % entry, "rb") as f:
                argv0 = f.read().split(b"\0")[0]
        except (OSError, IndexError, ValueError):
            continue  # ended meanwhile
        if os.path.basename(argv0) == b"fluid_sim_node":
            nodes.append(int(entry))
    for pid in nodes:
        q = pid
        while q in parent and q > 1:  # up to the launch
            q = parent[q]
            if q == launch_pid:
                return pid
    raise SystemExit("no fluid_sim_node process under the launch (pid %d)" % launch_pid)


class Recorder:
    """Stats and cloud arrivals, timestamped with the wall clock."""

    def __init__(self):
        self.lock = threading.Lock()
        self.stats = []  # (wall s, SolverStats)
        self.clouds = []  # wall s

    def on_stats(self, msg):
        with self.lock:
            self.stats.append((time.monotonic(), msg))

    def on_cloud(self, _msg):
        with self.lock:
            self.clouds.append(time.monotonic())


def last_error(log):
    """The launch log's last error line (the node's FATAL or ERROR: why it did not start), as
    '; last error: ...', or ''."""
    log.flush()
    try:
        with open(log.name, errors="replace") as f:
            lines = [l.strip() for l in f if "FATAL" in l or "ERROR" in l or "error:" in l]
    except OSError:
        return ""
    return "; last error: %s" % lines[-1][:400] if lines else ""


def on_sigterm(signum, frame):
    """SIGTERM (e.g. from `timeout`) as an exit, so that the finally blocks stop the launch and
    its private master instead of leaving them running."""
    raise SystemExit(128 + signum)


def measure(args, scene, label):
    port = free_port()
    host = os.environ.get("ROS_HOSTNAME") or os.environ.get("ROS_IP") or "localhost"
    env = dict(os.environ, ROS_MASTER_URI="http://%s:%d" % (host, port))
    os.environ["ROS_MASTER_URI"] = env["ROS_MASTER_URI"]
    log = open(os.path.join(args.out_dir, "launch_%s.log" % label), "wb")
    cmd = ["roslaunch", "-p", str(port), "fluid_sim", "demo.launch", "scene:=" + scene,
           "real_time_factor:=%g" % args.real_time_factor, "motion_speed:=%g" % args.real_time_factor]
    launch = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    rec = Recorder()
    row = {"scene": scene, "label": label, "real_time_factor_asked": args.real_time_factor}
    try:
        deadline = time.monotonic() + args.start_timeout
        while True:  # the master first, then this process's node on it
            try:
                rospy.init_node("node_speed", anonymous=True, disable_signals=True)
                break
            except Exception:  # noqa: BLE001 (rospy raises several kinds while the master starts)
                if time.monotonic() > deadline or launch.poll() is not None:
                    raise SystemExit("%s: the launch did not start (see %s)" % (label, log.name))
                time.sleep(0.5)
        subs = [rospy.Subscriber("/fluid_sim/stats", SolverStats, rec.on_stats, queue_size=100),
                rospy.Subscriber("/fluid_sim/particles", PointCloud2, rec.on_cloud, queue_size=5,
                                 buff_size=1 << 24, tcp_nodelay=True)]
        while not rec.stats:
            if time.monotonic() > deadline or launch.poll() is not None:
                raise SystemExit("%s: no stats within %g s%s (see %s)"
                                 % (label, args.start_timeout, last_error(log), log.name))
            time.sleep(0.2)
        pid = find_node_pid(launch.pid)
        time.sleep(args.warmup)
        t0, cpu0 = time.monotonic(), node_cpu_seconds(pid)
        time.sleep(args.seconds)
        t1, cpu1 = time.monotonic(), node_cpu_seconds(pid)
        with rec.lock:
            window = [m for (w, m) in rec.stats if t0 <= w <= t1 and not m.paused]
            clouds = [w for w in rec.clouds if t0 <= w <= t1]
        for s in subs:
            s.unregister()
        if len(window) < 2:
            with rec.lock:
                last = rec.stats[-1][1]
            raise SystemExit("%s: fewer than 2 stats messages of steps in the window (last status '%s'%s)"
                             % (label, last.status, ", paused" if last.paused else ""))
        n = len(window)
        mean = lambda f: sum(f(m) for m in window) / n  # noqa: E731
        row.update({
            "fluid_particles": window[-1].fluid_particles,
            "rtf": (window[-1].sim_time - window[0].sim_time) / (t1 - t0),
            "dt_ms": 1e3 * mean(lambda m: m.time_step),
            "density_it": mean(lambda m: m.density_iterations),
            "divergence_it": mean(lambda m: m.divergence_iterations),
            "clouds_per_s": len(clouds) / (t1 - t0),
            "cpu_cores": (cpu1 - cpu0) / (t1 - t0),
            "stats_samples": n,
            "status": sorted({m.status for m in window}),
        })
    finally:
        log.flush()
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGINT)
            try:
                launch.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(launch.pid, signal.SIGKILL)
                launch.wait()
        log.close()
    with open(log.name, errors="replace") as f:
        row["behind_warnings"] = f.read().count("cannot keep up")
    rospy.signal_shutdown("next run")  # rospy allows one init per process: later runs need a fresh one
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=os.path.join(ROOT, "config", "demo_scene.yaml"))
    parser.add_argument("--spacing", type=float, action="append", default=[], help="m; repeatable")
    parser.add_argument("--real-time-factor", type=float, default=1.0,
                        help="the node's pacing (> 0); the robot moves this much faster too, so the "
                             "water sees the demo's motion")
    parser.add_argument("--warmup", type=float, default=10.0, help="wall s before measuring (the start, the fill)")
    parser.add_argument("--seconds", type=float, default=20.0, help="wall s measured")
    parser.add_argument("--start-timeout", type=float, default=120.0)
    parser.add_argument("--out-dir", default=None, help="launch logs (default: a temporary folder)")
    parser.add_argument("--json", help="also write the rows to this file")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: one run in this process
    args = parser.parse_args()
    signal.signal(signal.SIGTERM, on_sigterm)
    if not args.real_time_factor > 0:
        parser.error("--real-time-factor must be > 0 (a scene posed from tf cannot run ahead of its tf)")
    scene = os.path.abspath(args.scene)
    if args.one is not None:
        # A child run: rospy cannot init twice in one process, so each spacing gets its own.
        print(json.dumps(measure(args, args.one, os.path.basename(args.one))))
        return 0
    # Absolute: the scene written there is handed to the node, which resolves a relative path
    # against its own working folder (~/.ros), not this one.
    args.out_dir = os.path.abspath(args.out_dir or tempfile.mkdtemp(prefix="node_speed_"))
    os.makedirs(args.out_dir, exist_ok=True)
    scenes = [scene_with_spacing(scene, s, args.out_dir) for s in args.spacing] or [scene]
    rows, failed = [], False
    for sc in scenes:
        child = [sys.executable, os.path.abspath(__file__), "--one", sc, "--out-dir", args.out_dir,
                 "--real-time-factor", str(args.real_time_factor), "--warmup", str(args.warmup),
                 "--seconds", str(args.seconds), "--start-timeout", str(args.start_timeout)]
        proc = subprocess.Popen(child, stdout=subprocess.PIPE, universal_newlines=True)
        try:
            out, _ = proc.communicate()
        except BaseException:
            proc.terminate()  # the child's SIGTERM handler stops its launch
            proc.wait(60)
            raise
        if proc.returncode != 0 or not out.strip():
            print("%s: run failed (exit %d; logs in %s)" % (sc, proc.returncode, args.out_dir), file=sys.stderr)
            failed = True
            continue
        row = json.loads(out.strip().splitlines()[-1])
        if row["status"] != ["ok"] or row["clouds_per_s"] == 0:
            # No cloud received: the figures would miss the publishing they are meant to include.
            print("%s: status %s, %.1f clouds/s" % (sc, ",".join(row["status"]), row["clouds_per_s"]), file=sys.stderr)
            failed = True
        rows.append(row)
    print("real_time_factor asked %g; %g s measured after %g s; logs in %s" %
          (args.real_time_factor, args.seconds, args.warmup, args.out_dir))
    print("%-22s %8s %7s %7s %8s %8s %9s %6s %7s  %s" % (
        "scene", "fluid", "rtf", "dt_ms", "dens_it", "div_it", "clouds/s", "cpu", "behind", "status"))
    for r in rows:
        print("%-22s %8d %7.3f %7.2f %8.2f %8.2f %9.1f %6.2f %7d  %s" % (
            r["label"], r["fluid_particles"], r["rtf"], r["dt_ms"], r["density_it"], r["divergence_it"],
            r["clouds_per_s"], r["cpu_cores"], r["behind_warnings"], ",".join(r["status"])))
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, "w") as f:
            json.dump({"real_time_factor": args.real_time_factor, "warmup_s": args.warmup,
                       "seconds": args.seconds, "rows": rows}, f, indent=1)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
