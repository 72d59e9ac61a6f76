#!/usr/bin/env python3
"""ctest ros_master_restart_connected / ros_master_restart_startup (test/ros/master_restart.sh):
the node (tank_scene.yaml, paced) on a master of its own that is killed and started again.

  connected  a tf publisher that was already running (this process, rospy: it does not register
             again with the new master, as robot_state_publisher does not) keeps the node
             stepping after the restart: stats with status 'ok' and sim_time advancing. Until
             2026-12-05 the node's re-registration handed its /tf subscription only the
             publishers the new master knew, and roscpp dropped the link to this one: the node
             stalled with 'waiting_for_tf: tank'. Then another /tf publisher registers with the
             new master, whose update to the node lists only the publishers it knows: the node
             must keep this process's tf still.
  startup    the master restarts while the node waits for tf at start-up; a tf publisher started
             afterwards against the new master gets the node going. Until 2026-12-05 the node
             registered again only once it had started, so the new master never told it of the
             publisher and it waited on.

Exit code 0 if the scenario passed, 1 with a message if not.
"""
import argparse
import os
import sys
import threading
import time

import rosgraph.masterapi
import rospy
from fluid_msgs.msg import SolverStats
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The soak's process helpers: the built node, a free port, a child in its own process group.
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from soak import Proc, free_port, libexec  # noqa: E402

NODE = "/fluid_sim/fluid_sim"
STATS = "/fluid_sim/stats"
# Waits (s), times FLUID_SIM_TEST_TIME_SCALE (an instrumented node runs 10-30 times slower).
SCALE = int(os.environ.get("FLUID_SIM_TEST_TIME_SCALE", "1") or 1)


