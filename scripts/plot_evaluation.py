#!/usr/bin/env python3
"""Draws the PNG plots of an `llc evaluate` output folder: roc.png, error_vs_rounds.png and
feature_removal.png from the CSV files beside them. Usage: plot_evaluation.py DIR"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main(folder):
    made = []
    summary = ""
    if os.path.exists(os.path.join(folder, "summary.txt")):
        summary = open(os.path.join(folder, "summary.txt")).read()
    roc = read(os.path.join(folder, "roc.csv"))
    fa = [float(r["false_alarm"]) for r in roc]
    det = [float(r["detection"]) for r in roc]
    validated = None
    if os.path.exists(os.path.join(folder, "roc_validated.csv")):
        rows = read(os.path.join(folder, "roc_validated.csv"))
        validated = ([float(r["false_alarm"]) for r in rows], [float(r["detection"]) for r in rows])
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, limit in zip(axes, (1.0, 0.1)):
        ax.plot(fa, det, "b-", label="strong classifier (cross-validated)")
        if validated:
            ax.plot(validated[0], validated[1], "r--", label="+ alignment and shape validation")
        ax.axvline(0.01, color="grey", ls=":", label="1% false alarm")
        ax.set_xlim(0, limit)
        ax.set_ylim(0, 1.01)
        ax.set_xlabel("false alarm rate")
        ax.set_ylabel("detection rate")
        ax.grid(alpha=0.3)
    axes[0].set_title("ROC")
    axes[1].set_title("ROC, false alarm up to 10%")
    axes[1].legend(loc="lower right")
    fig.suptitle(os.path.basename(os.path.abspath(folder)) + "  " +
                 " ".join(l for l in summary.splitlines() if l.startswith(("detection_at_1", "auc="))))
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "roc.png"), dpi=100)
    made.append("roc.png")
    plt.close(fig)

    curve_path = os.path.join(folder, "error_vs_rounds.csv")
    if os.path.exists(curve_path):
        rows = read(curve_path)
        t = [int(r["rounds"]) for r in rows]
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for key, style in (("false_alarm", "r-"), ("missed_detection", "g-"), ("total", "b-")):
            ax.plot(t, [100 * float(r[key]) for r in rows], style, label=key.replace("_", " "))
        ax.set_xscale("log")
        ax.set_xlabel("training rounds T")
        ax.set_ylabel("error at K = 0.5 [%]")
        ax.set_title("Cross-validated error against T (paper Fig. 3)")
        ax.grid(alpha=0.3, which="both")
        ax.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(folder, "error_vs_rounds.png"), dpi=100)
        made.append("error_vs_rounds.png")
        plt.close(fig)

    removal_path = os.path.join(folder, "feature_removal.csv")
    if os.path.exists(removal_path):
        rows = [r for r in read(removal_path) if r["feature"] != "0"]
        fig, ax = plt.subplots(figsize=(max(7, 0.3 * len(rows)), 4.5))
        x = range(len(rows))
        ax.bar([i - 0.2 for i in x], [100 * float(r["false_alarm"]) for r in rows], 0.4, label="false alarm")
        ax.bar([i + 0.2 for i in x], [100 * float(r["missed_detection"]) for r in rows], 0.4, label="missed detection")
        ax.set_xticks(list(x))
        ax.set_xticklabels([r["feature"] for r in rows], fontsize=7)
        ax.set_xlabel("feature removed")
        ax.set_ylabel("error [%]")
        ax.set_title("Error after removing one feature (paper Fig. 4)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(folder, "feature_removal.png"), dpi=100)
        made.append("feature_removal.png")
        plt.close(fig)
    print("plotted " + ", ".join(os.path.join(folder, m) for m in made), file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
