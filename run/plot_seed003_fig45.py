#!/usr/bin/python3
"""Seed 003 Figs. 4-5 from two morse fom runs (linear twin and nonlinear).

usage: /usr/bin/python3 run/plot_seed003_fig45.py DIR [IMGDIR]
Reads DIR/fom_linear.h5 and DIR/fom_nonlinear.h5 (/fom/time, /fom/sets/LE/u), writes
IMGDIR/seed003_fig4.png (u_x at LE against time, linear dashed, nonlinear solid, as the seed) and
IMGDIR/seed003_fig5.png (single-sided amplitude spectrum of the same signals), and prints the
peak-to-peak amplitudes and the dominant spectral lines.
"""
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path, comp=0):
    with h5py.File(path, "r") as f:
        t = f["/fom/time"][:]
        u = f["/fom/sets/LE/u"][:, 0, comp]
    return t, u


def spectrum(t, u):
    n = len(u)
    dt = t[1] - t[0]
    win = np.hanning(n)
    a = np.abs(np.fft.rfft((u - u.mean()) * win)) * 2 / win.sum()
    w = 2 * np.pi * np.fft.rfftfreq(n, dt)
    return w, a


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else "out/seed003"
    img = sys.argv[2] if len(sys.argv) > 2 else "docs/img"
    os.makedirs(img, exist_ok=True)
    tl, ul = load(os.path.join(d, "fom_linear.h5"))
    tn, un = load(os.path.join(d, "fom_nonlinear.h5"))
    fig, ax = plt.subplots(figsize=(8, 3.6))
    ax.plot(tl * 1e3, ul * 1e3, "--", color="0.4", label="linear")
    ax.plot(tn * 1e3, un * 1e3, "-", color="C3", label="nonlinear (St Venant-Kirchhoff)")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("$u_x$ at LE [mm]")
    ax.set_title("morse fom: LE response to 300 N at 2000 rad/s (seed 003 Fig. 4)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "seed003_fig4.png"), dpi=130)
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for t, u, style, lab in ((tl, ul, "--", "linear"), (tn, un, "-", "nonlinear")):
        w, a = spectrum(t, u)
        ax.semilogy(w, a * 1e3, style, label=lab)
    ax.set_xlim(0, 3.5e4)
    ax.set_xlabel("angular frequency [rad/s]")
    ax.set_ylabel("amplitude of $u_x$ at LE [mm]")
    ax.set_title("seed 003 Fig. 5: frequency content (Hann window)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "seed003_fig5.png"), dpi=130)
    for lab, t, u in (("linear", tl, ul), ("nonlinear", tn, un)):
        w, a = spectrum(t, u)
        peaks = [i for i in range(1, len(a) - 1) if a[i] > a[i - 1] and a[i] >= a[i + 1]]
        peaks = sorted(peaks, key=lambda i: -a[i])[:6]
        lines = ", ".join(f"{w[i]:.0f} rad/s ({a[i]*1e3:.3g} mm)" for i in sorted(peaks))
        print(f"{lab}: u_x at LE peak-to-peak {1e3*(u.max()-u.min()):.4f} mm; spectral peaks: {lines}")


if __name__ == "__main__":
    main()
