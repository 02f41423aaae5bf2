#!/usr/bin/env python3
"""Would the loops the back end's gate refused agree among themselves? Pairwise consistency
(as in PCM, Mangelson et al. 2018) of the loops of an `llc slam --truth` run: for two loops
A (a1 -> a2) and B (b1 -> b2) whose ends lie near each other along the keyframe chain, the
cycle a1 -> a2 (A) -> b2 (the front end's chain) -> b1 (B backwards) -> a1 (the chain) should
close. Loops that the gate refused because the chain between their ends is wrong, but that
agree with each other, are what a consensus rule would apply; this says whether the wrong ones
agree as well.

  scripts/lib/loop_consensus.py RUN_DIR [--near 30] [--chi2 11.34] [--loop-sigma-m 0.05] [--loop-sigma-rad 0.02]

RUN_DIR holds trajectory.csv, loops.csv (with x,y,theta,innovation_chi2) and
odometry_steps.csv (llc slam --out DIR --truth LOG, or --evaluate); truth.csv, if there, judges
each loop (off the truth by over 1 m or 15 deg: false). Two loops are compared when both pairs
of ends are at most --near keyframes apart. The cycle's error is weighed against the chain's
step covariances (odometry_steps.csv's sigmas, compounded along the chain; isotropic in
position, their trace) and two loop covariances of --loop-sigma-m / --loop-sigma-rad, as a
chi-square of 3 degrees of freedom: consistent below --chi2 (11.34: 99%).
First `key=value` lines (counts; with truth.csv, the refused loops' mean count of consistent
refused partners, true and false ones apart), then one row per loop the gate refused.
"""
import csv
import math
import signal
import sys


