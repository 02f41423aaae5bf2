#!/usr/bin/env python3
"""Which relations make a run's Kuemmerle figure: the largest relation errors of an `llc slam
--relations R` run, where each end's pose hangs in the keyframe chain, and the odometry steps
between them that no scan placed or that were widened along a corridor.

  scripts/lib/relation_tail.py RUN_DIR [--top 20]

RUN_DIR holds relation_errors.csv and scans.csv (llc slam --out DIR --relations R);
odometry_steps.csv (written with --truth or --evaluate) adds the steps' columns, else they read
"-". First `key=value` lines: the relations, their mean translational error and the mean left
when the largest 5, 20 and --top are taken out (the mean over the rest). Then one row per
relation of the --top largest, largest first: its scans, the keyframes their poses hang from
(scans.csv), how many keyframe steps lie between them, and of those the steps that were not
matched (the pose of a scan no ICP placed: the motion model's or the wheels' guess) and those
widened as ambiguous (ambiguous_shift_m above 0: a scan that fits as well metres along a
corridor), each as keyframe or keyframe:metres.
"""
import csv
import math
import sys


def fail(message, code=1):
    print("relation_tail: %s" % message, file=sys.stderr)
    return code


def read_steps(path):
    """keyframe -> (matched, the shift m it was widened to along a corridor); None without the file."""
    try:
        rows = list(csv.DictReader(open(path)))
    except FileNotFoundError:
        return None
    steps = {}
    for row in rows:
        shift = float(row["ambiguous_shift_m"]) if row.get("ambiguous_shift_m") not in (None, "") else 0.0
        steps[int(row["keyframe"])] = (row["matched"] == "1", shift)
    return steps


def main(argv):
    if not argv or argv[0].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    run, top = argv[0], 20
    args = argv[1:]
    while args:
        if args[0] != "--top" or len(args) < 2:
            print(__doc__.strip(), file=sys.stderr)
            return 2
        try:
            top = int(args[1])
        except ValueError:
            top = 0
        if top < 1:
            return fail("--top %s: must be a whole number >= 1" % args[1], 2)
        args = args[2:]
    try:
        relations = list(csv.DictReader(open(run + "/relation_errors.csv")))
        keyframe_of = {int(r["scan"]): int(r["keyframe"]) for r in csv.DictReader(open(run + "/scans.csv"))}
        steps = read_steps(run + "/odometry_steps.csv")
        rows = []
        for r in relations:
            error = float(r["translation_m"])
            if not math.isfinite(error):
                raise ValueError("relation %s: translation_m is not finite" % r["relation"])
            scan1, scan2 = int(r["scan1"]), int(r["scan2"])
            if scan1 not in keyframe_of or scan2 not in keyframe_of:
                raise ValueError("relation %s: scan %d or %d is not in scans.csv" % (r["relation"], scan1, scan2))
            rows.append((error, float(r["rotation_deg"]), r["relation"], scan1, scan2))
    except (OSError, KeyError, TypeError, ValueError) as error:  # missing file, column or value; not a number
        return fail("%s: %s" % (run, error))
    if not rows:
        return fail("%s: relation_errors.csv holds no relation" % run)
    rows.sort(key=lambda row: -row[0])
    n = len(rows)
    total = sum(row[0] for row in rows)
    print("relations=%d translation_mean_m=%.4g largest_m=%.4g" % (n, total / n, rows[0][0]))
    dropped = 0.0
    for k, (error, *_rest) in enumerate(rows[:max(top, 20)], start=1):
        dropped += error
        if k in (5, 20, top) and k < n:
            print("without_largest_%d_m=%.4g  (the mean over the other %d)" % (k, (total - dropped) / (n - k), n - k))
    print("relation,scan1,scan2,keyframe1,keyframe2,translation_m,rotation_deg,steps_between,unmatched_steps,ambiguous_steps")
    for error, rotation, name, scan1, scan2 in rows[:top]:
        k1, k2 = sorted((keyframe_of[scan1], keyframe_of[scan2]))
        between = range(k1 + 1, k2 + 1)  # step k joins keyframe k-1 to k
        if steps is None:
            unmatched = ambiguous = "-"
        else:
            unmatched = " ".join(str(k) for k in between if k in steps and not steps[k][0]) or "none"
            ambiguous = " ".join("%d:%.1f" % (k, steps[k][1]) for k in between
                                 if k in steps and steps[k][1] > 0) or "none"
        print("%s,%d,%d,%d,%d,%.4g,%.4g,%d,%s,%s" % (name, scan1, scan2, keyframe_of[scan1], keyframe_of[scan2], error,
                                                   rotation, len(between), unmatched, ambiguous))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
