#!/usr/bin/python3
"""The nonlinear map on fine grids around its interactions (run/contact_study.py --stages windows):
one panel per window file, the LE RMS [mm] against |Omega| (failed speeds as red x) and, on a second
axis, the engine order of each speed's dominant spectral line (f_dominant 2 pi / |Omega|), with the
window's integer order drawn dotted.

usage: /usr/bin/python3 run/plot_contact_windows.py OUT_DIR [--png docs/img/contact_windows_nonlinear.png]
           [--files PATTERN] [--lines 2,6]

Reads OUT_DIR/window_nonlinear_*.h5 (or --files, a glob in OUT_DIR; /sweep of `morse sweep`). With
--lines, a second row of panels gives the amplitude [mm] of the spectral lines of those engine
orders (the largest of the three bins around k |Omega| / 2 pi), to tell a locked response from a
static push that the RMS (which keeps the mean) does not. Needs numpy, h5py, matplotlib (Agg).
Exits non-zero if no window file is found.
"""
import argparse
import glob
import math
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contact_study import dominant_lines  # noqa: E402


def load(path):
    with h5py.File(path, "r") as f:
        s = f["/sweep"]
        w = np.abs(s["omega"][:])
        o = np.argsort(w)
        rms, status = s["rms"][:][o], s["status"][:][o]
        spec, freq = s["spectrum"][:][o], s["frequency"][:]
        orders = 1e3 * s["order_amplitude"][:][o] if "order_amplitude" in s else None
    w = w[o]
    return w, 1e3 * rms, status, dominant_lines(spec, freq) * 2 * math.pi / w, 1e3 * spec, freq, orders


def line_amplitude(w, spec, freq, order, orders=None):
    """Per speed, the amplitude of engine order `order`: /sweep/order_amplitude (at its exact
    frequency) when the file has it, else the largest spectrum value of the three bins around
    order |Omega| / 2 pi. Files written before the spectrum held each bin's peak lose a line that
    falls farther than 2 / T from every bin frequency (docs/contact.md): there this is not the
    line's amplitude."""
    if orders is not None and orders.shape[1] >= order:
        return orders[:, order - 1]
    out = np.zeros(w.size)
    for k in range(w.size):
        i = int(np.argmin(np.abs(freq - order * w[k] / (2 * math.pi))))
        out[k] = spec[k, max(i - 1, 0):i + 2].max()
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--png", default="contact_windows_nonlinear.png")
    ap.add_argument("--files", default="window_nonlinear_*.h5", help="a glob in OUT_DIR")
    ap.add_argument("--lines", default="", help="engine orders whose line amplitudes to draw, e.g. 2,6")
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.out, a.files)), key=lambda p: float(os.path.basename(p).split("_")[3]))
    if not files:
        print("plot_contact_windows: no %s in %s" % (a.files, a.out), file=sys.stderr)
        return 1
    lines = [int(x) for x in a.lines.split(",") if x]
    rows = 2 if lines else 1
    fig, axes = plt.subplots(rows, len(files), figsize=(5.5 * len(files), 4.0 * rows), squeeze=False)
    for col, path in enumerate(files):
        ax = axes[0][col]
        w, rms, status, order, spec, freq, orders = load(path)
        if lines:
            ok = status == 0
            for j, n in enumerate(lines):
                axes[1][col].plot(w[ok], line_amplitude(w[ok], spec[ok], freq, n, None if orders is None else orders[ok]), "o-", ms=3, color="C%d" % (j + 2),
                                  label="engine order %d" % n)
            axes[1][col].set_xlabel("|Ω| [rad/s]")
            axes[1][col].set_ylabel("line amplitude [mm]")
            axes[1][col].set_ylim(bottom=0)
            axes[1][col].grid(alpha=0.3)
            axes[1][col].legend(fontsize=8)
        ok = status == 0
        ax.plot(w[ok], rms[ok], "o-", color="C0", ms=4, label="LE RMS, 2nd half")
        if (~ok).any():
            ax.plot(w[~ok], np.zeros((~ok).sum()), "rx", label="failed")
        ax.set_xlabel("|Ω| [rad/s]")
        ax.set_ylabel("LE radial RMS [mm]", color="C0")
        ax.set_ylim(bottom=0)
        ax2 = ax.twinx()
        ax2.plot(w[ok], order[ok], "s", color="C3", ms=3, label="order of the dominant line")
        n = round(float(np.median(order[ok]))) if ok.any() else 0
        if n:
            ax2.axhline(n, color="C3", ls=":", lw=1)
        ax2.set_ylabel("engine order of the dominant line", color="C3")
        ax2.set_ylim(max(0, n - 3), n + 3)
        ax.set_title(os.path.basename(path).replace(".h5", ""), fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    tmp = a.png + ".tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, a.png)
    print("wrote %s" % a.png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
