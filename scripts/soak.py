#!/usr/bin/env python3
"""Soak test of the fluid_sim node: the demo for a long time, with faults.

Runs the ROS demo (config/demo_scene.yaml: the paddle robot stirring water, posed through tf) on
a master of its own, and at random moments (seeded) injects the faults a robot's launch sees:

  tf          robot_state_publisher (the tf publisher) killed, restarted 2-10 s later
  master      the ROS master killed and started again 2-8 s later (with its parameters set
              again; the robot's nodes, which do not register again by themselves, restarted)
  pause       pause, a few single steps, resume (services pause and step)
  reset       reset (service)

The node itself is started once and must live through all of it. Every 10 s the script records
the node's memory (resident set), open file descriptors and threads, and from its stats topic
the particle count, step wall time, real-time factor, iterations and status; it keeps the node's
log and counts every warning and error by kind. It ends with a verdict (exit 0 = pass):

  - the node ran to the end (same process, never restarted);
  - after every fault its stats came back within --resume-limit s (new simulated time);
  - after every master restart a fresh subscriber got its stats and a service call got answered
    (the node registered again), within --resume-limit s;
  - no error or fatal line, no status but ok (or waiting_for_tf while the robot's tf is down),
    the particle count changed only at a reset;
  - memory and file descriptors did not grow over the second half (resident set by at most
    10 % + 20 MB over its value at half time, descriptors by at most 8).

Writes DIR/report.md (the summary and the verdict), DIR/samples.csv, DIR/events.csv and
DIR/node.log.

  PYENV_VERSION=system python3 scripts/soak.py --duration 3600 --out out/soak   # the hour
  PYENV_VERSION=system python3 scripts/soak.py --duration 120 --event-period 12  # ctest's version

Needs the build (build/devel/setup.bash sourced, as scripts/ros_env.sh and ctest do).
"""
import argparse
import collections
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time

import rosgraph.masterapi
import rospy
from fluid_msgs.msg import SolverStats
from fluid_msgs.srv import StepSimulation
from std_srvs.srv import SetBool, Trigger

from free_port import free_port  # this folder: a master port outside the kernel's ephemeral range

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE = "/fluid_sim"

# The demo's robot (launch/demo.launch): parameters and the nodes that pose it through tf.
DEMO_MOTION_PARAMS = {
    "joints": ["turn", "tilt"],
    "velocities": [1.5, 0.0],
    "offsets": [0.0, -0.35],
    "amplitudes": [0.0, 0.1],
    "frequencies": [0.0, 0.3],
}


# Stats that say "waiting_for_tf" are expected while the robot's tf is down and for this many
# seconds after it is back (s).
TF_GRACE = 5.0
WAITING_WHILE_TF_DOWN = "waiting_for_tf (while tf was down)"


def libexec(exe):
    """The built executable of this package (devel space), not a stale copy elsewhere under it."""
    dirs = subprocess.run(["catkin_find", "--libexec", "fluid_sim"], stdout=subprocess.PIPE,
                          universal_newlines=True).stdout.split()
    for d in dirs:
        if os.access(os.path.join(d, exe), os.X_OK):
            return os.path.join(d, exe)
    raise RuntimeError("%s not found (is build/devel/setup.bash sourced?)" % exe)


class Proc:
    """A child process in its own process group, its output appended to a log file."""

    def __init__(self, name, args, log_path, env=None):
        self.name = name
        self.log = open(log_path, "ab")
        self.p = subprocess.Popen(args, stdout=self.log, stderr=subprocess.STDOUT, env=env, start_new_session=True)

    def alive(self):
        return self.p.poll() is None

    def stop(self, sig=signal.SIGINT, wait=15.0):
        if self.alive():
            try:
                os.killpg(self.p.pid, sig)
            except ProcessLookupError:
                pass
            try:
                self.p.wait(wait)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, signal.SIGKILL)
                self.p.wait()
        self.log.close()
        return self.p.returncode


