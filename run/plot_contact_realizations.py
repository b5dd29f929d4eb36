#!/usr/bin/python3
"""The linear map against its round-off realizations (issue 28; docs/contact.md "Coexisting solutions").

usage: /usr/bin/python3 run/plot_contact_realizations.py [--out out/contact_study] [--png docs/img/X.png]
                                                        [--zoom LO:HI[,LO:HI...]]

Reads <out>/study.json (entry "realizations" of `run/contact_study.py --stages realizations`) and the
sweep files it names: the refined linear map (realization 0) and the maps of the same coarse grid with
every speed multiplied by 1 + e. Draws the LE radial RMS over the speed: the refined map as a thin
line with dots, each realization of the coarse grid as markers, the exact 1B / engine-order crossings
(eo4, eo6, eo8) as dotted lines, and the coarse speeds whose realizations differ by more than 20 %
shaded. With --zoom, one extra panel per range (refined map only, dots), where the two branches show.
Prints the spread statistics. Needs numpy, h5py, matplotlib (Agg).
"""
import argparse
import json
import math
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def sweep(path):
    with h5py.File(path, "r") as f:
        w, rms, status = np.abs(f["/sweep/omega"][:]), f["/sweep/rms"][:], f["/sweep/status"][:]
        eig = f["/sweep/eigenfrequencies"][:]
    o = np.argsort(w)
    return w[o], rms[o], status[o], eig


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "contact_study"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "img", "contact_map_realizations.png"))
    ap.add_argument("--zoom", default="740:810,1110:1240")
    a = ap.parse_args()
    try:
        rec = json.load(open(os.path.join(a.out, "study.json")))["realizations"]
    except (OSError, KeyError, ValueError) as e:
        sys.exit("plot_contact_realizations: no realizations in %s/study.json (%s)" % (a.out, e))
    files = rec["files"]
    grid, R = np.array(rec["speeds"]), np.array(rec["rms"])
    spread = R.max(0) / R.min(0)
    w0, r0, s0, eig = sweep(files["0"])
    zooms = [tuple(float(x) for x in z.split(":")) for z in a.zoom.split(",") if z]
    fig, axes = plt.subplots(1 + len(zooms), 1, figsize=(10, 3.6 * (1 + len(zooms))), squeeze=False)
    ax = axes[0, 0]
    ax.plot(w0, 1e3 * r0, "-", color="0.6", lw=0.6, label="refined map (%d speeds)" % w0.size)
    ax.plot(w0, 1e3 * r0, ".", color="0.4", ms=2)
    marks = ["o", "s", "^", "v", "D"]
    for k, (e, _) in enumerate(files.items()):
        ax.plot(grid, 1e3 * R[k], marks[k % len(marks)], mfc="none", ms=5,
                label="coarse grid, speeds x (1 + %s)" % e if e != "0" else "coarse grid of the map")
    for x in grid[spread > 1.2]:
        for axx in axes[:, 0]:
            axx.axvspan(x - 8, x + 8, color="orange", alpha=0.25, lw=0)
    f1b = eig[0]
    for eo in (4, 6, 8):
        wc = 2 * math.pi * f1b / eo
        for axx in axes[:, 0]:
            axx.axvline(wc, ls=":", color="k", lw=0.8)
        ax.text(wc, ax.get_ylim()[1] * 0.95, " 1B/eo%d" % eo, fontsize=8, va="top")
    ax.set_xlabel("|Ω| [rad/s]")
    ax.set_ylabel("LE radial RMS, 2nd half [mm]")
    ax.set_title("Linear map (r79 mass-scaled, μ = 0.15, 200 revolutions): realizations differing by round-off;"
                 "\nshaded: coarse speeds whose realizations differ by more than 20 %", fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    for k, (lo, hi) in enumerate(zooms):
        axx = axes[k + 1, 0]
        s = (w0 >= lo) & (w0 <= hi)
        axx.plot(w0[s], 1e3 * r0[s], ".-", color="0.3", lw=0.5, ms=4)
        g = (grid >= lo) & (grid <= hi)
        for j in range(R.shape[0]):
            axx.plot(grid[g], 1e3 * R[j, g], marks[j % len(marks)], mfc="none", ms=7)
        axx.set_xlim(lo, hi)
        axx.set_xlabel("|Ω| [rad/s] (refined map, every 1 rad/s)")
        axx.set_ylabel("RMS [mm]")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(a.png)), exist_ok=True)
    fig.savefig(a.png, dpi=110)
    print("wrote %s" % a.png)
    print("RMS spread over %d realizations of %d speeds: median %.3f, 90 %% %.3f, largest %.2f at %g rad/s"
          % (R.shape[0], grid.size, np.median(spread), np.percentile(spread, 90), spread.max(),
             grid[np.argmax(spread)]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
