#!/usr/bin/python3
"""Stress-strain curves from an fdem monitor CSV, drawn as in rock mechanics papers.

Usage: plot_curves.py monitors.csv out.png [--title T]

Compression is positive. Required columns: axial_strain, axial_stress_Pa. Optional:
lateral_strain, volumetric_strain, broken_ce6 (panels or curves are left out when missing).
Panels: (a) axial stress vs axial strain, with the broken-CE6 count on a second axis;
(b) axial stress vs lateral strain (left, negative) and axial strain (right);
(c) volumetric strain vs axial strain. The peak stress is marked on every panel.
"""
import argparse
import csv
import math
import os
import sys

REQUIRED = ("axial_strain", "axial_stress_Pa")


def fail(msg):
    print("plot_curves.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


def read_columns(path):
    if not os.path.isfile(path):
        fail("monitor CSV '%s' does not exist" % path)
    with open(path, newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if not header:
            fail("monitor CSV '%s' is empty (no header row)" % path)
        header = [h.strip() for h in header]
        missing = [c for c in REQUIRED if c not in header]
        if missing:
            fail("monitor CSV '%s' lacks column(s) %s (has: %s)" % (path, ", ".join(missing), ", ".join(header)))
        cols = {h: [] for h in header}
        for row in reader:
            if not row or all(not c.strip() for c in row):
                continue
            for i, h in enumerate(header):
                cols[h].append(_num(row[i]) if i < len(row) else math.nan)
    rows = len(cols[REQUIRED[0]])
    if rows == 0:
        fail("monitor CSV '%s' has a header but no data rows" % path)
    return cols, rows


def _num(text):
    try:
        v = float(text)
    except ValueError:
        return math.nan
    return v if math.isfinite(v) else math.nan


def pairs(xs, ys):
    """Rows where both values are finite."""
    out_x, out_y = [], []
    for a, b in zip(xs, ys):
        if not (math.isnan(a) or math.isnan(b)):
            out_x.append(a)
            out_y.append(b)
    return out_x, out_y


def main(argv):
    ap = argparse.ArgumentParser(description="Plot fdem stress-strain curves (compression positive).")
    ap.add_argument("csv", help="monitor CSV written by fdem")
    ap.add_argument("png", help="output PNG")
    ap.add_argument("--title", default=None, help="figure title")
    args = ap.parse_args(argv)

    cols, _ = read_columns(args.csv)
    pct = 100.0  # strains are plotted in %
    ea, sa = pairs(cols["axial_strain"], cols["axial_stress_Pa"])
    if not ea:
        fail("monitor CSV '%s' has no row with finite axial_strain and axial_stress_Pa" % args.csv)
    s_mpa = [s / 1e6 for s in sa]
    ea_pct = [e * pct for e in ea]
    ipk = max(range(len(s_mpa)), key=lambda i: s_mpa[i])
    peak_s, peak_e = s_mpa[ipk], ea_pct[ipk]

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), constrained_layout=True)
    peak_label = "peak %.3g MPa" % peak_s

    # (a) stress vs axial strain (+ broken CE6 count)
    ax = axes[0]
    ax.plot(ea_pct, s_mpa, color="tab:blue", lw=1.6, label="axial stress")
    ax.plot([peak_e], [peak_s], "o", color="tab:red", ms=7, zorder=5, label=peak_label)
    ax.annotate("%.3g MPa\n@ %.3g %%" % (peak_s, peak_e), (peak_e, peak_s), textcoords="offset points",
                xytext=(8, -28), fontsize=8, color="tab:red")
    ax.set_xlabel("axial strain $\\varepsilon_a$ (%)")
    ax.set_ylabel("axial stress $\\sigma_a$ (MPa)")
    ax.set_title("(a) stress - axial strain")
    handles, labels = ax.get_legend_handles_labels()
    if "broken_ce6" in cols:
        eb, nb = pairs(cols["axial_strain"], cols["broken_ce6"])
        if eb:
            tw = ax.twinx()
            h = tw.step([e * pct for e in eb], nb, where="post", color="0.45", lw=1.0, ls="--",
                        label="broken CE6")
            tw.set_ylabel("broken CE6 (count)", color="0.35")
            tw.tick_params(axis="y", colors="0.35")
            tw.set_ylim(bottom=0)
            handles += h
            labels += ["broken CE6"]
    ax.legend(handles, labels, loc="upper left", fontsize=8)

    # (b) stress vs lateral strain (negative side) and axial strain
    ax = axes[1]
    if "lateral_strain" in cols:
        el, sl = pairs(cols["lateral_strain"], cols["axial_stress_Pa"])
        note = ""
        if el and max(el) > 0 and min(el) >= 0:  # expansion reported positive: put it on the negative side
            el = [-e for e in el]
            note = " (sign flipped)"
        if el:
            ax.plot([e * pct for e in el], [s / 1e6 for s in sl], color="tab:green", lw=1.6,
                    label="lateral $\\varepsilon_l$" + note)
            if not math.isnan(cols["lateral_strain"][_row_of(cols, ipk)]):
                lp = cols["lateral_strain"][_row_of(cols, ipk)] * (-1 if note else 1)
                ax.plot([lp * pct], [peak_s], "o", color="tab:red", ms=7, zorder=5)
    ax.plot(ea_pct, s_mpa, color="tab:blue", lw=1.0, alpha=0.6, label="axial $\\varepsilon_a$")
    ax.plot([peak_e], [peak_s], "o", color="tab:red", ms=7, zorder=5, label=peak_label)
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("strain (%)   lateral $\\leftarrow$ | $\\rightarrow$ axial")
    ax.set_ylabel("axial stress $\\sigma_a$ (MPa)")
    ax.set_title("(b) stress - lateral and axial strain")
    ax.legend(loc="upper left", fontsize=8)

    # (c) volumetric strain vs axial strain
    ax = axes[2]
    if "volumetric_strain" in cols:
        e2, ev = pairs(cols["axial_strain"], cols["volumetric_strain"])
        if e2:
            ax.plot([e * pct for e in e2], [v * pct for v in ev], color="tab:purple", lw=1.6,
                    label="volumetric $\\varepsilon_v$")
            ax.axhline(0.0, color="0.6", lw=0.8)
    else:
        ax.text(0.5, 0.5, "no volumetric_strain column", ha="center", va="center", transform=ax.transAxes,
                color="0.4")
    ax.axvline(peak_e, color="tab:red", lw=1.0, ls=":", label="peak stress")
    ax.set_xlabel("axial strain $\\varepsilon_a$ (%)")
    ax.set_ylabel("volumetric strain $\\varepsilon_v$ (%)  (compaction +)")
    ax.set_title("(c) volumetric - axial strain")
    ax.legend(loc="best", fontsize=8)

    for ax in axes:
        ax.grid(True, color="0.9", lw=0.6)
    if args.title:
        fig.suptitle(args.title)
    out_dir = os.path.dirname(os.path.abspath(args.png))
    if not os.path.isdir(out_dir):
        fail("output folder '%s' does not exist" % out_dir)
    try:
        fig.savefig(args.png, dpi=150)
    except OSError as e:
        fail("cannot write '%s': %s" % (args.png, e))
    print("wrote %s (peak %.4g MPa at axial strain %.4g %%)" % (args.png, peak_s, peak_e))
    return 0


def _row_of(cols, k):
    """Row index in the raw columns of the k-th finite (axial_strain, axial_stress) pair."""
    n = -1
    for i, (a, b) in enumerate(zip(cols["axial_strain"], cols["axial_stress_Pa"])):
        if not (math.isnan(a) or math.isnan(b)):
            n += 1
            if n == k:
                return i
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
