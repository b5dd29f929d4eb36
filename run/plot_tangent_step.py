#!/usr/bin/python3
"""The tangent critical step along contact runs (morse simulate -sim_tangent_checks): docs/contact.md,
"Which step the nonlinear maps need".

    /usr/bin/python3 run/plot_tangent_step.py OUT.png LABEL=RUN.h5 [LABEL=RUN.h5 ...] [--zoom T0:T1]

Top: h_T(t) = 2 / omega_max(K~ + dg~/dq(q(t)), M~) of each run (/sim/tangent) with its step -sim_dt
(dashed) and, marked, the checked states with negative tangent stiffness. Bottom: the total normal
contact force of each run (/sim/contact/normal summed over the nodes). Prints, per run, the smallest
h_T, its time, the share of states with negative tangent stiffness and dt / min h_T.
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    zoom = None
    for a in sys.argv[1:]:
        if a.startswith("--zoom="):
            zoom = [float(x) for x in a.split("=", 1)[1].split(":")]
    if len(args) < 2:
        sys.exit(__doc__)
    out, runs = args[0], [a.split("=", 1) for a in args[1:]]
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for k, (label, path) in enumerate(runs):
        with h5py.File(path, "r") as f:
            tan = f["/sim/tangent"][:]
            dt = float(f["/sim"].attrs["dt"])
            t = f["/sim/time"][:]
            lam = f["/sim/contact/normal"][:].sum(axis=1) if "/sim/contact/normal" in f else None
        c = "C%d" % k
        finite = np.isfinite(tan[:, 1])
        ax.semilogy(1e3 * tan[finite, 0], tan[finite, 1], "-", color=c, lw=0.8, label="%s: h_T" % label)
        neg = tan[:, 2] > 0
        ax.plot(1e3 * tan[neg & finite, 0], tan[neg & finite, 1], ".", color=c, ms=2)
        ax.axhline(dt, color=c, ls="--", lw=0.8, label="%s: dt = %.2g s" % (label, dt))
        if lam is not None:
            bx.plot(1e3 * t, 1e-3 * lam, "-", color=c, lw=0.6, label=label)
        i = int(np.argmin(np.where(finite, tan[:, 1], np.inf)))
        print("%s: %d checks, smallest h_T %.4g s at t = %.6g s, dt / min = %.3f, negative stiffness at %d "
              "(%.0f %%), median h_T %.4g s" % (label, len(tan), tan[i, 1], tan[i, 0], dt / tan[i, 1], neg.sum(),
                                              100.0 * neg.mean(), np.median(tan[finite, 1])))
    ax.set_ylabel("tangent critical step h_T [s]")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    bx.set_ylabel("total normal contact force [kN]")
    bx.set_xlabel("t [ms]")
    bx.legend(fontsize=7)
    bx.grid(True, alpha=0.3)
    if zoom:
        bx.set_xlim(1e3 * zoom[0], 1e3 * zoom[1])
    ax.set_title("Tangent critical step along the run (dots: states with negative tangent stiffness)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print("wrote", out)


if __name__ == "__main__":
    main()
