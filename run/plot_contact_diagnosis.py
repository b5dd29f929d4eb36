#!/usr/bin/python3
"""The diagnosis of docs/contact.md ("Why the linear maps were not physical"), from the `diagnosis`
stage of run/contact_study.py:

    /usr/bin/python3 run/plot_contact_diagnosis.py [--out out/contact_study] [--img docs/img]

Writes <img>/contact_diagnosis.png: (a) RMS of the LE radial displacement over the second half of
each run against the speed, linear r54, with friction (both senses of rotation) and without, with
the 1B engine-order crossings of the free blade; (b) the energy fed to the blade over the second
half by the normal contact forces and by friction, and dissipated by damping (/sweep/energy_balance,
theory §10.6). Prints the table of docs/contact.md.
"""
import argparse
import os

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES = [("friction", "mu = 0.15, Omega > 0 (the study)", "C3"),
         ("friction_negative", "mu = 0.15, Omega < 0", "C0"),
         ("frictionless", "mu = 0", "C2")]


def read(path):
    with h5py.File(path, "r") as f:
        g = f["sweep"]
        o = np.abs(g["omega"][:])
        k = np.argsort(o)
        eb = g["energy_balance"][:][k]
        return {"omega": o[k], "rms": g["rms"][:][k], "status": g["status"][:][k],
                "normal": eb[:, 7] - eb[:, 2], "friction": eb[:, 8] - eb[:, 3], "damping": eb[:, 9] - eb[:, 4],
                "de": eb[:, 5] - eb[:, 0], "f": g["eigenfrequencies"][:]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "contact_study"))
    ap.add_argument("--img", default=os.path.join(ROOT, "docs", "img"))
    a = ap.parse_args()
    d = {tag: read(os.path.join(a.out, "diag_sweep_%s.h5" % tag)) for tag, _, _ in CASES}
    fig, ax = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True)
    f1b = d["friction"]["f"][0]
    for eo in (4, 6, 8):
        w = 2 * np.pi * f1b / eo
        for x in ax:
            x.axvline(w, color="0.7", lw=0.8, ls="--")
        ax[0].text(w, 1.02, "1B/eo%d" % eo, transform=ax[0].get_xaxis_transform(), ha="center", fontsize=8)
    for tag, label, c in CASES:
        r = d[tag]
        ax[0].semilogy(r["omega"], 1e3 * r["rms"], "o-", color=c, label=label, ms=4)
    ax[0].set_ylabel("RMS of u_r at LE, 2nd half [mm]")
    ax[0].legend(fontsize=8)
    ax[0].set_title("linear r54, 20 revolutions per speed", fontsize=9, pad=16)
    w = d["friction"]["omega"]
    dw = 0.25 * (w[1] - w[0]) if len(w) > 1 else 10
    for k, (tag, label, c) in enumerate(CASES):
        r = d[tag]
        ax[1].bar(r["omega"] + (k - 1) * dw, r["friction"], width=dw, color=c, label=label)
        ax[1].bar(r["omega"] + (k - 1) * dw, r["normal"], width=dw, color=c, alpha=0.4)
    ax[1].set_yscale("symlog", linthresh=10)
    ax[1].set_ylabel("work on the blade, 2nd half [J]\n(solid: friction, light: normal)")
    ax[1].set_xlabel("Omega [rad/s]")
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    os.makedirs(a.img, exist_ok=True)
    png = os.path.join(a.img, "contact_diagnosis.png")
    fig.savefig(png, dpi=110)
    print("wrote", png)
    print("| Omega [rad/s] | " + " | ".join("RMS %s [mm]" % t for t, _, _ in CASES) +
          " | friction / normal work, 2nd half, mu = 0.15, Omega > 0 [J] |")
    print("|---" * (len(CASES) + 2) + "|")
    for i, om in enumerate(w):
        row = ["%.0f" % om] + ["%.2f" % (1e3 * d[t]["rms"][i]) for t, _, _ in CASES]
        row.append("%+.3g / %+.3g" % (d["friction"]["friction"][i], d["friction"]["normal"][i]))
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