def fail(message, code=1):
    print("loop_consensus: %s" % message, file=sys.stderr)
    return code


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def between(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


def wrap(angle):
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def number(row, key, path):
    value = float(row[key])
    if not math.isfinite(value):
        raise ValueError("%s: %s is not finite (%s)" % (path, key, row[key]))
    return value


def read_run(run):
    keyframe_of = {}
    for k, row in enumerate(csv.DictReader(open(run + "/trajectory.csv"))):
        keyframe_of[int(row["index"])] = k
    # The chain: keyframe k = keyframe k-1 composed with step k; its position and heading
    # variances summed along it (a diagnostic's isotropic approximation).
    chain, position_var, heading_var = [(0.0, 0.0, 0.0)], [0.0], [0.0]
    path = run + "/odometry_steps.csv"
    for expected, row in enumerate(csv.DictReader(open(path)), start=1):
        if int(row["keyframe"]) != expected:
            raise ValueError("%s: keyframe %s where %d was due (steps in order, one per keyframe)" % (path, row["keyframe"], expected))
        step = tuple(number(row, key, path) for key in ("dx", "dy", "dtheta"))
        chain.append(compose(chain[-1], step))
        position_var.append(position_var[-1] + number(row, "sigma_x", path) ** 2 + number(row, "sigma_y", path) ** 2)
        heading_var.append(heading_var[-1] + number(row, "sigma_theta", path) ** 2)
    truth = None
    try:
        truth = {int(r["index"]): (float(r["x"]), float(r["y"]), float(r["theta"]))
                 for r in csv.DictReader(open(run + "/truth.csv"))}
    except FileNotFoundError:
        pass
    loops = []
    path = run + "/loops.csv"
    for row in csv.DictReader(open(path)):
        if "innovation_chi2" not in row:
            raise ValueError("%s: no innovation_chi2 column (a run of an older llc)" % path)
        if row["x"] == "":
            continue  # never reached the back end
        scan_a, scan_b = int(row["a"]), int(row["b"])
        if scan_a not in keyframe_of or scan_b not in keyframe_of:
            raise ValueError("%s: scan %d or %d is no keyframe of trajectory.csv" % (path, scan_a, scan_b))
        a, b = keyframe_of[scan_a], keyframe_of[scan_b]
        if max(a, b) >= len(chain):
            raise ValueError("%s: keyframe %d has no step in odometry_steps.csv" % (path, max(a, b)))
        loop = {"scan_a": scan_a, "scan_b": scan_b, "a": a, "b": b, "applied": row["accepted"] == "1",
                "pose": tuple(number(row, key, path) for key in ("x", "y", "theta")),
                "chi2": number(row, "innovation_chi2", path), "error_m": None, "error_deg": None, "true": None}
        if truth is not None and scan_a in truth and scan_b in truth:
            t = between(truth[scan_a], truth[scan_b])
            loop["error_m"] = math.hypot(loop["pose"][0] - t[0], loop["pose"][1] - t[1])
            loop["error_deg"] = abs(math.degrees(wrap(loop["pose"][2] - t[2])))
            loop["true"] = loop["error_m"] <= 1.0 and loop["error_deg"] <= 15.0
        loops.append(loop)
    return chain, position_var, heading_var, loops


def main(argv):
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # quiet when piped into head
    if not argv or argv[0].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    run = argv[0]
    settings = {"--near": 30.0, "--chi2": 11.34, "--loop-sigma-m": 0.05, "--loop-sigma-rad": 0.02}
    args = argv[1:]
    while args:
        if args[0] not in settings or len(args) < 2:
            print(__doc__.strip(), file=sys.stderr)
            return 2
        try:
            value = float(args[1])
        except ValueError:
            value = float("nan")
        if not (math.isfinite(value) and value > 0):
            return fail("%s %s: must be a number > 0" % (args[0], args[1]), 2)
        settings[args[0]] = value
        args = args[2:]
    try:
        chain, position_var, heading_var, loops = read_run(run)
    except (OSError, KeyError, TypeError, ValueError) as error:  # missing file, column or value; not a number
        return fail("%s: %s" % (run, error))
    near, threshold = settings["--near"], settings["--chi2"]
    loop_position_var = 2.0 * 2.0 * settings["--loop-sigma-m"] ** 2  # two loops, x and y
    loop_heading_var = 2.0 * settings["--loop-sigma-rad"] ** 2

    def consistent(p, q):
        if abs(p["a"] - q["a"]) > near or abs(p["b"] - q["b"]) > near:
            return False
        d1 = between(chain[p["a"]], chain[q["a"]])
        d2 = between(chain[p["b"]], chain[q["b"]])
        e = between(compose(d1, q["pose"]), compose(p["pose"], d2))
        position = abs(position_var[p["a"]] - position_var[q["a"]]) + abs(position_var[p["b"]] - position_var[q["b"]])
        heading = abs(heading_var[p["a"]] - heading_var[q["a"]]) + abs(heading_var[p["b"]] - heading_var[q["b"]])
        # Isotropic in position: each of x, y gets half the summed trace.
        chi2 = 2.0 * (e[0] ** 2 + e[1] ** 2) / (position + loop_position_var) + e[2] ** 2 / (heading + loop_heading_var)
        return chi2 < threshold

    refused = [loop for loop in loops if not loop["applied"]]
    applied = [loop for loop in loops if loop["applied"]]
    print("loops_weighed=%d applied=%d refused_by_gate=%d" % (len(loops), len(applied), len(refused)))
    rows = []
    for p in refused:
        partners = sum(1 for q in refused if q is not p and consistent(p, q))
        agreeing_applied = sum(1 for q in applied if consistent(p, q))
        rows.append((p, partners, agreeing_applied))
    judged = [row for row in rows if row[0]["true"] is not None]
    if judged:
        for label, want in (("true", True), ("false", False)):
            group = [partners for p, partners, _ in judged if p["true"] == want]
            mean = sum(group) / len(group) if group else float("nan")
            print("refused_%s=%d mean_consistent_refused_partners_%s=%.3g" % (label, len(group), label, mean))
        wrong_applied = sum(1 for loop in applied if loop["true"] is False)
        print("applied_false=%d" % wrong_applied)
    print("a,b,keyframe_a,keyframe_b,innovation_chi2,truth_error_m,truth_error_deg,consistent_refused,consistent_applied")
    for p, partners, agreeing_applied in rows:
        error = "-,-" if p["error_m"] is None else "%.3g,%.3g" % (p["error_m"], p["error_deg"])
        print("%d,%d,%d,%d,%.4g,%s,%d,%d" % (p["scan_a"], p["scan_b"], p["a"], p["b"], p["chi2"], error, partners, agreeing_applied))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
