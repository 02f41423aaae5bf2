#!/usr/bin/env python3
"""How straight a map keeps a building's walls: the direction of the straight walls each
keyframe's scan sees, turned into the world by the reference's heading and by the run's, block
by block of keyframes, as a departure from the drive's mean direction modulo 90 degrees.

  scripts/lib/wall_directions.py RUN_DIR LOG [--block 100] [--min-agreement 0.8]

RUN_DIR holds trajectory.csv (llc slam --log LOG --out RUN_DIR); LOG is a CARMEN log whose
FLASER lines carry the reference's poses (the *-corrected logs), or are each followed by a
TRUEPOS line that does (llc simulate's sim.log); the keyframes' `index` is their FLASER line. In each keyframe's scan every run of 9 beams (within
15 m, no jump over 0.5 m) that lies on a line (its second singular value under 3% of the
first) gives a direction, weighted by its length; their mean modulo 90 degrees is the scan's
wall direction, kept when the segments agree (the resultant's length over the weights at least
--min-agreement). In a building whose walls meet at right angles a block's mean departure is
the heading error of the poses there; two sets of poses that depart differently disagree in
heading by the difference (the last column, the run's heading minus the reference's after the
mean offset). Blocks whose walls are not at right angles show a large standard error.
"""
import csv
import gzip
import math
import sys

import numpy as np

HALF_WINDOW = 4        # beams on each side of a segment's centre
MAX_RANGE = 15.0       # m; farther returns are left out
MAX_JUMP = 0.5         # m; between neighbouring beams of one segment
MAX_THICKNESS = 0.03   # second over first singular value of a straight segment


def read_flaser(path):
    """[(ranges, bearings, reference heading)] of the log's FLASER lines, in order; the heading
    of a TRUEPOS line right after a FLASER line (llc simulate's logs) over the FLASER's own."""
    opener = gzip.open if path.endswith(".gz") else open
    scans = []
    truth_taken = True
    with opener(path, "rt") as log:
        for number, line in enumerate(log, start=1):
            fields = line.split()
            if fields and fields[0] == "TRUEPOS" and not truth_taken:
                if len(fields) < 4:
                    raise ValueError("%s:%d: TRUEPOS with %d values" % (path, number, len(fields) - 1))
                ranges, bearings, _ = scans[-1]
                scans[-1] = (ranges, bearings, float(fields[3]))
                truth_taken = True
                continue
            if not fields or fields[0] != "FLASER":
                continue
            truth_taken = False
            n = int(fields[1])
            if n < 2 * HALF_WINDOW + 1 or len(fields) < 2 + n + 3:
                raise ValueError("%s:%d: FLASER with %d beams and %d values" % (path, number, n, len(fields)))
            ranges = np.array([float(v) for v in fields[2:2 + n]])
            heading = float(fields[2 + n + 2])
            # CARMEN: n beams over 180 degrees from -90; pi/n apart for even n, pi/(n-1) for odd.
            step = math.pi / (n if n % 2 == 0 else n - 1)
            scans.append((ranges, -math.pi / 2 + step * np.arange(n), heading))
    return scans


def wall_direction(ranges, bearings):
    """(direction mod 90 degrees in rad, agreement 0..1) of a scan's straight segments, or None."""
    x, y = ranges * np.cos(bearings), ranges * np.sin(bearings)
    usable = np.isfinite(ranges) & (ranges > 0.1) & (ranges < MAX_RANGE)
    c = s = weight = 0.0
    for centre in range(HALF_WINDOW, len(ranges) - HALF_WINDOW):
        window = slice(centre - HALF_WINDOW, centre + HALF_WINDOW + 1)
        if not usable[window].all() or np.max(np.abs(np.diff(ranges[window]))) > MAX_JUMP:
            continue
        points = np.stack([x[window], y[window]], 1)
        points = points - points.mean(0)
        _, singular, axes = np.linalg.svd(points)
        if singular[0] < 1e-6 or singular[1] > MAX_THICKNESS * singular[0]:
            continue
        angle = 4.0 * math.atan2(axes[0][1], axes[0][0])  # on the circle of directions mod 90 degrees
        c += singular[0] * math.cos(angle)
        s += singular[0] * math.sin(angle)
        weight += singular[0]
    if weight <= 0.0:
        return None
    return math.atan2(s, c) / 4.0, math.hypot(c, s) / weight


