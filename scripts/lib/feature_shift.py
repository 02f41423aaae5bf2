#!/usr/bin/env python3
"""How far each feature moves when a log's scans are resampled (llc features, then llc
features --augment KIND), in units of its spread over the log's scans: |median shift| / std.
With a model file, also the share of the model's stump weight (alpha) on each listed feature.
  feature_shift.py NATIVE.csv RESAMPLED.csv [--model MODEL.yaml] [--top 8]"""
import argparse
import csv
import re
import statistics


def load(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0][2:], [[float(v) for v in row[2:]] for row in rows[1:]]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("native")
    parser.add_argument("resampled")
    parser.add_argument("--model")
    parser.add_argument("--top", type=int, default=8)
    args = parser.parse_args()
    names, native = load(args.native)
    resampled_names, resampled = load(args.resampled)
    if names != resampled_names or len(native) != len(resampled):
        raise SystemExit("feature_shift.py: the two files hold other features or other scans")
    weight = {}
    if args.model:  # stumps are written one per line: {feature: I, name: N, ..., alpha: A}
        with open(args.model) as f:
            for name, alpha in re.findall(r"name: ([a-z0-9_]+),.*alpha: ([-0-9.e+]+)", f.read()):
                weight[name] = weight.get(name, 0.0) + float(alpha)
    total = sum(weight.values()) or 1.0
    shifts = []
    for j, name in enumerate(names):
        column = [row[j] for row in native]
        spread = statistics.pstdev(column) or 1e-12
        median = statistics.median(b[j] - a[j] for a, b in zip(native, resampled))
        shifts.append((abs(median) / spread, name))
    shifts.sort(reverse=True)
    print("%-28s %10s %14s" % ("feature", "shift/std", "model_weight"))
    for shift, name in shifts[: args.top]:
        print("%-28s %10.2f %14.3f" % (name, shift, weight.get(name, 0.0) / total))
    print("largest shift among the others: %.2f" % shifts[args.top][0] if len(shifts) > args.top else "")


if __name__ == "__main__":
    main()
