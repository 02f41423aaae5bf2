#!/usr/bin/env python3
"""Draws one incremental `llc graph` run's latency per step (`--latency-csv`) against the step:
every step a dot (log scale), and the worst so far and the running p99 over the last 1,000 steps
as lines, so that whether an update's cost grows with the map shows at a glance.
Usage: plot_step_latency.py STEPS.csv OUT.png [TITLE]"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def running_p99(values, window):
    """The 99th percentile (nearest rank) of the last `window` values at each step, every
    `window // 10` steps (a sorted window per point: cheap enough for 10^5 steps)."""
    xs, ys = [], []
    stride = max(1, window // 10)
    for end in range(stride, len(values) + 1, stride):
        last = sorted(values[max(0, end - window):end])
        xs.append(end - 1)
        ys.append(last[max(0, int(0.99 * len(last) + 0.999999) - 1)])
    return xs, ys


def main(csv_path, png_path, title):
    with open(csv_path) as f:
        ms = [float(row["ms"]) for row in csv.DictReader(f)]
    if not ms:
        sys.exit("%s: no steps" % csv_path)
    steps = range(len(ms))
    worst, worst_so_far = 0.0, []
    for v in ms:
        worst = max(worst, v)
        worst_so_far.append(worst)
    floor = 1e-4  # ms: steps timed at 0 still show
    fig, ax = plt.subplots(figsize=(9, 4.5))
    ax.scatter(steps, [max(v, floor) for v in ms], s=1, alpha=0.3, color="tab:blue", label="each step", rasterized=True)
    px, py = running_p99(ms, 1000)
    ax.plot(px, [max(v, floor) for v in py], color="tab:orange", label="p99 of the last 1,000 steps")
    ax.plot(steps, worst_so_far, color="tab:red", label="worst so far")
    ax.set_yscale("log")
    ax.set_xlabel("step (edge of the file, in order)")
    ax.set_ylabel("latency (ms)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    print("wrote %s (%d steps, worst %.1f ms at step %d)" % (png_path, len(ms), worst, ms.index(worst)))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) == 4 else sys.argv[1])