def mod90(angle):
    return (angle + math.pi / 4) % (math.pi / 2) - math.pi / 4


def circular_mean90(angles):
    return math.atan2(np.mean(np.sin(4 * angles)), np.mean(np.cos(4 * angles))) / 4.0


def main(argv):
    if len(argv) < 2 or argv[0].startswith("-") or argv[1].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    run, log = argv[0], argv[1]
    block, min_agreement = 100, 0.8
    args = argv[2:]
    while args:
        if len(args) < 2 or args[0] not in ("--block", "--min-agreement"):
            print(__doc__.strip(), file=sys.stderr)
            return 2
        try:
            if args[0] == "--block":
                block = int(args[1])
            else:
                min_agreement = float(args[1])
        except ValueError:
            block = 0
        if block < 1 or not 0.0 <= min_agreement <= 1.0:
            print("wall_directions: %s %s: --block must be a whole number >= 1, --min-agreement in [0, 1]"
                  % (args[0], args[1]), file=sys.stderr)
            return 2
        args = args[2:]
    try:
        scans = read_flaser(log)
        keyframes = [(int(r["index"]), float(r["theta"])) for r in csv.DictReader(open(run + "/trajectory.csv"))]
        if not keyframes:
            raise ValueError("trajectory.csv holds no keyframe")
        for index, theta in keyframes:
            if not 0 <= index < len(scans):
                raise ValueError("keyframe index %d: the log has %d FLASER scans" % (index, len(scans)))
            if not math.isfinite(theta):
                raise ValueError("keyframe index %d: a heading that is not finite" % index)
    except (OSError, KeyError, TypeError, ValueError, EOFError) as error:  # missing file, column or value
        print("wall_directions: %s" % error, file=sys.stderr)
        return 1
    rows = []  # (keyframe position, direction in the scan, reference heading, run heading)
    for position, (index, theta) in enumerate(keyframes):
        ranges, bearings, reference = scans[index]
        found = wall_direction(ranges, bearings)
        if found is not None and found[1] >= min_agreement:
            rows.append((position, found[0], reference, theta))
    if len(rows) < 2:
        print("wall_directions: fewer than 2 keyframes see straight walls that agree", file=sys.stderr)
        return 1
    rows = np.array(rows)
    reference_world = rows[:, 1] + rows[:, 2]
    run_world = rows[:, 1] + rows[:, 3]
    reference_mean, run_mean = circular_mean90(reference_world), circular_mean90(run_world)
    offset = np.arctan2(np.sin(rows[:, 3] - rows[:, 2]), np.cos(rows[:, 3] - rows[:, 2]))
    offset_mean = math.atan2(np.mean(np.sin(offset)), np.mean(np.cos(offset)))
    print("keyframes=%d with_walls=%d" % (len(keyframes), len(rows)))
    print("block,keyframes_with_walls,reference_deg,reference_se_deg,run_deg,run_se_deg,heading_error_deg")
    for start in range(0, len(keyframes), block):
        inside = (rows[:, 0] >= start) & (rows[:, 0] < start + block)
        if inside.sum() < 3:
            continue
        reference = np.degrees([mod90(a - reference_mean) for a in reference_world[inside]])
        ours = np.degrees([mod90(a - run_mean) for a in run_world[inside]])
        heading = np.degrees(np.arctan2(np.sin(offset[inside] - offset_mean), np.cos(offset[inside] - offset_mean)))
        n = int(inside.sum())
        print("%d-%d,%d,%+.2f,%.2f,%+.2f,%.2f,%+.2f" % (start, start + block - 1, n, reference.mean(),
                                                       reference.std() / math.sqrt(n), ours.mean(),
                                                       ours.std() / math.sqrt(n), heading.mean()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
