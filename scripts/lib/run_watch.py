"""What the run watchers (bag_run_watch.py, fleet_watch.py) share: waiting for the master, for the
player (node /player) to start and leave, and reading a number from a diagnostics status."""
import sys
import time

import rosgraph
import rosnode


def wait_for_master(deadline, within=60.0):
    """Waits for the ROS master at most `within` s (and never past `deadline`); exits if none."""
    give_up = min(deadline, time.time() + within)
    while not rosgraph.is_master_online():
        if time.time() > give_up:
            sys.exit("no ROS master after %.0f s" % within)
        time.sleep(0.5)


def player_running():
    try:
        return "/player" in rosnode.get_node_names()
    except rosnode.ROSNodeIOException:
        return False


def wait_for_player_to_finish(deadline, timeout):
    """The player registers a moment after the master starts; then waits until it has left."""
    while not player_running():
        if time.time() > deadline:
            sys.exit("the player never started")
        time.sleep(0.5)
    while player_running():
        if time.time() > deadline:
            sys.exit("the bag did not finish in %.0f s" % timeout)
        time.sleep(1.0)


def number(values, key):
    """A diagnostics value as a number; nan when it is missing or not a number."""
    try:
        return float(values.get(key, "nan"))
    except ValueError:
        return float("nan")
