#!/usr/bin/env python3
"""A free TCP port for a ROS master of a script's or test's own: printed, or free_port() imported.

The port is drawn at random below the kernel's ephemeral range (/proc/sys/net/ipv4/
ip_local_port_range, 32768-60999 by default): the kernel hands ports from that range to outgoing
connections and to bind(0), so a port below it stays free between this check and the master's
own bind unless another process asks for that very number. A random port in 20000-39999, partly
inside the range, once met a live connection's port (ctest ros_demo_headless: "Unable to start
XML-RPC server, port 34568 is already in use").

    port=$(/usr/bin/python3 scripts/free_port.py)
"""
import random
import socket
import sys

LOWEST = 20000  # below: ports that services are often configured on


def ephemeral_range():
    """The kernel's ephemeral port range (first, last); the Linux default when unreadable."""
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            first, last = (int(v) for v in f.read().split()[:2])
            return first, last
    except (OSError, ValueError):
        return 32768, 60999


def is_free(port):
    """Whether a server could bind the port now (as the master's XML-RPC server does: with
    SO_REUSEADDR, so a port whose old connections linger in TIME_WAIT counts as free)."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("", port))
            return True
        except OSError:
            return False


def free_port():
    first, last = ephemeral_range()
    # Below the range; where the range starts low, above it.
    candidates = (LOWEST, first) if first - LOWEST >= 1000 else (last + 1, 65536)
    rng = random.SystemRandom()
    for _ in range(200):
        port = rng.randrange(*candidates)
        if is_free(port):
            return port
    # Every draw taken: whatever the kernel gives (free now, inside its range).
    with socket.socket() as s:
        s.bind(("", 0))
        return s.getsockname()[1]


if __name__ == "__main__":
    print(free_port())
    sys.exit(0)
