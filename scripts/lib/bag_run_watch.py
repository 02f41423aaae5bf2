"""Watches one bag.launch run for scripts/real_bags: waits until the player has finished and the
nodelets have taken in every scan, then saves the map (~save_map), writes the back end's last
/path as path.csv (stamp,x,y,yaw) and prints the run's figures; the last line starts with "row:"
(the columns of scripts/real_bags' table). Exit 1 when the run does not finish in time."""
import argparse
import math
import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Path
from rosgraph_msgs.msg import Clock
from laser_loop_closure.srv import SaveMap
from run_watch import number, wait_for_master, wait_for_player_to_finish

parser = argparse.ArgumentParser()
parser.add_argument("--run", required=True, help="folder for map.pgm/.yaml and path.csv")
parser.add_argument("--duration", type=float, required=True, help="s of the bag's own clock")
parser.add_argument("--timeout", type=float, default=3600.0, help="s of wall time for the whole run")
args = parser.parse_args()

deadline = time.time() + args.timeout
wait_for_master(deadline)
rospy.init_node("real_bags_watch", anonymous=True, disable_signals=True)

lock = threading.Lock()
state = {"front": {}, "back": {}, "merger": {}, "path": None, "first_clock": None, "diag_count": 0}


def on_diagnostics(msg):
    with lock:
        state["diag_count"] += 1
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            if s.name.endswith(": loop closure"):
                state["front"] = values
            elif s.name.endswith(": esdf backend"):
                state["back"] = values
            elif s.name.endswith(": scan merger"):
                state["merger"] = values


def on_path(msg):
    with lock:
        state["path"] = msg


def on_clock(_):
    if state["first_clock"] is None:
        state["first_clock"] = time.time()


rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=50)
rospy.Subscriber("/path", Path, on_path, queue_size=1)
rospy.Subscriber("/clock", Clock, on_clock, queue_size=1)




wait_for_player_to_finish(deadline, args.timeout)

# Drained: nothing waits for the front end, both ends agree on the keyframes, and two diagnostics
# in a row say the same (the nodelets publish diagnostics on wall time, so they go on after /clock stops).
last, same = None, 0
while same < 2:
    if time.time() > deadline:
        sys.exit("the nodelets did not drain in time")
    time.sleep(1.5)
    with lock:
        front, back = dict(state["front"]), dict(state["back"])
    figure = (number(front, "scans processed"), number(front, "keyframes"), number(back, "keyframes"),
              number(back, "loops applied"))
    # Scans may still wait for odometry: the last ones of a bag whose odometry ends first.
    drained = (number(front, "scans waiting for the front end") == 0 and
               number(back, "loops waiting for keyframes") == 0 and figure[1] == figure[2])
    same = same + 1 if drained and figure == last else 0
    last = figure
wall = time.time() - (state["first_clock"] or time.time())

rospy.wait_for_service("/esdf_backend/save_map", timeout=30)
answer = rospy.ServiceProxy("/esdf_backend/save_map", SaveMap)(path=args.run + "/map")
print("save_map: %s (%s)" % (answer.success, answer.message))
with lock:
    path = state["path"]
if path is not None:
    with open(args.run + "/path.csv", "w") as out:
        out.write("stamp,x,y,yaw\n")
        for p in path.poses:
            q = p.pose.orientation
            yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
            out.write("%.6f,%.4f,%.4f,%.5f\n" % (p.header.stamp.to_sec(), p.pose.position.x, p.pose.position.y, yaw))

front, back, merger = state["front"], state["back"], state["merger"]
received = number(front, "scans received")
dropped = (number(front, "scans dropped to catch up (max_lag)") + number(front, "scans dropped, queue full (queue_size)"))
for key in sorted(front):
    print("loop_closure: %s = %s" % (key, front[key]))
for key in sorted(back):
    print("esdf_backend: %s = %s" % (key, back[key]))
for key in sorted(merger):
    print("scan_merger: %s = %s" % (key, merger[key]))
print("row: %d | %d | %d | %d | %d | %d | %.2f | %.0f | %.1f" % (
    received, number(front, "scans processed"), dropped, number(back, "keyframes"), number(back, "loops applied"),
    number(back, "loops refused by the gate"), number(front, "largest lag (s)"), wall, args.duration / max(wall, 1e-9)))
