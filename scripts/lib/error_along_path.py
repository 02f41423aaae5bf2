#!/usr/bin/env python3
"""Where along the drive a map is wrong: the keyframes of an `llc slam --truth` (or `--evaluate`
with a truth) run against their true poses, after the rigid alignment report.txt's rms_error_m
uses, block by block of keyframes, with the loops applied there and the returns to a place left open.

  scripts/lib/error_along_path.py RUN_DIR [--block 25] [--radius 3] [--gap 30]

RUN_DIR holds trajectory.csv, truth.csv and loops.csv (llc slam --out DIR --truth LOG). A block
row: keyframes k..k+block-1, the mean error vector and its length (m), the RMS of the block, the
applied loops with an end in the block, and its keyframes that come back to a place (a keyframe
at least `gap` older within `radius` m by the truth, in any heading: wider than the true
revisits llc slam counts, within 1.5 m and 45 degrees) that no applied loop touches ("open").
Last, the open ones grouped into runs of consecutive keyframes with the keyframes they come
back to, and the mean heading between them: near 180 degrees, the robot went the other way
along the old path and its scanner (if it sees less than all around) looks at the other side.
"""
import csv
import math
import sys


def main(argv):
    if not argv or argv[0].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    run, block, radius, gap = argv[0], 25, 3.0, 30
    args = argv[1:]
    while args:
        flag, value = args[0], args[1] if len(args) > 1 else None
        if value is None or flag not in ("--block", "--radius", "--gap"):
            print(__doc__.strip(), file=sys.stderr)
            return 2
        try:
            if flag == "--block":
                block = int(value)
            elif flag == "--radius":
                radius = float(value)
            else:
                gap = int(value)
        except ValueError:
            block = 0
        if block < 1 or not radius > 0 or gap < 1:
            print("error_along_path: %s %s: --block and --gap must be whole numbers >= 1, --radius > 0 m" % (flag, value),
                  file=sys.stderr)
            return 2
        args = args[2:]
    try:
        keyframes = list(csv.DictReader(open(run + "/trajectory.csv")))
        truth = {int(r["index"]): r for r in csv.DictReader(open(run + "/truth.csv"))}
        loops = [r for r in csv.DictReader(open(run + "/loops.csv")) if r["accepted"] == "1"]
        scans = [int(r["index"]) for r in keyframes]
        if any(s not in truth for s in scans):
            raise ValueError("a keyframe's scan has no truth pose in truth.csv")
        est = [(float(r["x"]), float(r["y"])) for r in keyframes]
        ref = [(float(truth[s]["x"]), float(truth[s]["y"])) for s in scans]
        heading = [float(truth[s]["theta"]) for s in scans]
        if not est:
            raise ValueError("trajectory.csv holds no keyframe")
        if not all(math.isfinite(v) for p in est + ref for v in p) or not all(math.isfinite(h) for h in heading):
            raise ValueError("a pose that is not finite (nan or inf)")
    except (OSError, KeyError, TypeError, ValueError) as error:  # missing file, column or value; not a number
        print("error_along_path: %s: %s" % (run, error), file=sys.stderr)
        return 1
    n = len(est)
    # Rigid alignment (rotation and translation, least squares), as llc slam's rms_error_m.
    me = (sum(p[0] for p in est) / n, sum(p[1] for p in est) / n)
    mr = (sum(q[0] for q in ref) / n, sum(q[1] for q in ref) / n)
    cos_sum = sin_sum = 0.0
    for p, q in zip(est, ref):
        a, b = (p[0] - me[0], p[1] - me[1]), (q[0] - mr[0], q[1] - mr[1])
        cos_sum += a[0] * b[0] + a[1] * b[1]
        sin_sum += a[0] * b[1] - a[1] * b[0]
    angle = math.atan2(sin_sum, cos_sum)
    c, s = math.cos(angle), math.sin(angle)
    errors = []
    for p, q in zip(est, ref):
        a = (p[0] - me[0], p[1] - me[1])
        errors.append((c * a[0] - s * a[1] + mr[0] - q[0], s * a[0] + c * a[1] + mr[1] - q[1]))
    rms = math.sqrt(sum(e[0] ** 2 + e[1] ** 2 for e in errors) / n)
    # loops.csv names scans; a keyframe is touched by a loop with either end at its scan.
    index_of = {scan: k for k, scan in enumerate(scans)}
    touched = {}
    for r in loops:
        for end in (int(r["a"]), int(r["b"])):
            if end in index_of:
                touched[index_of[end]] = touched.get(index_of[end], 0) + 1
    revisited = {}
    for k in range(n):
        best = None
        for j in range(0, k - gap + 1):
            d = math.hypot(ref[k][0] - ref[j][0], ref[k][1] - ref[j][1])
            if d <= radius and (best is None or d < best[0]):
                best = (d, j)
        if best:
            revisited[k] = best[1]
    print("rms_error_m=%.4g over %d keyframes (rigid alignment)" % (rms, n))
    print("%-11s %-16s %6s %6s %6s %5s %s" % ("keyframes", "mean_error_m", "|mean|", "rms", "loops", "open", "true position"))
    for k in range(0, n, block):
        part = range(k, min(n, k + block))
        ex = sum(errors[i][0] for i in part) / len(part)
        ey = sum(errors[i][1] for i in part) / len(part)
        part_rms = math.sqrt(sum(errors[i][0] ** 2 + errors[i][1] ** 2 for i in part) / len(part))
        loops_here = sum(touched.get(i, 0) for i in part)
        open_here = sum(1 for i in part if i in revisited and i not in touched)
        print("%4d-%-6d (%+6.2f,%+6.2f) %6.2f %6.2f %6d %5d (%.1f, %.1f)" %
              (k, part[-1], ex, ey, math.hypot(ex, ey), part_rms, loops_here, open_here, ref[k][0], ref[k][1]))
    runs = []
    for k in sorted(i for i in revisited if i not in touched):
        if runs and k == runs[-1][-1][0] + 1:
            runs[-1].append((k, revisited[k]))
        else:
            runs.append([(k, revisited[k])])
    print("open returns to a place: %d keyframes in %d runs; runs of 5 or more:" % (sum(len(r) for r in runs), len(runs)))
    for r in runs:
        if len(r) < 5:
            continue
        turn = sum(abs(math.remainder(heading[k] - heading[j], 2 * math.pi)) for k, j in r) / len(r)
        print("  keyframes %d-%d come back to %d..%d (%d keyframes, heading apart %.0f deg on average)" %
              (r[0][0], r[-1][0], r[0][1], r[-1][1], len(r), math.degrees(turn)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
