#!/usr/bin/python3
"""Interaction maps and RMS curves of a `morse sweep` (seed 003 Figs. 23-24 style: blade rubbing an
ovalized casing).

usage: /usr/bin/python3 run/plot_sweep.py SWEEP.h5 [SWEEP_LINEAR.h5] [--out-prefix PREFIX]
                                          [--title T] [--max-eo N] [--fmax HZ] [--orders 4,6,8]
                                          [--names A,B]

Reads /sweep of one or two sweep files (src/sim/sweep_file.cpp: omega, rms, status, spectrum,
frequency, eigenfrequencies, settings; order_amplitude if present). The first file is normally the nonlinear run, the second its
linear twin; panels and curves are named from settings linear=0/1 (else from the file name).
PREFIX defaults to the first file's path without .h5. Needs numpy, h5py, matplotlib (Agg).
Writes
  PREFIX_map.png  interaction map: x = speed omega [rad/s], y = frequency [Hz] (up to --fmax, default
                  the file's top bin), colour = spectrum amplitude [m] on a log scale (shared by both
                  panels; failed speeds left blank); dashed lines at the eigenfrequencies of the
                  reduced model ("mode k"), thin grey engine-order lines f = k omega / 2 pi,
                  k = 1..--max-eo (default 20). One panel per file; a file with a single speed is skipped.
  PREFIX_rms.png  RMS of the monitored displacement [mm] vs omega for each file, failed speeds as red x,
                  dotted verticals where engine order k (a multiple of lobes=, default 2, k <= --max-eo)
                  crosses one of the first 3 eigenfrequencies: omega = 2 pi f_mode / k (at most 12,
                  lowest modes first; lobes and eigenfrequencies from the first file).
  PREFIX_orders.png  (files with /sweep/order_amplitude, sweeps of 2026-12-02 on) the amplitude [mm]
                  of the engine-order lines of --orders (default 4,6,8) at their exact frequencies
                  k |omega| / 2 pi against omega, one panel per order, log scale, one curve per file,
                  dotted verticals at that order's crossings with the first 3 eigenfrequencies. This
                  reads each line where it is, not from the 20 Hz bins of the map.
and prints, per file, the speed of the highest RMS and the 3 largest interior local maxima of RMS
(the critical speeds), and for each order of --orders the speed of its largest line. Exits non-zero if a file is missing or is not a sweep file.
"""
import argparse
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

REQUIRED = ("omega", "rms", "status", "spectrum", "frequency", "eigenfrequencies", "settings")
N_MODE_LABELS = 4  # eigenfrequency lines labelled "mode k" on the map
N_CROSS_MODES = 3  # modes considered for the critical-speed lines on the RMS plot
MAX_CROSS_LINES = 12


def fail(msg):
    sys.exit(f"plot_sweep: {msg}")


def load(path):
    """The /sweep datasets of PATH as a dict (settings parsed into a dict of strings)."""
    if not os.path.isfile(path):
        fail(f"{path}: no such file")
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in REQUIRED if f"sweep/{k}" not in f]
            if missing:
                fail(f"{path} is not a morse sweep file (missing /sweep/{', /sweep/'.join(missing)})")
            d = {k: f[f"sweep/{k}"][()] for k in REQUIRED}
            d["orders"] = f["sweep/order_amplitude"][()] if "sweep/order_amplitude" in f else None
    except OSError as e:
        fail(f"{path} is not an HDF5 file ({e})")
    s = d["settings"]
    s = s.decode() if isinstance(s, bytes) else str(s)
    d["settings"] = dict(line.split("=", 1) for line in s.splitlines() if "=" in line)
    n, nf = len(d["omega"]), len(d["frequency"])
    d["spectrum"] = np.asarray(d["spectrum"], float).reshape(n, nf)
    if len(d["rms"]) != n or len(d["status"]) != n or (d["orders"] is not None and len(d["orders"]) != n):
        fail(f"{path}: inconsistent /sweep datasets")
    # A sweep turning negatively (-sweep_rotation negative) stores -|omega|: plotted as the speed |omega|,
    # in ascending order, and named so.
    d["negative"] = bool(np.all(d["omega"] < 0))
    if d["negative"]:
        order = np.argsort(np.abs(d["omega"]))
        for k in ("omega", "rms", "status"):
            d[k] = np.asarray(d[k])[order]
        d["omega"] = np.abs(d["omega"])
        d["spectrum"] = d["spectrum"][order]
        if d["orders"] is not None:
            d["orders"] = d["orders"][order]
    lin = d["settings"].get("linear")
    d["name"] = {"0": "nonlinear", "1": "linear"}.get(lin, os.path.basename(path))
    if d["negative"]:
        d["name"] += ", turning negatively (|omega| shown)"
    d["path"] = path
    return d


