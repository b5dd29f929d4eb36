#!/usr/bin/python3
"""The nonlinear map on fine grids around its interactions (run/contact_study.py --stages windows):
one panel per window file, the LE RMS [mm] against |Omega| (failed speeds as red x) and, on a second
axis, the engine order of each speed's dominant spectral line (f_dominant 2 pi / |Omega|), with the
window's integer order drawn dotted.

usage: /usr/bin/python3 run/plot_contact_windows.py OUT_DIR [--png docs/img/contact_windows_nonlinear.png]

Reads OUT_DIR/window_nonlinear_*.h5 (/sweep of `morse sweep`). Needs numpy, h5py, matplotlib (Agg).
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
    w = w[o]
    return w, 1e3 * rms, status, dominant_lines(spec, freq) * 2 * math.pi / w


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--png", default="contact_windows_nonlinear.png")
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.out, "window_nonlinear_*.h5")),
                   key=lambda p: float(os.path.basename(p).split("_")[3]))
    if not files:
        print("plot_contact_windows: no window_nonlinear_*.h5 in %s" % a.out, file=sys.stderr)
        return 1
    fig, axes = plt.subplots(1, len(files), figsize=(5.5 * len(files), 4.0), squeeze=False)
    for ax, path in zip(axes[0], files):
        w, rms, status, order = load(path)
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
