#!/usr/bin/env python3
"""How far off ICP's own steps are, without a truth: each keyframe k of a run aligned to k+1,
k+1 to k+2 and k to k+2 (`llc align`, no initial guess), and the triangle's closure (the direct
k -> k+2 against the two steps composed). With three independent errors of the same size the
heading closure is sqrt(3) times one pair's; an error of a scan's own (it enters two pairs
with opposite signs) cancels, so the per-pair figure is a lower bound. With the run's truth.csv
(llc slam --truth) the pairs k -> k+1 are also compared with the truth.

  scripts/lib/triangle_closure.py RUN_DIR LOG [--llc PATH] [--keep DIR] [-- ALIGN OPTIONS...]

RUN_DIR holds trajectory.csv (its `index` column: the keyframes' scan indices in LOG) and, if
there, truth.csv. LOG is the log the run read (CARMEN or bag, as `llc align --data` takes it).
Triangles with an alignment that turns over 1 rad (a corridor's mirror image) or whose three
alignments disagree by more than 0.1 rad or 0.5 m (a gross miss of the search with no guess)
are counted and left out. Options after `--` go to `llc align` (e.g.
--aligner/icp/huber_delta 0.02).
"""
import csv
import math
import os
import shutil
import subprocess
import sys
import tempfile

GROSS_RAD, GROSS_M = 0.1, 0.5
# No two keyframes two steps apart turn this much (a keyframe comes at keyframe_angle, 0.35
# rad): a pair beyond it is the search's mirror image of a corridor, and two such mirrored
# pairs can close a triangle as well as the true ones.
MAX_TURN_RAD = 1.0


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def compose(p, q):
    c, s = math.cos(p[2]), math.sin(p[2])
    return (p[0] + c * q[0] - s * q[1], p[1] + s * q[0] + c * q[1], wrap(p[2] + q[2]))


def between(p, q):
    dx, dy = q[0] - p[0], q[1] - p[1]
    c, s = math.cos(p[2]), math.sin(p[2])
    return (c * dx + s * dy, -s * dx + c * dy, wrap(q[2] - p[2]))


def rms(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else float("nan")


def read_poses(path, key):
    """{row[key]: (x, y, theta)} of a CSV of poses; ValueError naming the file when malformed."""
    try:
        with open(path) as f:
            return {int(r[key]): (float(r["x"]), float(r["y"]), float(r["theta"])) for r in csv.DictReader(f)}
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError("%s: not a CSV of %s,x,y,theta poses (%s)" % (path, key, error))


def main(argv):
    if len(argv) < 2 or argv[0].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    run, log = argv[0], argv[1]
    rest = argv[2:]
    align_options = []
    if "--" in rest:
        align_options = rest[rest.index("--") + 1:]
        rest = rest[:rest.index("--")]
    here = os.path.dirname(os.path.abspath(__file__))
    llc = os.path.join(here, "..", "..", "build", ".ws", "devel", "lib", "laser_loop_closure", "llc")
    keep = None
    while rest:
        if len(rest) < 2 or rest[0] not in ("--llc", "--keep"):
            print(__doc__.strip(), file=sys.stderr)
            return 2
        if rest[0] == "--llc":
            llc = rest[1]
        else:
            keep = rest[1]
        rest = rest[2:]
    trajectory = os.path.join(run, "trajectory.csv")
    if not os.path.isfile(trajectory):
        print("triangle_closure: no %s" % trajectory, file=sys.stderr)
        return 1
    try:
        with open(trajectory) as f:
            scans = [int(row["index"]) for row in csv.DictReader(f)]
    except (KeyError, TypeError, ValueError) as error:
        print("triangle_closure: %s: no integer index column (%s)" % (trajectory, error), file=sys.stderr)
        return 1
    if len(scans) < 3:
        print("triangle_closure: fewer than 3 keyframes in %s" % trajectory, file=sys.stderr)
        return 1
    work = keep or tempfile.mkdtemp(prefix="triangle_closure_")
    os.makedirs(work, exist_ok=True)
    try:
        return measure(run, log, llc, align_options, scans, work)
    except ValueError as error:
        print("triangle_closure: %s" % error, file=sys.stderr)
        return 1
    finally:
        if not keep:
            shutil.rmtree(work, ignore_errors=True)


def measure(run, log, llc, align_options, scans, work):
    """Aligns the triangles' pairs in `work` and prints the figures; 0, or 1 when llc fails."""
    pairs_path, aligned_path = os.path.join(work, "pairs.csv"), os.path.join(work, "aligned.csv")
    wanted = []
    for k in range(len(scans) - 2):
        a, b, c = scans[k], scans[k + 1], scans[k + 2]
        wanted += [(a, b), (b, c), (a, c)]
    with open(pairs_path, "w") as f:
        f.write("a,b,label\n")
        for a, b in dict.fromkeys(wanted):
            f.write("%d,%d,1\n" % (a, b))
    command = [llc, "align", "--data", "%s:%s" % (log, pairs_path), "--out", aligned_path] + align_options
    done = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        print("triangle_closure: %s failed: %s" % (" ".join(command), done.stderr.strip()), file=sys.stderr)
        return 1
    with open(aligned_path) as f:
        aligned = {(int(r["a"]), int(r["b"])): (float(r["x"]), float(r["y"]), float(r["theta"])) for r in csv.DictReader(f)}
    truth_path = os.path.join(run, "truth.csv")
    truth = read_poses(truth_path, "index") if os.path.isfile(truth_path) else None
    heading, position, gross = [], [], 0
    truth_heading, truth_position = [], []
    for k in range(len(scans) - 2):
        a, b, c = scans[k], scans[k + 1], scans[k + 2]
        if (a, b) not in aligned or (b, c) not in aligned or (a, c) not in aligned:
            gross += 1
            continue
        if not all(abs(aligned[pair][2]) <= MAX_TURN_RAD for pair in ((a, b), (b, c), (a, c))):
            gross += 1
            continue
        composed = compose(aligned[(a, b)], aligned[(b, c)])
        direct = aligned[(a, c)]
        dh = wrap(direct[2] - composed[2])
        dp = math.hypot(direct[0] - composed[0], direct[1] - composed[1])
        if not (abs(dh) <= GROSS_RAD and dp <= GROSS_M):  # also a NaN (a pair with no pose)
            gross += 1
            continue
        heading.append(dh)
        position.append(dp)
        if truth and a in truth and b in truth:
            t = between(truth[a], truth[b])
            step = aligned[(a, b)]
            truth_heading.append(wrap(step[2] - t[2]))
            truth_position.append(math.hypot(step[0] - t[0], step[1] - t[1]))
    print("triangles=%d  (keyframes k, k+1, k+2 of %s)" % (len(scans) - 2, os.path.join(run, "trajectory.csv")))
    print("triangles_gross=%d  (an alignment missing or turning over %g rad, or the three disagreeing by over %g rad or %g m)" %
          (gross, MAX_TURN_RAD, GROSS_RAD, GROSS_M))
    print("closure_heading_rms_rad=%.5f" % rms(heading))
    print("closure_position_rms_m=%.4f" % rms(position))
    print("per_pair_heading_rad_at_least=%.5f  (closure / sqrt(3))" % (rms(heading) / math.sqrt(3)))
    print("per_pair_position_m_at_least=%.4f" % (rms(position) / math.sqrt(3)))
    if truth_heading:
        print("truth_pairs=%d  (k -> k+1 of the triangles kept, against truth.csv)" % len(truth_heading))
        print("truth_heading_rms_rad=%.5f" % rms(truth_heading))
        print("truth_position_rms_m=%.4f" % rms(truth_position))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
