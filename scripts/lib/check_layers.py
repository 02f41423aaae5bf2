#!/usr/bin/env python3
"""The include directions of the house, checked over the sources (scripts/test runs it).

  core/<stage>/   may include only its own stage and the stages listed before it below;
                  never ROS (ros/, sensor_msgs/, tf2, ..., laser_loop_closure/ros or messages).
  ros/io/         may include core/ and ros/io/, never ros/nodes/.
  ros/nodes/      may include all of the above.
A file outside a stage folder (straight in core/ or ros/) is an error too: every file has a
place. Prints each violation as PATH:LINE: what; exits 1 when there is one, 0 otherwise.
  scripts/lib/check_layers.py [REPO]
"""
import os
import re
import sys

# Lower first: a stage builds on the ones before it (docs/design.md says why this order).
CORE_STAGES = ["common", "geometry", "io", "sim", "features", "classifier", "alignment", "backend", "map", "slam"]
ROS_LAYERS = ["io", "nodes"]
ROS_INCLUDE = re.compile(r'#include\s*[<"](ros/|sensor_msgs/|std_msgs/|geometry_msgs/|nav_msgs/|tf2|nodelet/|'
                         r'pluginlib/|diagnostic_|rosbag/|message_filters/|laser_loop_closure/(ros/|[A-Z]))')
OWN_INCLUDE = re.compile(r'#include\s*"laser_loop_closure/(core|ros)/([^"]+)"')


def place(path, root):
    """(layer, rank) of a source file: ('core', stage rank) or ('ros', layer rank); None outside."""
    rel = os.path.relpath(path, root).split(os.sep)
    for prefix in (["include", "laser_loop_closure"], ["src"]):
        if rel[:len(prefix)] == prefix:
            rest = rel[len(prefix):]
            if len(rest) >= 2 and rest[0] in ("core", "ros"):
                return rest[0], rest[1] if len(rest) >= 3 else None
    return None


def rank_of(layer, folder):
    order = CORE_STAGES if layer == "core" else ROS_LAYERS
    return order.index(folder) if folder in order else None


def check(root):
    problems = []
    for top in ("include/laser_loop_closure/core", "include/laser_loop_closure/ros", "src/core", "src/ros"):
        for directory, _, names in os.walk(os.path.join(root, top)):
            for name in sorted(names):
                if not name.endswith((".hpp", ".cpp", ".h")):
                    continue
                path = os.path.join(directory, name)
                layer, folder = place(path, root)
                rel = os.path.relpath(path, root)
                own = rank_of(layer, folder)
                if own is None:
                    problems.append("%s: not in a %s folder (%s)" % (rel, layer, ", ".join(CORE_STAGES if layer == "core" else ROS_LAYERS)))
                    continue
                for number, line in enumerate(open(path, encoding="utf-8"), 1):
                    if layer == "core" and ROS_INCLUDE.search(line):
                        problems.append("%s:%d: the core includes ROS: %s" % (rel, number, line.strip()))
                        continue
                    found = OWN_INCLUDE.search(line)
                    if not found:
                        continue
                    target_layer, target = found.group(1), found.group(2).split("/")
                    if layer == "core" and target_layer == "ros":
                        continue  # reported above as ROS
                    target_rank = rank_of(target_layer, target[0]) if len(target) >= 2 else None
                    if target_rank is None:
                        problems.append("%s:%d: includes a file outside the %s folders: %s" % (rel, number, target_layer, line.strip()))
                    elif target_layer == layer and target_rank > own:
                        problems.append("%s:%d: %s/%s includes the higher %s/%s: %s" %
                                        (rel, number, layer, folder, target_layer, target[0], line.strip()))
    return problems


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    problems = check(os.path.abspath(root))
    for p in problems:
        print(p)
    if problems:
        print("FAIL: %d include(s) against the layers (scripts/lib/check_layers.py)" % len(problems))
        return 1
    print("ok: every include goes down the layers (core: %s; ros: %s)" % (" < ".join(CORE_STAGES), " < ".join(ROS_LAYERS)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
