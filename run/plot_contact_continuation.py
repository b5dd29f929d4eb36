#!/usr/bin/python3
"""Both branches of a map by continuation (issue 28; docs/contact.md "Continuation: both branches").

usage: /usr/bin/python3 run/plot_contact_continuation.py [--out out/contact_study] [--map linear]
                                                        [--png docs/img/contact_continuation_linear.png]
                                                        [--zoom LO:HI[,LO:HI...]] [--orders] [--rest FILE]

Reads <out>/study.json (entry "continuation_<map>" of `run/contact_study.py --stages continuation`)
and the sweep files it names: the continuation up (each speed from the final state of the one below)
and down (from the one above), and, if present, the from-rest map of the same model and sense
(map_<map>_<sense>.h5 of the `maps` stage). Draws the LE radial RMS over the speed: the from-rest
map as grey dots, up and down as lines, the exact 1B / engine-order crossings (eo4, eo6, eo8) as
dotted lines and the bands where up and down differ by more than 20 % shaded. With --zoom, one
extra panel per range. Prints the bands. Needs numpy, h5py, matplotlib (Agg).
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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from contact_study import dominant_lines  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def sweep(path):
    with h5py.File(path, "r") as f:
        w, rms, status = np.abs(f["/sweep/omega"][:]), f["/sweep/rms"][:], f["/sweep/status"][:]
        eig = f["/sweep/eigenfrequencies"][:]
        settings = f["/sweep/settings"][()]
        order = dominant_lines(f["/sweep/spectrum"][:], f["/sweep/frequency"][:]) * 2 * math.pi / np.maximum(w, 1e-300)
    o = np.argsort(w)
    settings = settings.decode() if isinstance(settings, bytes) else str(settings)
    return w[o], rms[o], status[o], eig, dict(l.split("=", 1) for l in settings.splitlines() if "=" in l), order[o]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "contact_study"))
    ap.add_argument("--map", default="linear")
    ap.add_argument("--png", default=None)
    ap.add_argument("--zoom", default="740:820,1120:1260")
    ap.add_argument("--orders", action="store_true",
                    help="a panel of the engine order of each speed's largest spectral line (up and down)")
    ap.add_argument("--rest", default=None, help="the from-rest sweep file (default: the maps stage's)")
    a = ap.parse_args()
    png = a.png or os.path.join(ROOT, "docs", "img", "contact_continuation_%s.png" % a.map)
    try:
        study = json.load(open(os.path.join(a.out, "study.json")))
        rec = study["continuation_" + a.map]
    except (OSError, KeyError, ValueError) as e:
        sys.exit("plot_contact_continuation: no continuation_%s in %s/study.json (%s)" % (a.map, a.out, e))
    up = sweep(rec["files"]["up"])
    down = sweep(rec["files"]["down"])
    sense = study.get("map_rotation", {}).get("sense", "negative")
    rest_path = a.rest or os.path.join(a.out, "map_%s_%s.h5" % (a.map, sense))
    rest = sweep(rest_path) if os.path.exists(rest_path) else None
    eig = up[3]
    zooms = [tuple(float(x) for x in z.split(":")) for z in a.zoom.split(",") if z]
    npan = 1 + len(zooms) + (1 if a.orders else 0)
    fig, axes = plt.subplots(npan, 1, figsize=(10, 3.6 * npan), squeeze=False)
    if a.orders:  # the last panel: the engine order of the largest line, up and down (and from rest)
        axo = axes[-1, 0]
        if rest is not None:
            axo.plot(rest[0], rest[5], ".", color="0.6", ms=4, label="from rest")
        axo.plot(up[0], up[5], "o-", color="C3", ms=3, lw=1.0, label="continuation up")
        axo.plot(down[0], down[5], "s--", color="C0", ms=3, lw=1.0, label="continuation down")
        for eo in (4, 6, 8):
            axo.axhline(eo, ls=":", color="k", lw=0.6)
        axo.set_xlim(up[0].min(), up[0].max())
        axo.set_ylim(3, 10)
        axo.set_xlabel("|Ω| [rad/s]")
        axo.set_ylabel("largest line / (Ω/2π)\n[engine order]")
        axo.legend(fontsize=8)
        axes = axes[:-1]
    lo, hi = up[0].min(), up[0].max()
    for k, axx in enumerate(axes[:, 0]):
        if k > 0:
            lo, hi = zooms[k - 1]
        if rest is not None:
            s = (rest[0] >= lo) & (rest[0] <= hi)
            axx.plot(rest[0][s], 1e3 * rest[1][s], ".", color="0.6", ms=3,
                     label="from rest (map, %s revolutions)" % rest[4].get("revolutions", "?"))
        for (w, rms, status, _, _, _), col, lab in ((up, "C3", "continuation up"), (down, "C0", "continuation down")):
            s = (w >= lo) & (w <= hi)
            axx.plot(w[s], 1e3 * rms[s], "-", color=col, lw=1.0 if k == 0 else 1.4, label=lab)
            bad = s & (status != 0)
            axx.plot(w[bad], 1e3 * rms[bad], "x", color=col, ms=6)
        for b in rec["bands"]:
            axx.axvspan(b[0] - 0.5, b[1] + 0.5, color="orange", alpha=0.25, lw=0)
        for eo in (4, 6, 8):
            wc = 2 * math.pi * eig[0] / eo
            if lo <= wc <= hi:
                axx.axvline(wc, ls=":", color="k", lw=0.8)
                axx.text(wc, 0.97, " 1B/eo%d" % eo, fontsize=8, va="top", transform=axx.get_xaxis_transform())
        axx.set_xlim(lo, hi)
        axx.set_xlabel("|Ω| [rad/s]")
        axx.set_ylabel("LE radial RMS, 2nd half [mm]")
    ax = axes[0, 0]
    ax.set_title("%s map (r79 mass-scaled, μ = 0.15): continuation up and down, %g revolutions per speed; "
                 "\nshaded: up and down differ by more than 20 %%" % (a.map.capitalize(), rec["revs"]), fontsize=9)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    os.makedirs(os.path.dirname(png), exist_ok=True)
    fig.savefig(png, dpi=110)
    print("plot_contact_continuation: %d speeds, %d differ by > 20 %%; bands %s; wrote %s" %
          (rec["speeds"], rec["speeds_differing"], ["%g-%g (%s higher)" % tuple(b) for b in rec["bands"]], png))


if __name__ == "__main__":
    main()
