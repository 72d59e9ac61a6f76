#!/usr/bin/env python3
"""Runs a launch file as roslaunch does, and ends it when one of its nodes has ended.

  /usr/bin/python3 scripts/run_launch.py --until /fluid_sim/fluid_sim [-p PORT] \\
      fluid_sim demo.launch headless:=true required:=false duration:=5

Why: roslaunch ends a launch when a node marked required="true" exits, but always with a red
"REQUIRED process [...] has died!" banner, also after a node that finished its work and exited
0 (the headless demo's normal end), and roslaunch itself then exits 0 whatever the node's exit
code was. This runs the same launch through roslaunch's own Python API (the same output, the
same master: an existing one at ROS_MASTER_URI, else one started on PORT or 11311) and

  - when the node named by --until (its full name) exits, shuts the launch down the ordinary
    way (SIGINT to the other nodes, no banner) and exits with the node's exit code;
  - when any other process dies with a non-zero exit code (roslaunch prints which and its exit
    code), ends the launch and exits 1 (the run cannot end normally without it);
  - on Ctrl-C (SIGINT, SIGTERM), shuts down as roslaunch does and exits 0, or with the node's
    exit code if it had already ended.

The node must not be required="true" in the launch (that would print the banner again): the
demo's launch files take required:=false.
"""

import argparse
import sys
import threading
import time

import roslaunch
import roslaunch.parent
import roslaunch.pmon
import roslaunch.rlutil


class NodeWatch(roslaunch.pmon.ProcessListener):
    """Told by roslaunch's process monitor (its own thread) about every process that ends."""

    def __init__(self, node):
        self.node = node.strip("/")
        self.ended = threading.Event()
        self.exit_code = None  # of the watched node, once it has ended
        self.failure = None  # "<process> exited with code N" for another process

    def process_died(self, process_name, exit_code):
        # roslaunch names a node's process "<namespace>/<name>-<counter>" without a leading '/'.
        name = process_name.rsplit("-", 1)[0]
        if name == self.node:
            # None: the monitor could not read the exit code; count it as a failure.
            self.exit_code = 1 if exit_code is None else exit_code
            self.ended.set()
        elif exit_code:
            self.failure = "%s exited with code %s" % (process_name, exit_code)
            self.ended.set()


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--until", required=True, metavar="NODE",
                        help="full name of the node whose end ends the launch, e.g. /fluid_sim/fluid_sim")
    parser.add_argument("-p", "--port", type=int, default=None, help="port of a master started here")
    parser.add_argument("launch", nargs="+", help="PACKAGE FILE.launch or PATH.launch, then arg:=value ...")
    options = parser.parse_args(argv)

    # resolve_launch_arguments drops the arg:=value arguments (as remappings): keep them apart.
    launch_args = [a for a in options.launch if ":=" in a]
    launch_file = roslaunch.rlutil.resolve_launch_arguments(options.launch)[0]
    run_id = roslaunch.rlutil.get_or_generate_uuid(None, False)
    roslaunch.configure_logging(run_id)
    watch = NodeWatch(options.until)
    parent = roslaunch.parent.ROSLaunchParent(run_id, [(launch_file, launch_args)], port=options.port,
                                              process_listeners=[watch])
    try:
        parent.start()
    except roslaunch.RLException as e:
        print("run_launch: %s" % e, file=sys.stderr)
        parent.shutdown()
        return 1
    try:
        # roslaunch's main-thread duties (it runs some process work there) until the node ends,
        # another process fails, or a signal shuts the process monitor down.
        while not watch.ended.is_set() and not parent.runner.pm.is_shutdown:
            parent.spin_once()
            time.sleep(0.1)
    finally:
        parent.shutdown()

    if watch.failure is not None and watch.exit_code is None:
        print("run_launch: %s; the launch was ended" % watch.failure, file=sys.stderr)
        return 1
    if watch.exit_code is None:
        return 0  # shut down from outside (Ctrl-C) before the node ended
    if watch.exit_code != 0:
        print("run_launch: %s ended with exit code %d" % (options.until, watch.exit_code), file=sys.stderr)
    return watch.exit_code if 0 <= watch.exit_code < 256 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
