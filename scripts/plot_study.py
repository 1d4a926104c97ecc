#!/usr/bin/python3
"""Speed against error of an fdem study: one point per variant, the Pareto front joined.

Usage: plot_study.py study.csv out.png [--error peak]

study.csv is written by `fdem study`. The x axis is the chosen error against the reference
(in %, or 1 - overlap for jaccard), the y axis the speed-up over the reference (log scale).
Unstable variants are listed in the title; the recommended variant is circled.
"""
import argparse
import csv
import math
import sys


def main(argv):
    ap = argparse.ArgumentParser(description="Plot an fdem study (speed-up against error).")
    ap.add_argument("csv")
    ap.add_argument("png")
    ap.add_argument("--error", default="peak")
    args = ap.parse_args(argv)
    with open(args.csv, newline="") as fh:
        reader = csv.DictReader(fh)
        rows = list(reader)
        keys = reader.fieldnames[: reader.fieldnames.index("reference")]
    col = "error_" + args.error
    if not rows or col not in rows[0]:
        print("plot_study.py: error: '%s' has no rows or no column %s" % (args.csv, col), file=sys.stderr)
        return 2

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def label(r):
        return ", ".join("%s=%s" % (k, r[k]) for k in keys)

    fig, ax = plt.subplots(figsize=(8, 5.5), constrained_layout=True)
    pts, unstable = [], []
    for r in rows:
        s, e = float(r["speedup"]), float(r[col])
        if r["stable"] != "1" or math.isnan(s) or math.isnan(e):
            unstable.append(label(r)) if r["stable"] != "1" else None
            continue
        e = (1 - e) if args.error == "jaccard" else 100 * e
        pts.append((e, s, r))
        ax.plot([e], [s], "o", color="tab:red" if r["pareto"] == "1" else "tab:blue", ms=7)
        ax.annotate(label(r) + (" (ref)" if r["reference"] == "1" else ""), (e, s), textcoords="offset points",
                    xytext=(6, 4), fontsize=7)
        if r["recommended"] == "1":
            ax.plot([e], [s], "o", mfc="none", mec="k", ms=15, mew=1.5, label="recommended")
    front = sorted((p for p in pts if p[2]["pareto"] == "1"), key=lambda p: p[0])
    if front:
        ax.plot([p[0] for p in front], [p[1] for p in front], "-", color="tab:red", lw=1.2, label="Pareto front")
    ax.set_yscale("log")
    ax.set_xlabel("1 - Jaccard overlap of broken CE6" if args.error == "jaccard" else "%s error (%%)" % args.error)
    ax.set_ylabel("speed-up over the reference (wall time)")
    title = "speed against error"
    if unstable:
        title += " (unstable: %s)" % "; ".join(unstable)
    ax.set_title(title, fontsize=9)
    ax.grid(True, color="0.9", lw=0.6, which="both")
    ax.legend(fontsize=8, loc="best")
    fig.savefig(args.png, dpi=150)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