def crossings(eig, lobes, max_eo, wmin, wmax):
    """[(omega, mode, k)]: omega = 2 pi f_mode / k in [wmin, wmax], k a multiple of lobes <= max_eo."""
    out = []
    for m, f in enumerate(eig[:N_CROSS_MODES], 1):
        for k in range(lobes, max_eo + 1, lobes):
            w = 2 * np.pi * f / k
            if wmin <= w <= wmax:
                out.append((w, m, k))
    return out[:MAX_CROSS_LINES]


def plot_map(runs, prefix, title, max_eo, fmax):
    for r in runs:
        if len(r["omega"]) < 2:
            print(f"{r['path']}: {len(r['omega'])} speed(s), no map")
    runs = [r for r in runs if len(r["omega"]) >= 2]
    if not runs:
        return
    ok = [(r["spectrum"][r["status"] == 0][:, r["frequency"] <= fmax]) for r in runs]
    allv = np.concatenate([a.ravel() for a in ok])
    allv = allv[np.isfinite(allv) & (allv > 0)]
    if allv.size == 0:
        print("no positive spectrum amplitude, no map")
        return
    vmax = allv.max()
    vmin = max(allv.min(), vmax * 1e-6)  # zeros and near-zeros are clipped to vmin
    fig, axes = plt.subplots(1, len(runs), figsize=(7.5 * len(runs), 5.5), squeeze=False, sharey=True,
                             constrained_layout=True)
    for ax, r in zip(axes[0], runs):
        w, f = r["omega"], r["frequency"]
        A = np.ma.masked_where(np.repeat((r["status"] != 0)[:, None], len(f), 1), np.maximum(r["spectrum"], vmin))
        pc = ax.pcolormesh(w, f, A.T, shading="nearest", norm=LogNorm(vmin, vmax), cmap="viridis")
        ax.set_xlim(w[0] - 0.5 * (w[1] - w[0]), w[-1] + 0.5 * (w[-1] - w[-2]))
        ax.set_ylim(0, fmax)
        x0, x1 = ax.get_xlim()
        for m, fe in enumerate(r["eigenfrequencies"], 1):
            if fe >= fmax:
                break
            ax.axhline(fe, color="w", ls="--", lw=0.9)
            if m <= N_MODE_LABELS:
                ax.text(x0 + 0.01 * (x1 - x0), fe, f"mode {m}", color="w", fontsize=8, va="bottom")
        xx = np.array([x0, x1])
        for k in range(1, max_eo + 1):
            ax.plot(xx, k * xx / (2 * np.pi), color="0.75", lw=0.6)
            fe = k * x1 / (2 * np.pi)
            if fe < 0.98 * fmax:
                ax.text(x1 - 0.005 * (x1 - x0), fe, f"eo {k}", color="w", fontsize=6.5, ha="right", va="bottom")
        ax.set_xlim(x0, x1)
        ax.set_xlabel(r"rotation speed $\Omega$ [rad/s]")
        ax.set_title(f"{r['name']} ({os.path.basename(r['path'])})")
    axes[0][0].set_ylabel("frequency [Hz]")
    fig.colorbar(pc, ax=axes[0].tolist(), label="spectrum amplitude [m]")
    if title:
        fig.suptitle(title)
    fig.savefig(f"{prefix}_map.png", dpi=130)
    plt.close(fig)
    print(f"wrote {prefix}_map.png")


