#!/usr/bin/python3
"""Curves of a series of fdem runs on common axes, and the Mohr circles of a triaxial series.

Usage: plot_series.py series.csv folder [--mohr mohr_coulomb.csv]

series.csv is written by `fdem triaxial` or `fdem series`: the varied keys first, then a
`folder` column and the columns of each run's summary.csv. Each run's monitors.csv is read
from its folder. Writes <folder>/series_curves.png: (a) axial stress vs axial strain,
(b) axial stress vs lateral strain, (c) volumetric vs axial strain, one curve per run.
With --mohr also <folder>/mohr_circles.png: a circle per peak, (sigma_3, sigma_1) with
sigma_1 the peak axial stress, and the fitted envelope tau = c + sigma tan(phi).
Compression positive, stresses in MPa, strains in %.
"""
import argparse
import csv
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_curves import fail, pairs, read_columns  # noqa: E402


def read_rows(path):
    if not os.path.isfile(path):
        fail("series table '%s' does not exist" % path)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        fail("series table '%s' has no runs" % path)
    if "folder" not in rows[0]:
        fail("series table '%s' lacks the folder column" % path)
    return rows


def run_label(row):
    keys = []
    for k in row:
        if k == "folder":
            break
        keys.append(k)
    parts = []
    for k in keys:
        v = row[k]
        if k == "sigma3":
            parts.append("$\\sigma_3$ = %g MPa" % (float(v) / 1e6))
        else:
            parts.append("%s = %s" % (k, v))
    return ", ".join(parts)


def main(argv):
    ap = argparse.ArgumentParser(description="Plot an fdem series (compression positive).")
    ap.add_argument("csv", help="series.csv written by fdem triaxial / fdem series")
    ap.add_argument("folder", help="where to write the PNGs")
    ap.add_argument("--mohr", default=None, help="mohr_coulomb.csv of a triaxial series")
    ap.add_argument("--input", default=None, help="cohesion_Pa,friction_angle_deg of the input (CE6) strength")
    args = ap.parse_args(argv)
    rows = read_rows(args.csv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), constrained_layout=True)
    # A Brazilian disc: the indirect tensile stress 2P/(pi D t) instead of P/(D t).
    stress_col, stress_name = "axial_stress_Pa", "axial stress $\\sigma_1$ (MPa)"
    if any(float(r.get("peak_indirect_tensile_Pa") or 0) > 0 for r in rows):
        stress_col, stress_name = "indirect_tensile_Pa", "indirect tensile stress $2P/(\\pi D t)$ (MPa)"
    colours = plt.cm.viridis([i / max(1, len(rows) - 1) * 0.9 for i in range(len(rows))])
    for row, c in zip(rows, colours):
        monitors = os.path.join(row["folder"], "monitors.csv")
        cols, _ = read_columns(monitors)
        lab = run_label(row)
        if row.get("end_reason", "").startswith("unstable"):
            lab += " (stopped: unstable)"
        ea, sa = pairs(cols["axial_strain"], cols[stress_col])
        axes[0].plot([e * 100 for e in ea], [s / 1e6 for s in sa], color=c, lw=1.4, label=lab)
        if "lateral_strain" in cols:
            el, sl = pairs(cols["lateral_strain"], cols[stress_col])
            axes[1].plot([e * 100 for e in el], [s / 1e6 for s in sl], color=c, lw=1.4, label=lab)
        if "volumetric_strain" in cols:
            e2, ev = pairs(cols["axial_strain"], cols["volumetric_strain"])
            axes[2].plot([e * 100 for e in e2], [v * 100 for v in ev], color=c, lw=1.4, label=lab)
    axes[0].set_xlabel("axial strain $\\varepsilon_a$ (%)")
    axes[0].set_ylabel(stress_name)
    axes[0].set_title("(a) stress - axial strain")
    axes[1].set_xlabel("lateral strain $\\varepsilon_l$ (%)  (expansion negative)")
    axes[1].set_ylabel(stress_name)
    axes[1].set_title("(b) stress - lateral strain")
    axes[2].set_xlabel("axial strain $\\varepsilon_a$ (%)")
    axes[2].set_ylabel("volumetric strain $\\varepsilon_v$ (%)  (compaction +)")
    axes[2].set_title("(c) volumetric - axial strain")
    for ax in axes:
        ax.grid(True, color="0.9", lw=0.6)
        ax.legend(fontsize=7, loc="best")
    fig.savefig(os.path.join(args.folder, "series_curves.png"), dpi=150)

    if args.mohr:
        with open(args.mohr, newline="") as fh:
            fit = next(csv.DictReader(fh), None)
        if fit is None:
            fail("Mohr-Coulomb table '%s' is empty" % args.mohr)
        c = float(fit["cohesion_Pa"]) / 1e6
        phi = float(fit["friction_angle_deg"])
        fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
        smax = 0.0
        for row, col in zip(rows, colours):
            s3 = float(row["confining_pressure_Pa"]) / 1e6
            s1 = float(row["peak_stress_Pa"]) / 1e6
            centre, radius = 0.5 * (s1 + s3), 0.5 * (s1 - s3)
            t = [math.pi * i / 180 for i in range(181)]
            ax.plot([centre + radius * math.cos(a) for a in t], [radius * math.sin(a) for a in t], color=col,
                    lw=1.4, label="$\\sigma_3$ = %g, $\\sigma_1$ = %.3g MPa" % (s3, s1))
            smax = max(smax, s1)
        tanp = math.tan(math.radians(phi))
        sig0 = -c / tanp if tanp > 0 else 0.0
        ax.plot([sig0, smax], [0.0, c + smax * tanp], "k--", lw=1.2,
                label="fit: c = %.3g $\\pm$ %.2g MPa, $\\varphi$ = %.3g $\\pm$ %.2g$^\\circ$"
                % (c, float(fit["cohesion_se_Pa"]) / 1e6, phi, float(fit["friction_angle_se_deg"])))
        if args.input:
            ci, pi = (float(v) for v in args.input.split(","))
            ci /= 1e6
            ti = math.tan(math.radians(pi))
            ax.plot([-ci / ti, smax], [0.0, ci + smax * ti], ":", color="0.4", lw=1.2,
                    label="input (CE6): c = %.3g MPa, $\\varphi$ = %.3g$^\\circ$" % (ci, pi))
        ax.set_xlabel("normal stress $\\sigma$ (MPa)")
        ax.set_ylabel("shear stress $\\tau$ (MPa)")
        ax.set_title("Mohr circles at the peaks and the Mohr-Coulomb envelope")
        ax.set_aspect("equal")
        ax.set_ylim(bottom=0)
        ax.grid(True, color="0.9", lw=0.6)
        ax.legend(fontsize=7, loc="upper left")
        fig.savefig(os.path.join(args.folder, "mohr_circles.png"), dpi=150)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
