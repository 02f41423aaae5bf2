#!/usr/bin/env python3
"""Whose keyframe steps do the scans side with, the run's or the reference's? Each keyframe step
of an `llc slam --evaluate` (or `--truth`) run whose heading is off the reference by at least
--min-deg is aligned again by ICP started from the reference's own step (`llc align
--truth-check`): where the scans fit the reference's step, ICP stays; where they fit another
(the run's), ICP moves there and the fit rises.

  scripts/lib/step_truth_check.py RUN_DIR LOG [--min-deg 1.5] [--llc PATH] [-- ALIGN OPTIONS...]

RUN_DIR holds odometry_steps.csv (its `scan_index` and `error_theta`: the step's heading minus
the reference's, rad); LOG is the log the run read, whose poses are the reference (CARMEN, as
`llc align --data` takes it). One row per such step: keyframe, its scan pair, the run's heading
error (deg), how far ICP from the reference's step moved (m, deg), and the fit (share of points
near the other scan, both ways) at the reference's step and where ICP went. A step "sides with
the run" when ICP from the reference's step moves at least half the run's heading error and
fits better. Last, the counts and, over every step, the median and 90th percentile of ICP's
move from the reference's step (how far the reference and the scans part in general).
Options after `--` go to `llc align`.
"""
import csv
import math
import os
import shutil
import subprocess
import sys
import tempfile


def fail(message, code=1):
    print("step_truth_check: " + message, file=sys.stderr)
    sys.exit(code)


def parse(argv):
    if len(argv) < 2 or argv[0].startswith("-") or argv[1].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        sys.exit(2)
    run, log, min_deg, llc, extra = argv[0], argv[1], 1.5, None, []
    args = argv[2:]
    while args:
        if args[0] == "--":
            extra = args[1:]
            break
        if args[0] not in ("--min-deg", "--llc") or len(args) < 2:
            fail("unknown or incomplete option " + args[0] + " (--min-deg DEG, --llc PATH, -- ALIGN OPTIONS)", 2)
        if args[0] == "--min-deg":
            try:
                min_deg = float(args[1])
            except ValueError:
                min_deg = float("nan")
            if not (min_deg >= 0.0 and math.isfinite(min_deg)):
                fail("--min-deg must be a number >= 0", 2)
        else:
            llc = args[1]
        args = args[2:]
    if llc is None:
        llc = shutil.which("llc") or "llc"
    return run, log, min_deg, llc, extra


def read_steps(run):
    path = os.path.join(run, "odometry_steps.csv")
    if not os.path.isfile(path):
        fail("no " + path + " (llc slam --evaluate or --truth writes it)")
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    for column in ("keyframe", "scan_index", "error_theta"):
        if rows and column not in rows[0]:
            fail(path + ": no column " + column + " (a run without a truth has no step errors)")
    steps, scan_of = [], {0: 0}
    for row in rows:
        try:
            keyframe, scan, error = int(row["keyframe"]), int(row["scan_index"]), float(row["error_theta"])
        except ValueError:
            fail(path + ": keyframe " + row.get("keyframe", "?") + ": not a number")
        scan_of[keyframe] = scan
        if keyframe - 1 in scan_of and math.isfinite(error):
            steps.append((keyframe, scan_of[keyframe - 1], scan, error))
    if not steps:
        fail(path + ": no keyframe step with a heading error")
    return steps


def percentile(values, share):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))] if ordered else float("nan")


def main(argv):
    run, log, min_deg, llc, extra = parse(argv)
    if not os.path.isfile(log):
        fail("no log " + log)
    steps = read_steps(run)
    work = tempfile.mkdtemp(prefix="step_truth_check.")
    try:
        pairs = os.path.join(work, "pairs.csv")
        with open(pairs, "w") as handle:
            handle.write("a,b,label\n")
            for _, a, b, _ in steps:
                handle.write("%d,%d,1\n" % (a, b))
        aligned = os.path.join(work, "align.csv")
        command = [llc, "align", "--data", log + ":" + pairs, "--out", aligned, "--truth-check"] + extra
        try:
            done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        except OSError as error:
            fail("cannot run " + llc + ": " + str(error))
        if done.returncode != 0:
            fail("llc align failed: " + done.stderr.strip()[-400:])
        with open(aligned, newline="") as handle:
            result = {(int(r["a"]), int(r["b"])): r for r in csv.DictReader(handle)}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print("keyframe,scan_a,scan_b,run_heading_error_deg,icp_from_reference_moved_m,icp_from_reference_moved_deg,"
          "fit_at_reference,fit_where_icp_went,sides_with_run")
    large = sides = 0
    moves = []
    for keyframe, a, b, error in steps:
        row = result.get((a, b))
        if row is None or row["icp_from_truth_converged"] != "1":
            continue
        moved_m, moved_deg = float(row["icp_from_truth_error_m"]), float(row["icp_from_truth_error_deg"])
        moves.append(moved_deg)
        error_deg = math.degrees(error)
        if abs(error_deg) < min_deg:
            continue
        large += 1
        fit_reference, fit_icp = float(row["truth_fit"]), float(row["icp_from_truth_fit"])
        with_run = moved_deg >= 0.5 * abs(error_deg) and fit_icp > fit_reference
        sides += with_run
        print("%d,%d,%d,%.2f,%.3f,%.2f,%.3f,%.3f,%d" % (keyframe, a, b, error_deg, moved_m, moved_deg, fit_reference,
                                                       fit_icp, with_run))
    print("steps=%d steps_aligned_from_reference=%d" % (len(steps), len(moves)))
    print("steps_off_by_min_deg=%d (heading off the reference by %.2f deg or more)" % (large, min_deg))
    print("steps_siding_with_run=%d (of those, ICP from the reference's step moves half the error or more and fits better)"
          % sides)
    print("icp_move_from_reference_deg_median=%.3f p90=%.3f (over every step)" % (percentile(moves, 0.5),
                                                                                  percentile(moves, 0.9)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