class Test:
    def __init__(self, out):
        self.out = out
        self.master = None
        self.procs = []
        self.lock = threading.Lock()
        self.stats = []  # (wall time, status, sim_time)
        self.node = None
        self.stop_tf = False
        self.master_api = rosgraph.masterapi.Master("/master_restart_test")

    def fail(self, why):
        print("master_restart: FAILED: %s" % why, flush=True)
        self.shutdown()
        for name in sorted(os.listdir(self.out)):
            print("----- %s" % name)
            with open(os.path.join(self.out, name), errors="replace") as f:
                print(f.read()[-6000:])
        sys.exit(1)

    def start_master(self):
        self.master = Proc("roscore", ["roscore", "-p", os.environ["ROS_MASTER_URI"].rsplit(":", 1)[1]],
                           os.path.join(self.out, "master.log"))
        deadline = time.time() + 60 * SCALE
        while time.time() < deadline:
            try:
                self.master_api.getPid()
                break
            except Exception:
                time.sleep(0.2)
        else:
            self.fail("roscore did not come up")
        with open(os.path.join(ROOT, "test", "ros", "test_robot.urdf")) as f:
            self.master_api.setParam("/robot_description", f.read())

    def restart_master(self):
        self.master.stop()
        time.sleep(1.0)
        self.start_master()
        print("master_restart: master restarted", flush=True)

    def start_node(self):
        self.node = Proc("node", [libexec("fluid_sim_node"), "__name:=fluid_sim", "__ns:=/fluid_sim",
                          "_scene_file:=" + os.path.join(ROOT, "test", "ros", "tank_scene.yaml"),
                          "_real_time_factor:=0.5"], os.path.join(self.out, "node.log"))
        self.procs.append(self.node)

    def expect_stepping_after(self, settle, failure):
        """Waits `settle` s, then 3 s (scaled) in which the node must go on stepping; fails with
        `failure` and what the stats said if it does not. Returns when the 3 s began."""
        time.sleep(settle)
        since = time.time()
        time.sleep(3.0 * SCALE)
        if not self.stepping_since(since):
            self.fail("%s: %s" % (failure, self.describe_stats(since)))
        return since

    def node_known(self):
        try:
            self.master_api.lookupNode(NODE)
            return True
        except Exception:
            return False

    def wait_for(self, what, pred, limit):
        deadline = time.time() + limit * SCALE
        while time.time() < deadline:
            if self.node.p.poll() is not None:
                self.fail("the node exited (code %s) while waiting for %s" % (self.node.p.returncode, what))
            if pred():
                return True
            time.sleep(0.1)
        return False

    def on_stats(self, msg):
        with self.lock:
            self.stats.append((time.time(), msg.status, msg.sim_time))

    def stepping_since(self, since):
        """Stats since `since` (wall time): the last says ok and sim_time advanced over them."""
        with self.lock:
            recent = [s for s in self.stats if s[0] >= since]
        return len(recent) >= 2 and recent[-1][1] == "ok" and recent[-1][2] > recent[0][2] + 0.2

    def describe_stats(self, since):
        with self.lock:
            recent = [s for s in self.stats if s[0] >= since]
        if not recent:
            return "no stats"
        return "%d stats, last status '%s', sim_time %.3f -> %.3f" % (len(recent), recent[-1][1], recent[0][2],
                                                                      recent[-1][2])

    def publish_tf(self):
        pub = rospy.Publisher("/tf", TFMessage, queue_size=10)
        while not self.stop_tf:
            t = TransformStamped()
            t.header.stamp = rospy.Time.now()
            t.header.frame_id = "world"
            t.child_frame_id = "tank"
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = 0.15, 0.075, 0.15
            t.transform.rotation.w = 1.0
            pub.publish(TFMessage([t]))
            time.sleep(0.02)

    def shutdown(self):
        self.stop_tf = True
        for p in reversed(self.procs):
            p.stop()
        self.procs = []
        if self.master:
            self.master.stop()
            self.master = None

    # ------------------------------------------------------------------ scenarios
    def connected(self):
        self.start_master()
        rospy.init_node("master_restart_test", disable_signals=True)
        self.stop_tf = False
        threading.Thread(target=self.publish_tf, daemon=True).start()
        rospy.Subscriber(STATS, SolverStats, self.on_stats)
        self.start_node()
        t0 = time.time()
        if not self.wait_for("the node to step", lambda: self.stepping_since(t0), 60):
            self.fail("the node did not step before the restart: %s" % self.describe_stats(t0))
        print("master_restart: the node steps: %s" % self.describe_stats(t0), flush=True)
        self.restart_master()
        if not self.wait_for("the node to register again", self.node_known, 10):
            self.fail("the node did not register with the new master")
        registered = time.time()
        print("master_restart: the node registered again", flush=True)
        # A second for the re-registration's publisherUpdate to take effect, then three more in
        # which the node must go on stepping on the old publisher's tf (a node without it stalls
        # and says 'waiting_for_tf: tank' after a second).
        self.expect_stepping_after(1.0, "after the master restart the node stopped stepping on the tf publisher "
                                        "that was already running")
        print("master_restart: after the restart: %s" % self.describe_stats(registered), flush=True)
        # Another /tf publisher registers with the new master, which tells the node of the /tf
        # publishers it knows (not this process): the node must keep this process's tf still.
        self.procs.append(
            Proc("other_tf", ["rostopic", "pub", "-r", "10", "/tf", "tf2_msgs/TFMessage",
                  "transforms: [{header: {frame_id: world}, child_frame_id: elsewhere, transform: {rotation: {w: 1}}}]"],
                 os.path.join(self.out, "other_tf.log")))

        def other_known():
            try:
                pubs = self.master_api.getSystemState()[0]
                return any(t == "/tf" and any(x.startswith("/rostopic") for x in n) for t, n in pubs)
            except Exception:
                return False

        if not self.wait_for("the other tf publisher to register", other_known, 20):
            self.fail("the other tf publisher did not register with the new master")
        # Its publisherUpdate, a check of the node's master watch (1 s) and tf2 catching up.
        since = self.expect_stepping_after(3.0, "after another tf publisher registered with the new master the node "
                                                "stopped stepping on the tf publisher that was already running")
        print("master_restart: after another tf publisher registered: %s" % self.describe_stats(since), flush=True)

    def startup(self):
        self.start_master()
        rospy.init_node("master_restart_test", disable_signals=True)
        self.stop_tf = True
        self.start_node()

        def waiting_for_tf():
            try:
                _, subs, _ = self.master_api.getSystemState()
            except Exception:
                return False
            return any(topic == "/tf" and NODE in nodes for topic, nodes in subs)

        if not self.wait_for("the node to subscribe to /tf", waiting_for_tf, 60):
            self.fail("the node did not subscribe to /tf")
        time.sleep(1.0)  # it is in its start-up wait for tf now
        self.restart_master()
        known = self.wait_for("the node to register again", self.node_known, 5)
        print("master_restart: the node %s registered with the new master" % ("has" if known else "has NOT"),
              flush=True)
        self.procs.append(
            Proc("tf", ["rosrun", "tf2_ros", "static_transform_publisher", "0.15", "0.075", "0.15", "0", "0", "0", "world",
                  "tank", "__name:=world_to_tank"], os.path.join(self.out, "tf.log")))
        # Registered with the new master (this process's first registration with it), so it hears
        # of the node's stats when the node advertises them.
        rospy.Subscriber(STATS, SolverStats, self.on_stats)
        t0 = time.time()
        if not self.wait_for("the node to start", lambda: self.stepping_since(t0), 30):
            self.fail("the node did not start on the tf publisher started after the master restart: %s" %
                      self.describe_stats(t0))
        print("master_restart: the node started: %s" % self.describe_stats(t0), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario", choices=["connected", "startup"])
    ap.add_argument("--out", required=True, help="folder for the logs")
    args = ap.parse_args()
    os.environ["ROS_MASTER_URI"] = "http://%s:%d" % (
        os.environ.get("ROS_HOSTNAME") or os.environ.get("ROS_IP") or "localhost", free_port())
    test = Test(args.out)
    try:
        getattr(test, args.scenario)()
    except SystemExit:
        raise
    except BaseException as e:  # noqa: B902 -- any error fails the test with the logs
        test.fail("%s: %s" % (type(e).__name__, e))
    code = test.node.stop() if test.node else None
    test.shutdown()
    if code != 0:
        test.fail("the node exited with code %s on SIGINT (expected 0)" % code)
    print("master_restart: %s: ok" % args.scenario, flush=True)


if __name__ == "__main__":
    main()
