#!/usr/bin/env python3
"""The keyframe steps a run took from the tracked seed (odometry/track_scans) against the others:
how many, and the RMS and mean of their heading errors against the truth; then the heading errors
summed by blocks of keyframes. With OTHER_RUN (the same input mapped otherwise, e.g. with
--odometry/match_every_scan false), the same steps' errors in that run beside them, paired by scan
index: whether a map moved because its steps got worse, or because their errors stopped cancelling.

  scripts/lib/tracked_steps.py RUN_DIR [OTHER_RUN_DIR] [--block 100]

Reads RUN_DIR/odometry_steps.csv (llc slam with a truth: --evaluate, --truth or --drift).
"""
import csv
import math
import signal
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)


def fail(message, code=1):
    print("tracked_steps: " + message, file=sys.stderr)
    sys.exit(code)


def load(run, need_tracked):
    path = run + "/odometry_steps.csv"
    try:
        with open(path) as handle:
            rows = list(csv.DictReader(handle))
    except OSError as error:
        fail("cannot read %s (%s)" % (path, error.strerror))
    if rows and need_tracked and "tracked" not in rows[0]:
        fail("%s has no tracked column (written by an llc slam before it had one)" % path)
    try:
        return {int(r["scan_index"]): (float(r["error_theta"]), r.get("tracked") == "1") for r in rows}
    except (KeyError, ValueError):
        fail("%s: not llc slam's odometry_steps.csv" % path)


def summary(errors):
    if not errors:
        return "none"
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    return "%d steps, heading error rms %.5f rad, mean %+.5f rad" % (len(errors), rms, sum(errors) / len(errors))


def main(argv):
    usage = "usage: scripts/lib/tracked_steps.py RUN_DIR [OTHER_RUN_DIR] [--block 100]"
    runs, block = [], 100
    i = 0
    while i < len(argv):
        if argv[i] == "--block" and i + 1 < len(argv):
            if not argv[i + 1].isdigit() or int(argv[i + 1]) < 1:
                fail("--block must be a whole number >= 1, not %s" % argv[i + 1], 2)
            block = int(argv[i + 1])
            i += 2
        elif argv[i].startswith("--") or len(runs) == 2:
            fail(usage, 2)
        else:
            runs.append(argv[i])
            i += 1
    if not runs:
        fail(usage, 2)
    steps = load(runs[0], True)
    other = load(runs[1], False) if len(runs) == 2 else None
    scans = sorted(steps)
    for label, wanted in (("tracked", True), ("untracked", False)):
        chosen = [s for s in scans if steps[s][1] == wanted]
        line = "%s: %s" % (label, summary([steps[s][0] for s in chosen]))
        if other is not None:
            line += "; the same steps in the other run: %s" % summary([other[s][0] for s in chosen if s in other])
        print(line)
    for start in range(0, len(scans), block):
        part = scans[start:start + block]
        here = sum(steps[s][0] for s in part)
        line = "keyframes %d-%d: heading error summed %+.4f rad" % (start + 1, start + len(part), here)
        if other is not None:
            there = sum(other[s][0] for s in part if s in other)
            line += ", in the other run %+.4f (difference %+.4f)" % (there, here - there)
        print(line)


if __name__ == "__main__":
    main(sys.argv[1:])