def plot_rms(runs, prefix, title, max_eo):
    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    failed_label = "failed"
    for i, r in enumerate(runs):
        w, y, bad = r["omega"], r["rms"] * 1e3, r["status"] != 0
        ax.plot(w[~bad], y[~bad], ["o-", "s--"][i], ms=4, label=r["name"])
        for wi, yi in zip(w[bad], y[bad]):
            fin = np.isfinite(yi)  # a failed speed without an RMS goes to the bottom of the axes
            ax.plot(wi, yi if fin else 0.02, "rx", ms=8, mew=2, label=failed_label,
                    transform=ax.transData if fin else ax.get_xaxis_transform())
            failed_label = None
    ws = np.concatenate([r["omega"] for r in runs])
    if ws.size:
        lobes = int(runs[0]["settings"].get("lobes", 2))
        groups = []  # lines closer than 1.5% of the speed range share one label
        for w, m, k in sorted(crossings(runs[0]["eigenfrequencies"], lobes, max_eo, ws.min(), ws.max())):
            ax.axvline(w, color="0.5", ls=":", lw=1)
            if groups and w - groups[-1][0] < 0.015 * (np.ptp(ws) or 1):
                groups[-1][1].append(f"mode {m} / eo {k}")
            else:
                groups.append((w, [f"mode {m} / eo {k}"]))
        for w, labels in groups:
            ax.text(w, 0.98, ", ".join(sorted(labels)), transform=ax.get_xaxis_transform(), rotation=90, fontsize=7,
                    ha="right", va="top", color="0.3")
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.3 * (hi - lo))  # room for the labels above the curves
    ax.set_xlabel(r"rotation speed $\Omega$ [rad/s]")
    ax.set_ylabel(f"RMS of {runs[0]['settings'].get('monitor', 'monitored')} radial displacement [mm]")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    if title:
        ax.set_title(title)
    fig.savefig(f"{prefix}_rms.png", dpi=130)
    plt.close(fig)
    print(f"wrote {prefix}_rms.png")


def plot_orders(runs, prefix, title, orders):
    """One panel per engine order: its line amplitude [mm] against the speed, from /sweep/order_amplitude."""
    have = [r for r in runs if r["orders"] is not None]
    for r in runs:
        if r["orders"] is None:
            print(f"{r['path']}: no /sweep/order_amplitude (a sweep file older than 2026-12-02), no order lines")
    if not have or not orders:
        return
    fig, axes = plt.subplots(len(orders), 1, figsize=(8, 2.4 * len(orders)), sharex=True, squeeze=False,
                             constrained_layout=True)
    for ax, k in zip(axes[:, 0], orders):
        for i, r in enumerate(have):
            ok = r["status"] == 0
            if k > r["orders"].shape[1]:
                continue
            y = 1e3 * r["orders"][ok, k - 1]
            ax.semilogy(r["omega"][ok], np.where(y > 0, y, np.nan), ["-", "--"][i], lw=0.9, label=r["name"])
        ws = np.concatenate([r["omega"] for r in have])
        for m, f in enumerate(have[0]["eigenfrequencies"][:N_CROSS_MODES], 1):
            w = 2 * np.pi * f / k
            if ws.min() <= w <= ws.max():
                ax.axvline(w, color="0.5", ls=":", lw=1)
                ax.text(w, 0.97, f" mode {m} / eo {k}", transform=ax.get_xaxis_transform(), fontsize=7, va="top",
                        color="0.3")
        ax.set_ylabel(f"eo {k} [mm]")
        ax.grid(alpha=0.3, which="both")
    axes[0, 0].legend(loc="lower right", fontsize=8)
    axes[-1, 0].set_xlabel(r"rotation speed $\Omega$ [rad/s]")
    fig.suptitle(title or "engine-order lines at their exact frequencies (/sweep/order_amplitude)", fontsize=10)
    fig.savefig(f"{prefix}_orders.png", dpi=130)
    plt.close(fig)
    print(f"wrote {prefix}_orders.png")


