#!/usr/bin/env python3
"""A fault injector for `make bench-faults` (docs/faults.md): a rospy node beside one run.

    fault_injector.py --fault stall --at-s 30 --duration-s 2     # scans: bridge_scan -> scan
    fault_injector.py --fault drop --fraction 0.2                # from the start
    fault_injector.py --fault tf_delay --delay-s 0.3             # TF: bridge_tf -> /tf
    fault_injector.py --fault clock_jump --at-s 30 --jump-s 5    # one /clock 5 s earlier

The run is launched with ``bridge_scan:=scan_raw`` (stall, drop) or ``bridge_tf:=/tf_raw``
(tf_delay), so that the production graph is the same but for this relay; ``clock_jump`` needs no
remap: it publishes one /clock message ``jump_s`` earlier than the bridge's last, as a bag that
loops does (`rosbag play --loop` starts its /clock again from the bag's start), and the bridge's
next tick moves the clock forward again. Times (``--at-s``) are sim seconds after the explorer's
start (``/explorer/start_time_s``). On stdout: one line when the fault begins and ends, for the
harness to read.
"""
import argparse
import collections
import random
import sys
import threading
import time

import rospy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

SEED = 32                    # issue 32: the drops are the same in every run


def say(text: str) -> None:
    print(f"[inject] {text}", flush=True)


def wait_for_sim_time(timeout_s: float = 120.0) -> None:
    """Until the launch has set /use_sim_time (rospy reads it once, in init_node)."""
    import rosgraph
    master, deadline = rosgraph.Master("/fault_injector"), time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if master.getParam("/use_sim_time"):
                return
        except Exception:                   # the master not up yet, or the parameter not set
            pass
        time.sleep(0.2)
    say("no /use_sim_time after %.0f s: going on with the wall clock" % timeout_s)


def explorer_start_s() -> float:
    """The explorer's start (sim s), waited for."""
    while not rospy.is_shutdown():
        if rospy.has_param("/explorer/start_time_s"):
            return float(rospy.get_param("/explorer/start_time_s"))
        time.sleep(0.2)
    return float("inf")


def wait_until_sim(t: float) -> None:
    while not rospy.is_shutdown() and rospy.get_time() < t:
        time.sleep(0.01)


class ScanRelay:
    """bridge_scan -> scan, dropping a fraction, or nothing between two sim times (a stall)."""

    def __init__(self, src: str, dst: str, drop: float):
        self.drop, self.rng = drop, random.Random(SEED)
        self.stall = (float("inf"), float("inf"))
        self.relayed = self.dropped = 0
        self.pub = rospy.Publisher(dst, LaserScan, queue_size=5)
        rospy.Subscriber(src, LaserScan, self.on_scan, queue_size=5)

    def on_scan(self, m) -> None:
        now = rospy.get_time()
        if self.stall[0] <= now < self.stall[1] or (self.drop and self.rng.random() < self.drop):
            self.dropped += 1
            return
        self.relayed += 1
        self.pub.publish(m)


class TfDelay:
    """bridge_tf -> /tf, each message held until the sim clock reaches its stamp + delay."""

    def __init__(self, src: str, delay_s: float):
        self.delay_s, self.queue, self.lock = delay_s, collections.deque(), threading.Lock()
        self.pub = rospy.Publisher("/tf", TFMessage, queue_size=100)
        rospy.Subscriber(src, TFMessage, self.on_tf, queue_size=100)

    def on_tf(self, m: TFMessage) -> None:
        stamp = max((t.header.stamp.to_sec() for t in m.transforms), default=rospy.get_time())
        with self.lock:
            self.queue.append((stamp + self.delay_s, m))

    def spin(self) -> None:
        while not rospy.is_shutdown():
            now = rospy.get_time()
            out = []
            with self.lock:
                while self.queue and self.queue[0][0] <= now:
                    out.append(self.queue.popleft()[1])
            for m in out:
                self.pub.publish(m)
            time.sleep(0.002)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fault", required=True, choices=("stall", "drop", "tf_delay", "clock_jump"))
    ap.add_argument("--at-s", type=float, default=30.0, help="sim s after the explorer's start")
    ap.add_argument("--duration-s", type=float, default=2.0, help="stall: how long no scan passes")
    ap.add_argument("--fraction", type=float, default=0.2, help="drop: the fraction of scans dropped")
    ap.add_argument("--delay-s", type=float, default=0.3, help="tf_delay: sim s")
    ap.add_argument("--jump-s", type=float, default=5.0, help="clock_jump: how far back")
    ap.add_argument("--scan-src", default="/scan_raw")
    ap.add_argument("--tf-src", default="/tf_raw")
    a = ap.parse_args(rospy.myargv()[1:])
    wait_for_sim_time()
    rospy.init_node("fault_injector", disable_signals=False)
    if a.fault == "stall":
        relay = ScanRelay(a.scan_src, "/scan", 0.0)
        t0 = explorer_start_s() + a.at_s
        relay.stall = (t0, t0 + a.duration_s)
        wait_until_sim(t0)
        say(f"scan stalled at t={rospy.get_time():.1f} s sim for {a.duration_s:g} s")
        wait_until_sim(t0 + a.duration_s)
        say(f"scan flowing again at t={rospy.get_time():.1f} s sim")
    elif a.fault == "drop":
        relay = ScanRelay(a.scan_src, "/scan", a.fraction)
        say(f"dropping {a.fraction:.0%} of scans (seeded)")
    elif a.fault == "tf_delay":
        relay = TfDelay(a.tf_src, a.delay_s)
        say(f"TF from the bridge delayed by {a.delay_s:g} s sim")
        threading.Thread(target=relay.spin, daemon=True).start()
    else:
        pub = rospy.Publisher("/clock", Clock, queue_size=1)
        t0 = explorer_start_s() + a.at_s
        wait_until_sim(t0)
        now = rospy.get_time()
        back = rospy.Time.from_sec(max(0.0, now - a.jump_s))
        for _ in range(3):                      # a late subscriber connection may miss the first
            pub.publish(Clock(clock=back))
            time.sleep(0.01)
        say(f"clock jumped back from t={now:.1f} s to {back.to_sec():.1f} s sim")
    rospy.spin()
    if a.fault in ("stall", "drop"):
        say(f"scans relayed {relay.relayed}, dropped {relay.dropped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
