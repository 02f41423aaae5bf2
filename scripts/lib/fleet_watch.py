"""Watches one multi_robot.launch run for scripts/multi_robot_live: waits until the player has
finished and every robot's keyframes are in the back end (or nothing changed for 30 s), then
prints one row per robot (scans received, processed, dropped, the largest lag, keyframes of the
front end and of the back end, lost, sent again, joined, bytes and bytes per second of the
drive, place checks asked of the back end and unanswered) and the totals. Exit 1 when the run does not finish in time."""
import argparse
import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from run_watch import number, wait_for_master, wait_for_player_to_finish

parser = argparse.ArgumentParser()
parser.add_argument("--robots", required=True, help="the robots' namespaces, separated by spaces")
parser.add_argument("--duration", type=float, required=True, help="s of the bag's own clock (each robot drives it)")
parser.add_argument("--timeout", type=float, default=3600.0, help="s of wall time for the whole run")
args = parser.parse_args()
robots = args.robots.split()

deadline = time.time() + args.timeout
wait_for_master(deadline)
rospy.init_node("fleet_watch", anonymous=True, disable_signals=True)
lock = threading.Lock()
state = {"front": {r: {} for r in robots}, "back": {}}


def on_diagnostics(msg):
    with lock:
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            if s.name.endswith(": multi-robot backend"):
                state["back"] = values
            for r in robots:
                if s.name.startswith(r + "/") and s.name.endswith(": loop closure"):
                    state["front"][r] = values


rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=100)




wait_for_player_to_finish(deadline, args.timeout)

last, same, unchanged_since = None, 0, time.time()
while same < 3 and time.time() - unchanged_since < 30.0:
    if time.time() > deadline:
        sys.exit("the nodes did not drain in time")
    time.sleep(1.5)
    with lock:
        front, back = {r: dict(v) for r, v in state["front"].items()}, dict(state["back"])
    figure = tuple((number(front[r], "keyframes"), number(back, r + " keyframes")) for r in robots)
    drained = all(f == b and number(front[r], "scans waiting for the front end") == 0 for r, (f, b) in zip(robots, figure))
    if figure != last:
        unchanged_since = time.time()
    same = same + 1 if drained and figure == last else 0
    last = figure

with lock:
    front, back = state["front"], state["back"]
print("%-6s %8s %9s %7s %8s %9s %8s %5s %6s %6s %10s %9s %9s %9s %7s %10s" % (
    "robot", "scans", "processed", "dropped", "lag_s", "kf_front", "kf_back", "lost", "again", "joined", "bytes",
    "bytes/s", "of_srv", "of_loops", "checks", "unanswered"))
total_bytes = 0.0
for r in robots:
    f = front[r]
    dropped = number(f, "scans dropped to catch up (max_lag)") + number(f, "scans dropped, queue full (queue_size)")
    sent = number(back, r + " bytes exchanged")
    total_bytes += sent
    print("%-6s %8.0f %9.0f %7.0f %8.2f %9.0f %8.0f %5.0f %6.0f %6s %10.0f %9.0f %9.0f %9.0f %7.0f %10.0f" % (
        r, number(f, "scans received"), number(f, "scans processed"), dropped, number(f, "largest lag (s)"),
        number(f, "keyframes"), number(back, r + " keyframes"), number(back, r + " keyframes lost"),
        number(f, "keyframes sent again (resend_request)"), back.get(r + " joined", "?"), sent,
        sent / max(args.duration, 1e-9), number(back, r + " bytes of services"), number(back, r + " bytes of loops"), number(f, "place checks asked of the back end"),
        number(f, "place checks unanswered (aligned ungated)")))
print("total: robots_joined=%s cross_robot_loops=%s bytes=%.0f bytes_per_s=%.0f cross_robot_search_s=%s" % (
    back.get("robots joined", "?"), back.get("cross-robot loops", "?"), total_bytes,
    total_bytes / max(args.duration, 1e-9), back.get("cross-robot search s", "?")))
