#!/usr/bin/env python3
"""How good must the keyframe steps be for a given map accuracy? The pose graph an `llc slam
--truth` (or `--evaluate`) run ended with (`--save-graph G.g2o`), solved again by `llc graph
--batch` after the headings of chosen odometry steps were replaced: by the reference's own, or
by the reference's plus Gaussian noise of a chosen sigma (a step estimator of that precision).
The loops stay as the run applied them. Prints, for each variant, the keyframes' RMS error
against the reference after a rigid alignment (as `rms_error_m` in the run's report.txt).

  scripts/lib/graph_oracle.py RUN_DIR G.g2o [--keyframes K1,K2,...]
                             [--noise-rad S] [--noise-sigma-scale F] [--seeds 5] [--llc PATH]

RUN_DIR holds the run's trajectory.csv (keyframe -> scan), truth.csv (the reference pose of
every scan) and odometry_steps.csv (each step's sigma_theta). Rows:
  saved                   the graph as written, solved again (about the run's rms_error_m: the
                          run's poses are the incremental filter's, these a batch optimum)
  reference_headings      every step's heading the reference's, its translation the run's
  reference_translations  every step's translation the reference's, its heading the run's
  reference_steps         both: every step the reference's (only the loops left as measured)
  reference_listed(n)     only the headings of the steps into the --keyframes given (e.g. the
                          ones scripts/lib/step_truth_check.py lists, by whose side the scans take)
  noise ... seed i        every step's heading the reference's plus Gaussian noise, its
                          translation the run's: of sigma S (--noise-rad) or of F times the step's
                          own sigma_theta (--noise-sigma-scale: an unbiased step estimator as
                          precise as the run's step model claims), each given; one row per seed
                          1..N, then their median and largest
The loops always stay as the run applied them.
"""
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile


def fail(message, code=1):
    print("graph_oracle: " + message, file=sys.stderr)
    sys.exit(code)


def parse(argv):
    if len(argv) < 2 or argv[0].startswith("-") or argv[1].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        sys.exit(2)
    opts = {"run": argv[0], "graph": argv[1], "keyframes": [], "noise": None, "sigma_scale": None, "seeds": 5, "llc": None}
    args = argv[2:]
    while args:
        if args[0] not in ("--keyframes", "--noise-rad", "--noise-sigma-scale", "--seeds", "--llc") or len(args) < 2:
            fail("unknown or incomplete option " + args[0] +
                 " (--keyframes K,..., --noise-rad S, --noise-sigma-scale F, --seeds N, --llc PATH)", 2)
        name, value = args[0], args[1]
        try:
            if name == "--keyframes":
                opts["keyframes"] = [int(k) for k in value.split(",") if k != ""]
                if any(k < 1 for k in opts["keyframes"]):
                    raise ValueError
            elif name in ("--noise-rad", "--noise-sigma-scale"):
                key = "noise" if name == "--noise-rad" else "sigma_scale"
                opts[key] = float(value)
                if not (opts[key] >= 0.0 and math.isfinite(opts[key])):
                    raise ValueError
            elif name == "--seeds":
                opts["seeds"] = int(value)
                if opts["seeds"] < 1:
                    raise ValueError
            else:
                opts["llc"] = value
        except ValueError:
            fail(name + ": bad value " + value + " (keyframes >= 1, a sigma >= 0, seeds >= 1)", 2)
        args = args[2:]
    if opts["llc"] is None:
        opts["llc"] = shutil.which("llc") or "llc"
    return opts


def read_csv_rows(path):
    try:
        with open(path) as f:
            lines = [line.strip() for line in f if line.strip()]
    except OSError as e:
        fail("cannot read " + path + ": " + e.strerror)
    if not lines:
        fail(path + ": empty")
    header = lines[0].split(",")
    rows = []
    for number, line in enumerate(lines[1:], 2):
        fields = line.split(",")
        if len(fields) < len(header):
            fail("%s:%d: %d fields, %d expected" % (path, number, len(fields), len(header)))
        try:
            rows.append({h: float(v) for h, v in zip(header, fields)})
        except ValueError:
            fail("%s:%d: not a number" % (path, number))  # empty fields included
    return rows


def read_g2o(path):
    poses, edges = {}, []
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                p = line.split()
                if not p or p[0].startswith("#"):
                    continue
                try:
                    if p[0] == "VERTEX_SE2" and len(p) >= 5:
                        poses[int(p[1])] = tuple(float(v) for v in p[2:5])
                    elif p[0] == "EDGE_SE2" and len(p) >= 12:
                        edges.append([int(p[1]), int(p[2])] + [float(v) for v in p[3:12]])
                    else:
                        raise ValueError
                except ValueError:
                    fail("%s:%d: not a VERTEX_SE2 or EDGE_SE2 line" % (path, number))
    except OSError as e:
        fail("cannot read " + path + ": " + e.strerror)
    if sorted(poses) != list(range(len(poses))) or not poses:
        fail(path + ": vertex ids are not 0..n-1")
    return [poses[i] for i in range(len(poses))], edges


