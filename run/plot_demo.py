#!/usr/bin/python3
"""Plots of the morse demo (run/demo): full model vs Craig-Bampton superelement.

usage: /usr/bin/python3 run/plot_demo.py [DIR]   (DIR defaults to out/demo; reads DIR/modes.h5 and
       DIR/superelement.h5, writes DIR/*.png)

Needs h5py, numpy, matplotlib (Agg backend); scipy is used if present (numpy fallback).
Writes
  frequencies.png   full-model vs superelement frequencies (first N) and their relative error in %
  mode_shapes.png   the first 4 full-model mode shapes as deformed node clouds (x-y, x-z views)
  rom_matrices.png  log10 |value| of the superelement matrices /rom/K and /rom/M
and recomputes the superelement frequencies from /rom/K and /rom/M to check /rom/frequencies_hz.
"""
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

try:
    import scipy.linalg as sla
except ImportError:  # pragma: no cover - numpy fallback
    sla = None

N_COMPARE = 12  # modes compared in frequencies.png (at most the number of full-model modes)
N_SHAPES = 4


def generalized_eigenvalues(K, M):
    """Eigenvalues of K x = lambda M x (K symmetric, M symmetric positive definite), ascending."""
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    if sla is not None:
        return sla.eigh(K, M, eigvals_only=True), "scipy.linalg.eigh"
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    A = Li @ K @ Li.T
    return np.sort(np.linalg.eigvalsh(0.5 * (A + A.T))), "numpy (Cholesky + eigvalsh)"


def to_hz(lam):
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