class Soak:
    def __init__(self, args):
        self.args = args
        self.rng = random.Random(args.seed)
        self.out = args.out
        os.makedirs(self.out, exist_ok=True)
        for name in ("node.log", "master.log", "robot.log", "report.md", "samples.csv", "events.csv"):
            if os.path.exists(os.path.join(self.out, name)):
                os.remove(os.path.join(self.out, name))
        self.port = free_port()
        self.env = dict(os.environ)
        host = os.environ.get("ROS_HOSTNAME") or os.environ.get("ROS_IP") or "localhost"
        self.env["ROS_MASTER_URI"] = "http://%s:%d" % (host, self.port)
        os.environ["ROS_MASTER_URI"] = self.env["ROS_MASTER_URI"]
        self.procs = {}
        self.lock = threading.Lock()
        self.last_stats = None  # (wall time, SolverStats)
        self.stats_count = 0
        self.statuses = collections.Counter()
        self.tf_gone = False  # the robot's tf publisher is stopped (a fault)
        self.tf_back = 0.0  # wall time it was last started
        self.particle_counts = collections.Counter()
        self.count = None  # the particle count since the start or the last reset
        self.last_reset = 0.0  # wall time the last reset was asked for
        self.count_changes = []  # (s since start, old, new) outside a reset
        self.step_ms = []
        self.samples = []  # dicts
        self.events = []  # dicts
        self.failures = []
        self.t0 = time.time()
        self.epoch = float(int(self.t0))  # s, ROS (wall) time of the motion's t = 0

    # ------------------------------------------------------------------ processes
    def log_path(self, name):
        return os.path.join(self.out, name + ".log")

    def start_master(self):
        self.procs["master"] = Proc("master", ["roscore", "-p", str(self.port)], self.log_path("master"), self.env)
        master = rosgraph.masterapi.Master("/soak")
        deadline = time.time() + 60
        while time.time() < deadline:
            try:
                master.getPid()
                break
            except Exception:
                time.sleep(0.2)
        else:
            raise RuntimeError("roscore did not come up on port %d" % self.port)
        # The parameters the robot's nodes read at their start (a restarted master has none).
        with open(os.path.join(ROOT, "urdf", "paddle_robot.urdf")) as f:
            master.setParam("/robot_description", f.read())
        # The robot moves at the demo's speeds times the real-time factor, so that the water
        # (whose time runs at that factor) sees the demo's motion whatever the factor.
        f = self.args.real_time_factor if self.args.real_time_factor > 0 else 1.0
        for k, v in DEMO_MOTION_PARAMS.items():
            master.setParam("/demo_motion/" + k, [x * f for x in v] if k in ("velocities", "frequencies") else v)
        # One time line for every demo_motion started: a restarted one carries on the motion.
        master.setParam("/demo_motion/epoch", self.epoch)
        master.setParam("/robot_state_publisher/publish_frequency", 100.0)

    def start_robot(self, which=("static", "motion", "rsp")):
        if "static" in which:
            self.procs["static"] = Proc(
                "static",
                ["rosrun", "tf2_ros", "static_transform_publisher", "0.3", "0.2", "0.45", "0", "0", "0", "world", "base",
                 "__name:=world_to_base"],
                self.log_path("robot"), self.env)
        if "motion" in which:
            self.procs["motion"] = Proc("motion", [libexec("fluid_sim_demo_motion"), "__name:=demo_motion"],
                                        self.log_path("robot"), self.env)
        if "rsp" in which:
            self.procs["rsp"] = Proc("rsp", ["rosrun", "robot_state_publisher", "robot_state_publisher",
                                             "__name:=robot_state_publisher"], self.log_path("robot"), self.env)
            with self.lock:
                self.tf_gone = False
                self.tf_back = time.time()

    def stop_robot(self, which=("static", "motion", "rsp")):
        if "rsp" in which:
            with self.lock:
                self.tf_gone = True
        for k in which:
            if k in self.procs:
                self.procs.pop(k).stop()

    def start_node(self):
        # As launch/fluid_sim.launch starts it: /fluid_sim/fluid_sim, topics and services in /fluid_sim.
        args = [libexec("fluid_sim_node"), "__name:=fluid_sim", "__ns:=/fluid_sim",
                "_scene_file:=" + os.path.join(ROOT, "config", "demo_scene.yaml"),
                "_real_time_factor:=%g" % self.args.real_time_factor]
        if self.args.spacing:
            args.append("_spacing:=%g" % self.args.spacing)
        self.procs["node"] = Proc("node", args, os.path.join(self.out, "node.log"), self.env)

    def node_pid(self):
        """The node's own pid (the child itself)."""
        return self.procs["node"].p.pid

    # ------------------------------------------------------------------ observation
    def on_stats(self, msg):
        with self.lock:
            self.last_stats = (time.time(), msg)
            self.stats_count += 1
            # Stats while a step waits for tf (at most one a second) are expected while the
            # robot's tf is down and until the node has its poses again.
            status = msg.status.split(":")[0]
            if status == "waiting_for_tf" and (self.tf_gone or time.time() - self.tf_back < TF_GRACE):
                status = WAITING_WHILE_TF_DOWN
            self.statuses[status] += 1
            self.particle_counts[msg.fluid_particles] += 1
            # A reset builds the scene again around the links' current poses, which may cut a
            # different number of particles; at any other time the count must not change.
            if self.count is not None and msg.fluid_particles != self.count and time.time() - self.last_reset > 5.0:
                self.count_changes.append((time.time() - self.t0, self.count, msg.fluid_particles))
            self.count = msg.fluid_particles
            if not msg.paused:
                self.step_ms.append(1000.0 * msg.step_wall_time)

    def sample(self):
        pid = self.node_pid()
        row = {"t": time.time() - self.t0, "rss_mb": float("nan"), "fds": -1, "threads": -1}
        try:
            with open("/proc/%d/status" % pid) as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        row["rss_mb"] = int(line.split()[1]) / 1024.0
                    elif line.startswith("Threads:"):
                        row["threads"] = int(line.split()[1])
            row["fds"] = len(os.listdir("/proc/%d/fd" % pid))
        except OSError:
            pass
        with self.lock:
            s = self.last_stats[1] if self.last_stats else None
            recent = self.step_ms[-300:]
        row["sim_time"] = s.sim_time if s else float("nan")
        row["particles"] = s.fluid_particles if s else -1
        row["status"] = s.status if s else ""
        row["rtf"] = s.real_time_factor if s else float("nan")
        row["iterations"] = (s.density_iterations + s.divergence_iterations) if s else -1
        row["step_ms_mean"] = sum(recent) / len(recent) if recent else float("nan")
        row["step_ms_max"] = max(recent) if recent else float("nan")
        self.samples.append(row)

    def wait_stats_after(self, wall, limit):
        """Seconds until a stats message arrives, received after `wall` and not paused, or None."""
        deadline = time.time() + limit
        while time.time() < deadline:
            with self.lock:
                if self.last_stats and self.last_stats[0] > wall and not self.last_stats[1].paused:
                    return time.time() - wall
            time.sleep(0.1)
        return None

    def fresh_subscriber_ok(self, limit):
        """A new process (registered with the current master) must get the node's stats."""
        deadline = time.time() + limit
        while time.time() < deadline:
            r = subprocess.run(["rostopic", "echo", "-n", "1", NODE + "/stats/sim_time"], env=self.env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=limit + 5)
            if r.returncode == 0 and re.search(rb"\d", r.stdout):
                return True
            time.sleep(1.0)
        return False

    def call(self, name, srv_type, *req):
        rospy.wait_for_service(NODE + "/" + name, timeout=self.args.resume_limit)
        return rospy.ServiceProxy(NODE + "/" + name, srv_type)(*req)

    # ------------------------------------------------------------------ faults
    def event(self, kind):
        start = time.time()
        detail = ""
        ok = True
        try:
            if kind == "tf":
                self.stop_robot(("rsp",))
                gap = self.rng.uniform(2, 10)
                time.sleep(gap)
                self.start_robot(("rsp",))
                detail = "robot_state_publisher down %.1f s" % gap
            elif kind == "master":
                self.procs.pop("master").stop()
                self.stop_robot()
                gap = self.rng.uniform(2, 8)
                time.sleep(gap)
                self.start_master()
                self.start_robot()
                detail = "master down %.1f s" % gap
                if not self.fresh_subscriber_ok(self.args.resume_limit):
                    ok = False
                    detail += "; no fresh subscriber got the stats"
                else:
                    r = self.call("pause", SetBool, False)
                    if not r.success:
                        ok = False
                        detail += "; pause(false) not answered with success"
                    else:
                        detail += "; fresh subscriber and service call ok"
            elif kind == "pause":
                r = self.call("pause", SetBool, True)
                ok = ok and r.success
                n = self.rng.randint(1, 5)
                for _ in range(n):
                    s = self.call("step", StepSimulation, 1)
                    ok = ok and s.success
                time.sleep(self.rng.uniform(0.5, 3))
                r = self.call("pause", SetBool, False)
                ok = ok and r.success
                detail = "paused, %d steps, resumed" % n
            elif kind == "reset":
                self.last_reset = time.time()
                r = self.call("reset", Trigger)
                ok = r.success
                detail = "reset: " + r.message
        except Exception as e:  # a service that does not answer is a failure, not a crash
            ok = False
            detail += " exception: %s" % e
        resumed = self.wait_stats_after(time.time(), self.args.resume_limit)
        if resumed is None:
            ok = False
            detail += "; no stats within %g s after" % self.args.resume_limit
        row = {"t": start - self.t0, "kind": kind, "seconds": time.time() - start,
               "resumed_s": resumed if resumed is not None else float("nan"), "ok": ok, "detail": detail}
        self.events.append(row)
        print("[soak] %7.1f s  %-6s %s  %s" % (row["t"], kind, "ok" if ok else "FAILED", detail), flush=True)
        if not ok:
            self.failures.append("%s at %.0f s: %s" % (kind, row["t"], detail))

    # ------------------------------------------------------------------ run
    def run(self):
        a = self.args
        self.start_master()
        self.start_robot()
        self.start_node()
        rospy.init_node("soak", anonymous=True, disable_signals=True)
        rospy.Subscriber(NODE + "/stats", SolverStats, self.on_stats, queue_size=50)
        if self.wait_stats_after(0, a.start_limit) is None:
            self.failures.append("no stats from the node within %g s of its start" % a.start_limit)
            return
        print("[soak] node up after %.1f s; running %g s" % (time.time() - self.t0, a.duration), flush=True)
        kinds = ["tf", "master", "pause", "reset"]
        # Every kind once first (in random order), then at random.
        plan = kinds[:]
        self.rng.shuffle(plan)
        end = self.t0 + a.duration
        next_sample = time.time()
        next_event = time.time() + self.rng.uniform(0.5, 1.5) * a.event_period
        while time.time() < end:
            if not self.procs["node"].alive():
                self.failures.append("the node exited with code %s at %.0f s" %
                                     (self.procs["node"].p.returncode, time.time() - self.t0))
                break
            if time.time() >= next_sample:
                self.sample()
                next_sample += 10.0
            if time.time() >= next_event and time.time() < end - a.event_period / 2:
                kind = plan.pop(0) if plan else self.rng.choice(kinds)
                self.event(kind)
                next_event = time.time() + self.rng.uniform(0.5, 1.5) * a.event_period
            time.sleep(0.2)
        self.sample()

    def shutdown(self):
        node_code = None
        if "node" in self.procs:
            p = self.procs.pop("node")
            p.stop(signal.SIGINT, wait=30)
            node_code = p.p.returncode
        self.stop_robot()
        if "master" in self.procs:
            self.procs.pop("master").stop()
        rospy.signal_shutdown("soak done")
        return node_code

    # ------------------------------------------------------------------ verdict
    def verdict(self, node_code):
        a = self.args
        log = open(os.path.join(self.out, "node.log"), errors="replace").read()
        levels = collections.Counter()
        kinds = collections.Counter()
        for line in log.splitlines():
            m = re.search(r"\[ ?(WARN|ERROR|FATAL)\] \[[\d.]+\]: (.*)", line)
            if not m:
                continue
            levels[m.group(1)] += 1
            # A kind: the message with its numbers taken out.
            kinds[(m.group(1), re.sub(r"-?\d+(\.\d+)?(e[-+]?\d+)?", "#", m.group(2))[:150])] += 1
        fails = list(self.failures)
        if levels["ERROR"] or levels["FATAL"]:
            fails.append("%d error and %d fatal lines in the node's log" % (levels["ERROR"], levels["FATAL"]))
        bad_status = {k: v for k, v in self.statuses.items() if k not in ("ok", WAITING_WHILE_TF_DOWN)}
        if bad_status:
            fails.append("statuses other than ok: %s" % dict(bad_status))
        if self.count_changes:
            fails.append("the particle count changed outside a reset: %s" %
                         ", ".join("%d -> %d at %.0f s" % (o, n, t) for t, o, n in self.count_changes[:5]))
        if node_code not in (0, None):
            fails.append("the node ended with exit code %s at the soak's SIGINT" % node_code)
        half = [s for s in self.samples if s["t"] >= a.duration / 2]
        growth = ""
        if half and self.samples:
            first, last = half[0], self.samples[-1]
            rss_limit = first["rss_mb"] * 1.10 + 20.0
            if last["rss_mb"] > rss_limit:
                fails.append("resident memory grew over the second half: %.1f -> %.1f MB" % (first["rss_mb"],
                                                                                             last["rss_mb"]))
            if last["fds"] > first["fds"] + 8:
                fails.append("file descriptors grew over the second half: %d -> %d" % (first["fds"], last["fds"]))
            growth = "%.1f -> %.1f MB, descriptors %d -> %d, threads %d -> %d" % (
                first["rss_mb"], last["rss_mb"], first["fds"], last["fds"], first["threads"], last["threads"])

        with open(os.path.join(self.out, "samples.csv"), "w") as f:
            keys = ["t", "rss_mb", "fds", "threads", "sim_time", "particles", "status", "rtf", "iterations",
                    "step_ms_mean", "step_ms_max"]
            f.write(",".join(keys) + "\n")
            for s in self.samples:
                f.write(",".join(str(s[k]) for k in keys) + "\n")
        with open(os.path.join(self.out, "events.csv"), "w") as f:
            keys = ["t", "kind", "seconds", "resumed_s", "ok", "detail"]
            f.write(",".join(keys) + "\n")
            for e in self.events:
                f.write(",".join('"%s"' % e[k] if k == "detail" else str(e[k]) for k in keys) + "\n")

        steps = sorted(self.step_ms)
        pct = (lambda q: steps[min(len(steps) - 1, int(q * len(steps)))]) if steps else (lambda q: float("nan"))
        by_kind = collections.Counter(e["kind"] for e in self.events)
        resumed = [e["resumed_s"] for e in self.events if e["resumed_s"] == e["resumed_s"]]
        lines = [
            "# Soak report",
            "",
            "- wall time %.0f s (asked %g s), seed %d, real_time_factor %g, spacing %s, event period %g s" %
            (time.time() - self.t0, a.duration, a.seed, a.real_time_factor,
             "%g m" % a.spacing if a.spacing else "the scene's", a.event_period),
            "- faults: %s; stats back after each within %.1f s at most (median %.1f s)" %
            (", ".join("%s %d" % kv for kv in sorted(by_kind.items())), max(resumed) if resumed else float("nan"),
             sorted(resumed)[len(resumed) // 2] if resumed else float("nan")),
            "- stats messages %d; statuses %s; particle counts %s" %
            (self.stats_count, dict(self.statuses), dict(self.particle_counts)),
            "- step wall time (ms): median %.2f, 99th percentile %.2f, largest %.2f; final simulated time %.1f s" %
            (pct(0.5), pct(0.99), steps[-1] if steps else float("nan"),
             self.samples[-1]["sim_time"] if self.samples else float("nan")),
            "- memory over the second half: %s" % growth,
            "- node log: %d warnings, %d errors, %d fatal" % (levels["WARN"], levels["ERROR"], levels["FATAL"]),
            "",
            "Warnings and errors by kind (numbers replaced by #):",
            "",
        ]
        for (level, text), n in kinds.most_common():
            lines.append("- %s x%d: %s" % (level, n, text))
        lines += ["", "Verdict: " + ("PASS" if not fails else "FAIL")]
        lines += ["- " + f for f in fails]
        report = "\n".join(lines) + "\n"
        with open(os.path.join(self.out, "report.md"), "w") as f:
            f.write(report)
        print(report, flush=True)
        return not fails


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=3600.0, help="wall-clock seconds (default 3600)")
    ap.add_argument("--event-period", type=float, default=60.0, help="mean seconds between faults (default 60)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--real-time-factor", type=float, default=1.0,
                    help="the node's real_time_factor (default 1); the robot moves that much slower than in the "
                    "demo, so that the water sees the demo's motion")
    ap.add_argument("--spacing", type=float, default=0.0,
                    help="particle spacing in m (default: the demo scene's 0.02; 0.03 has 3x fewer particles)")
    ap.add_argument("--resume-limit", type=float, default=60.0,
                    help="seconds the node may take to publish again after a fault (default 60)")
    ap.add_argument("--start-limit", type=float, default=120.0, help="seconds the node may take to start")
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "soak"))
    args = ap.parse_args()
    soak = Soak(args)
    ok = False
    try:
        soak.run()
    finally:
        code = soak.shutdown()
        ok = soak.verdict(code)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