def write_g2o(path, poses, edges):
    with open(path, "w") as f:
        for i, (x, y, t) in enumerate(poses):
            f.write("VERTEX_SE2 %d %.17g %.17g %.17g\n" % (i, x, y, t))
        for e in edges:
            f.write("EDGE_SE2 %d %d " % (e[0], e[1]) + " ".join("%.17g" % v for v in e[2:]) + "\n")


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def aligned_rms(estimate, truth):
    """As llc::alignedRmsError: the rigid motion that best lays the estimate on the truth."""
    n = len(estimate)
    ex = sum(p[0] for p in estimate) / n
    ey = sum(p[1] for p in estimate) / n
    tx = sum(p[0] for p in truth) / n
    ty = sum(p[1] for p in truth) / n
    dot = cross = 0.0
    for a, b in zip(estimate, truth):
        ax, ay, bx, by = a[0] - ex, a[1] - ey, b[0] - tx, b[1] - ty
        dot += ax * bx + ay * by
        cross += ax * by - ay * bx
    angle = math.atan2(cross, dot) if n > 1 else 0.0
    c, s = math.cos(angle), math.sin(angle)
    total = 0.0
    for a, b in zip(estimate, truth):
        mx = c * (a[0] - ex) - s * (a[1] - ey) + tx
        my = s * (a[0] - ex) + c * (a[1] - ey) + ty
        total += (mx - b[0]) ** 2 + (my - b[1]) ** 2
    return math.sqrt(total / n)


def solve(opts, tmp, name, poses, edges):
    src, out = os.path.join(tmp, name + ".g2o"), os.path.join(tmp, name + "_solved.g2o")
    write_g2o(src, poses, edges)
    result = subprocess.run([opts["llc"], "graph", "--g2o", src, "--out", out, "--batch", "--least-squares"], capture_output=True, text=True)
    if result.returncode != 0:
        fail("llc graph failed on " + name + ": " + result.stderr.strip())
    solved, _ = read_g2o(out)
    return solved


def main(argv):
    opts = parse(argv)
    trajectory = read_csv_rows(os.path.join(opts["run"], "trajectory.csv"))
    truth_rows = read_csv_rows(os.path.join(opts["run"], "truth.csv"))
    truth_of_scan = {int(r["index"]): (r["x"], r["y"], r["theta"]) for r in truth_rows}
    try:
        truth = [truth_of_scan[int(r["index"])] for r in trajectory]
    except KeyError as e:
        fail("truth.csv has no pose for scan %s of trajectory.csv (not the same run?)" % e)
    poses, edges = read_g2o(opts["graph"])
    if len(poses) != len(truth):
        fail("%s has %d poses, %s/trajectory.csv %d keyframes (not the same run?)"
             % (opts["graph"], len(poses), opts["run"], len(truth)))
    # The step into keyframe k: the first edge from k-1 to k (the ESDF's augmentation).
    step_edge = {}
    for i, e in enumerate(edges):
        if e[1] == e[0] + 1 and e[1] not in step_edge:
            step_edge[e[1]] = i
    missing = [k for k in opts["keyframes"] if k not in step_edge]
    if missing:
        fail("no step edge into keyframe(s) " + ",".join(map(str, missing)))
    true_turn = {k: wrap(truth[k][2] - truth[k - 1][2]) for k in step_edge}
    true_shift = {}  # keyframe k in k-1's frame, by the reference
    for k in step_edge:
        (x0, y0, t0), (x1, y1, _) = truth[k - 1], truth[k]
        c, s = math.cos(t0), math.sin(t0)
        true_shift[k] = (c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0))

    def edited(headings=None, shifts=None):
        out = [list(e) for e in edges]
        for k, theta in (headings or {}).items():
            out[step_edge[k]][4] = theta
        for k, (dx, dy) in (shifts or {}).items():
            out[step_edge[k]][2:4] = [dx, dy]
        return out

    noise_models = []  # (label, sigma of each step's heading noise)
    if opts["noise"] is not None:
        noise_models.append(("noise %.4g rad" % opts["noise"], {k: opts["noise"] for k in step_edge}))
    if opts["sigma_scale"] is not None:
        steps = read_csv_rows(os.path.join(opts["run"], "odometry_steps.csv"))
        sigma = {int(r["keyframe"]): opts["sigma_scale"] * r["sigma_theta"] for r in steps}
        if set(sigma) != set(step_edge):
            fail("odometry_steps.csv does not list every step of the graph (not the same run?)")
        noise_models.append(("noise %.4g x sigma_theta" % opts["sigma_scale"], sigma))

    print("keyframes=%d steps=%d loops=%d" % (len(poses), len(step_edge), len(edges) - len(step_edge)))
    with tempfile.TemporaryDirectory() as tmp:
        rows = [("saved", edges), ("reference_headings", edited(true_turn)),
                ("reference_translations", edited(shifts=true_shift)), ("reference_steps", edited(true_turn, true_shift))]
        if opts["keyframes"]:
            rows.append(("reference_listed(%d)" % len(opts["keyframes"]), edited({k: true_turn[k] for k in opts["keyframes"]})))
        for name, graph_edges in rows:
            print("%-26s rms_error_m=%.4f" % (name, aligned_rms(solve(opts, tmp, "variant", poses, graph_edges), truth)))
        for label, noise_sigma in noise_models:
            errors = []
            for seed in range(1, opts["seeds"] + 1):
                rng = random.Random(seed)
                noisy = {k: true_turn[k] + rng.gauss(0.0, noise_sigma[k]) for k in sorted(step_edge)}
                rms = aligned_rms(solve(opts, tmp, "noise", poses, edited(noisy)), truth)
                errors.append(rms)
                print("%-26s rms_error_m=%.4f" % ("%s seed %d" % (label, seed), rms))
            errors.sort()
            print("%s: median rms_error_m=%.4f largest=%.4f of %d seeds" % (label, errors[len(errors) // 2], errors[-1], len(errors)))


if __name__ == "__main__":
    main(sys.argv[1:])