def plot_frequencies(f_fom, f_rom, f_fi, path):
    n = min(N_COMPARE, len(f_fom), len(f_rom))
    idx = np.arange(1, n + 1)
    err = 100.0 * (f_rom[:n] - f_fom[:n]) / f_fom[:n]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True,
                                  gridspec_kw={"height_ratios": [3, 2]})
    w = 0.38
    ax.bar(idx - w / 2, f_fom[:n], w, label="full model (morse modes)", color="tab:blue")
    ax.bar(idx + w / 2, f_rom[:n], w, label="superelement (morse reduce)", color="tab:orange")
    nfi = min(n, len(f_fi))
    if nfi:
        ax.plot(np.arange(1, nfi + 1), f_fi[:nfi], "k.--", lw=0.8,
                label="fixed-interface modes (x1 clamped too)")
    ax.set_yscale("log")
    ax.set_ylabel("frequency [Hz]")
    ax.set_title("Cantilever beam: full model vs Craig-Bampton superelement")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(True, which="both", axis="y", alpha=0.3)
    ax2.bar(idx, np.abs(err), 0.6, color=np.where(err >= 0, "tab:red", "tab:green"))
    ax2.set_yscale("log")
    ax2.set_ylabel("|relative error| [%]")
    ax2.set_xlabel("mode")
    ax2.set_xticks(idx)
    ax2.grid(True, which="both", axis="y", alpha=0.3)
    ax2.set_title("superelement error (red: too stiff, green: too soft)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return err


def plot_mode_shapes(xyz, shapes, f_fom, path):
    """Rows: modes; columns: x-y (top view) and x-z (side view) projections of the node cloud."""
    n = min(N_SHAPES, shapes.shape[0])
    extent = np.ptp(xyz, axis=0)
    scale_len = 0.12 * extent.max()
    fig, axes = plt.subplots(n, 2, figsize=(13, 2.3 * n + 0.8), squeeze=False)
    sc = None
    for k in range(n):
        u = shapes[k]
        umag = np.linalg.norm(u, axis=1)
        s = scale_len / max(umag.max(), 1e-300)
        d = xyz + s * u
        dominant = "xyz"[int(np.argmax(np.abs(u).max(axis=0)))]
        for col, (j, lab) in enumerate(((1, "y"), (2, "z"))):
            ax = axes[k, col]
            ax.scatter(xyz[:, 0], xyz[:, j], s=1, c="0.8", lw=0)
            sc = ax.scatter(d[:, 0], d[:, j], s=3, c=umag / umag.max(), cmap="viridis", vmin=0, vmax=1,
                            lw=0)
            ax.set_aspect("equal")
            ax.set_ylim(xyz[:, j].min() - 1.1 * scale_len, xyz[:, j].max() + 1.1 * scale_len)
            ax.set_ylabel(f"{lab} [m]")
            ax.tick_params(labelsize=7)
            ax.set_title(f"mode {k + 1}: {f_fom[k]:.2f} Hz, {'top view x-y' if j == 1 else 'side view x-z'}"
                         f"  (largest displacement along {dominant})", fontsize=9)
            if k == n - 1:
                ax.set_xlabel("x [m]")
    fig.colorbar(sc, ax=axes, shrink=0.6, label="|u| / max |u|")
    fig.suptitle("Full-model mode shapes: deformed node clouds (grey: undeformed; "
                 "largest displacement drawn as 12% of the length)", fontsize=11)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_matrices(K, M, n_b, path):
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    for ax, A, name in ((axes[0], K, "K"), (axes[1], M, "M")):
        a = np.abs(A)
        top = a.max()
        with np.errstate(divide="ignore"):
            la = np.log10(a)
        la = np.ma.masked_less(la, np.log10(top) - 16.0)  # exact zeros and round-off: blank
        im = ax.imshow(la, cmap="magma_r", interpolation="nearest")
        if 0 < n_b < A.shape[0]:
            for f in (ax.axhline, ax.axvline):
                f(n_b - 0.5, color="tab:cyan", lw=0.8)
        ax.set_title(f"/rom/{name}: log10 |value|  ({A.shape[0]}x{A.shape[1]}, {n_b} boundary DOFs first)",
                     fontsize=9)
        ax.set_xlabel("column")
        ax.set_ylabel("row")
        fig.colorbar(im, ax=ax, shrink=0.8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    outdir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "out", "demo")
    modes_h5 = os.path.join(outdir, "modes.h5")
    se_h5 = os.path.join(outdir, "superelement.h5")
    for p in (modes_h5, se_h5):
        if not os.path.isfile(p):
            sys.exit(f"plot_demo: error: {p} not found (run run/demo first)")

    with h5py.File(modes_h5, "r") as h:
        f_fom = h["/fom/frequencies_hz"][()]
        xyz = h["/mesh/coordinates"][()]
        shapes = h["/fom/mode_shapes"][()]
    with h5py.File(se_h5, "r") as h:
        f_fi = h["/cb/fixed_interface/frequencies_hz"][()]
        K = h["/rom/K"][()]
        M = h["/rom/M"][()]
        f_rom = h["/rom/frequencies_hz"][()]
        n_b = int(h["/rom"].attrs.get("n_boundary_dofs", 0))

    # Superelement frequencies recomputed here from /rom/K and /rom/M.
    lam, how = generalized_eigenvalues(K, M)
    f_mine = to_hz(lam)
    n = min(len(f_mine), len(f_rom))
    rel = np.abs(f_mine[:n] - f_rom[:n]) / np.maximum(np.abs(f_rom[:n]), 1e-300)
    asym_k = np.abs(K - K.T).max() / np.abs(K).max()
    asym_m = np.abs(M - M.T).max() / np.abs(M).max()
    print(f"plot_demo: superelement {K.shape[0]} DOFs ({n_b} boundary + {K.shape[0] - n_b} modal); "
          f"relative asymmetry K {asym_k:.1e}, M {asym_m:.1e}")
    print(f"plot_demo: superelement frequencies recomputed with {how}: max relative difference "
          f"to /rom/frequencies_hz over {n} modes = {rel.max():.2e}"
          + ("  OK" if rel.max() < 1e-6 else "  MISMATCH"))

    paths = [os.path.join(outdir, p) for p in ("frequencies.png", "mode_shapes.png", "rom_matrices.png")]
    err = plot_frequencies(f_fom, f_rom, f_fi, paths[0])
    plot_mode_shapes(xyz, shapes, f_fom, paths[1])
    plot_matrices(K, M, n_b, paths[2])

    print(f"\n  {'mode':<6}{'full [Hz]':>14}{'superelement [Hz]':>20}{'recomputed [Hz]':>18}{'error [%]':>12}")
    for i in range(len(err)):
        print(f"  {i + 1:<6}{f_fom[i]:>14.4f}{f_rom[i]:>20.4f}{f_mine[i]:>18.4f}{err[i]:>12.4f}")
    print()
    for p in paths:
        print(f"plot_demo: wrote {p}")
    return 0 if rel.max() < 1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