def summary(r, orders=()):
    ok = r["status"] == 0
    w, y = r["omega"][ok], r["rms"][ok] * 1e3
    head = f"{r['name']} ({r['path']}): {len(r['omega'])} speed(s), {int((~ok).sum())} failed"
    if not len(w):
        print(head + ", no finished speed")
        return
    i = int(np.argmax(y))
    print(head + f"; highest RMS {y[i]:.4g} mm at omega = {w[i]:.6g} rad/s" + (" (range end)" if i in (0, len(w) - 1) else ""))
    peaks = [j for j in range(1, len(y) - 1) if y[j] >= y[j - 1] and y[j] > y[j + 1]]
    peaks = sorted(peaks, key=lambda j: -y[j])[:3]
    print("  local maxima of RMS: " + ("; ".join(f"omega = {w[j]:.6g} rad/s, {y[j]:.4g} mm" for j in peaks) or "none"))
    if r["orders"] is not None:
        for k in orders:
            if k <= r["orders"].shape[1]:
                a = 1e3 * r["orders"][ok, k - 1]
                if np.isfinite(a).any():
                    j = int(np.nanargmax(a))
                    print(f"  eo {k}: largest line {a[j]:.4g} mm at omega = {w[j]:.6g} rad/s")


def main():
    p = argparse.ArgumentParser(usage="%(prog)s SWEEP.h5 [SWEEP_LINEAR.h5] [options]",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="+", metavar="SWEEP.h5", help="one or two morse sweep files")
    p.add_argument("--out-prefix", help="output prefix (default: first file without .h5)")
    p.add_argument("--title", help="figure title")
    p.add_argument("--max-eo", type=int, default=20, help="highest engine order drawn (default 20)")
    p.add_argument("--fmax", type=float, help="top of the frequency axis [Hz] (default: the top bin)")
    p.add_argument("--orders", default="4,6,8", help="engine orders of PREFIX_orders.png (default 4,6,8)")
    p.add_argument("--names", help="comma-separated names of the files' panels and curves (default: from "
                   "settings linear=, e.g. two linear maps of different friction laws)")
    a = p.parse_args()
    try:
        orders = [int(x) for x in a.orders.split(",") if x.strip()]
    except ValueError:
        p.error(f"--orders {a.orders}: a comma-separated list of positive integers")
    if any(k < 1 for k in orders):
        p.error(f"--orders {a.orders}: engine orders start at 1")
    if len(a.files) > 2:
        p.error("at most two sweep files")
    runs = [load(f) for f in a.files]
    if a.names:
        names = a.names.split(",")
        if len(names) != len(runs):
            p.error(f"--names {a.names}: one name per file ({len(runs)})")
        for r, nm in zip(runs, names):
            r["name"] = nm
    if len(runs) == 2 and runs[0]["name"] == runs[1]["name"]:
        for i, r in enumerate(runs):
            r["name"] += f" [{i + 1}]"
    prefix = a.out_prefix or (a.files[0][:-3] if a.files[0].endswith(".h5") else a.files[0])
    fmax = a.fmax or max(r["frequency"].max() for r in runs)
    plot_map(runs, prefix, a.title, a.max_eo, fmax)
    plot_rms(runs, prefix, a.title, a.max_eo)
    plot_orders(runs, prefix, a.title, orders)
    for r in runs:
        summary(r, orders)


if __name__ == "__main__":
    main()
