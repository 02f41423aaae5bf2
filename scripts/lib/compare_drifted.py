#!/usr/bin/env python3
"""Two versions (or settings) on the drifted logs, each run several times with a change that
should not matter (e.g. odometry/keyframe_distance 0.98, 1.0 and 1.02 m): the run-to-run noise
of every figure, and which figures moved beyond it.

Each input is the printout of one `scripts/drifted_logs ... --seeds 1,2,3` run. A drifted run
(drift, log, seed) is WORSE when its RMS in every "after" run is above its RMS in every
"before" run (the ranges do not overlap), better the other way round; the pooled figures are
given per run, so their spread is the noise.

Usage: scripts/lib/compare_drifted.py --before RUN.txt ... --after RUN.txt ...
"""
import argparse
import sys


def parse(path):
    """{(drift, log, seed): (rms_m, true_revisits, closed, wrong)} from one drifted_logs printout."""
    runs = {}
    try:
        f = open(path)
    except OSError as e:
        sys.exit("%s: %s" % (path, e.strerror))
    with f:
        for line in f:
            fields = line.split()
            if len(fields) != 10 or fields[0] not in ("moderate", "strong") or not fields[2].isdigit():
                continue
            try:
                runs[(fields[0], fields[1], int(fields[2]))] = (float(fields[8]), int(fields[4]), int(fields[5]), int(fields[6]))
            except ValueError:
                sys.exit("%s: unreadable row: %s" % (path, line.strip()))
    if not runs:
        sys.exit("%s: no drifted_logs rows" % path)
    return runs


def pooled(runs):
    rms = [r[0] for r in runs.values()]
    revisits = sum(r[1] for r in runs.values())
    closed = sum(r[2] for r in runs.values())
    wrong = sum(r[3] for r in runs.values())
    return sum(rms) / len(rms), 100.0 * closed / revisits if revisits else float("nan"), wrong


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", nargs="+", required=True, help="drifted_logs printouts of the first version")
    parser.add_argument("--after", nargs="+", required=True, help="drifted_logs printouts of the second version")
    args = parser.parse_args()
    before = [parse(p) for p in args.before]
    after = [parse(p) for p in args.after]
    keys = sorted(set().union(*before, *after))
    missing = [k for k in keys if any(k not in r for r in before + after)]
    if missing:
        sys.exit("runs missing from some printouts: %s" % ", ".join("%s %s seed %d" % k for k in missing))
    print("%-9s %-18s %4s  %-24s  %-24s  %s" % ("drift", "log", "seed", "RMS before (m)", "RMS after (m)", "verdict"))
    worse = better = 0
    for key in keys:
        b = [r[key][0] for r in before]
        a = [r[key][0] for r in after]
        verdict = ""
        if min(a) > max(b):
            verdict, worse = "WORSE beyond noise", worse + 1
        elif max(a) < min(b):
            verdict, better = "better beyond noise", better + 1
        print("%-9s %-18s %4d  %-24s  %-24s  %s" % (key[0], key[1], key[2], " / ".join("%.3f" % v for v in b),
                                                  " / ".join("%.3f" % v for v in a), verdict))
    for drift in sorted({k[0] for k in keys}):
        for label, runs in (("before", before), ("after", after)):
            figures = [pooled({k: v for k, v in r.items() if k[0] == drift}) for r in runs]
            print("%s %s: mean RMS %s m; revisits closed %s %%; wrong loops %s" % (
                drift, label, " / ".join("%.3f" % f[0] for f in figures), " / ".join("%.1f" % f[1] for f in figures),
                " / ".join("%d" % f[2] for f in figures)))
    print("drifted runs worse beyond noise: %d; better beyond noise: %d; of %d" % (worse, better, len(keys)))


if __name__ == "__main__":
    main()
