#!/usr/bin/python3
"""Seed 000 Fig. 5 on morse's stator: MAC > 0.95 between the modes of EIM superelements
(criteria 90 %, 95 % and 26 modes) and the full-model modes.

The seed keeps 610 of its 1,650 candidates (37 %); morse's stator has 70 candidates below 1000 Hz,
so the equivalent count is 26 (run/selection_study.py's "n26"). A fourth run keeps every candidate
(plain Craig–Bampton) as the reference.

For each criterion, two `morse select` runs on the same candidates (out/study/basis.h5, else
out/fig5/basis.h5 made with `morse reduce -cb_fmax 1000 -cb_write_basis`):

  band  -select_fmax_analysis 500:  the check of docs/select (superelement modes below 500 Hz
        against the full-model modes below 500 Hz), MAC threshold 0.95: the printed summary;
  wide  -select_fmax_analysis 1000: the same MAC up to the candidate cutoff (superelement and
        full-model modes below 1000 Hz): the figure's points.

The full-model modes are those of `morse select`'s check: -clamp mount only, interface free.

Writes out/fig5/ (the .h5 and .log of every run, summary.json) and docs/select/img/fig5_eim_mac.png,
and prints the summary (docs/select/fig5.md quotes it).

usage: run/selection_fig5.py [--np N] [--reuse] [--basis FILE.h5]
  --np N      MPI ranks of morse (default 2)
  --reuse     keep existing out/fig5/*.h5 (only redo the plot and the summary)
  --basis F   candidate basis (default out/study/basis.h5 if present, else out/fig5/basis.h5)
"""
import argparse
import json
import os
import subprocess
import sys

import h5py
import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_select import clusters  # noqa: E402  (groups of near-repeated modes)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODEL = ["-mesh", "meshes/stator.msh", "-clamp", "mount", "-boundary", "interface"]
OUT = "out/fig5"
IMG = "docs/select/img/fig5_eim_mac.png"
F_BAND = 500.0    # analysis band: 2.5 x 200 Hz
F_WIDE = 1000.0   # candidate cutoff: 5 x 200 Hz
THRESHOLD = 0.95  # seed 000 Fig. 4-5
# key: (method, option, value, label); "all" gets the candidate count at run time.
CRITERIA = [("f90", "eim", "-select_fraction", "0.90", "EIM 90 %"),
            ("f95", "eim", "-select_fraction", "0.95", "EIM 95 %"),
            ("n26", "eim", "-select_num_modes", "26", "EIM 26 modes"),
            ("all", "frequency", "-select_num_modes", None, "all candidates (plain CB)")]


def sh(cmd, log):
    # run/env's MPI settings (root, few cores), so that the script runs without sourcing it.
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1",
               OMPI_MCA_btl_vader_single_copy_mechanism="none")
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    with open(os.path.join(ROOT, log), "w") as f:
        f.write(" ".join(cmd) + "\n" + r.stdout + r.stderr)
    if r.returncode != 0:
        sys.exit("selection_fig5: failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-3000:], r.stderr[-3000:]))


def mpi(n):
    return ["mpiexec", "--oversubscribe", "--bind-to", "none", "-n", str(n), "build/morse"]


def load(path, m):
    with h5py.File(os.path.join(ROOT, path), "r") as f:
        g = f["/select/" + m]
        d = {k: g[k][:] for k in ["mac", "best_mac", "subspace_mac", "rom_frequencies_hz", "selected"]}
        d.update({k: g.attrs[k].item() for k in ["n_selected", "retained_fraction", "n_rom_modes_in_band",
                                                   "n_mac_matches", "n_subspace_mac_matches",
                                                   "worst_frequency_error"]})
        d["fom_hz"] = f["/select/fom/frequencies_hz"][:]
        d["f_an"] = float(f["/select"].attrs["fmax_analysis_hz"])
        d["threshold"] = float(f["/select"].attrs["mac_threshold"])
        d["cb_in_band"] = int(f["/select"].attrs["cb_modes_in_band"])
        d["n_b"] = int(f["/rom"].attrs["n_boundary_dofs"])
    # /select/<m>/mac is [n_fom][max(n_in_band, 1)]: drop the placeholder column of an empty band.
    d["mac"] = d["mac"][:, :d["n_rom_modes_in_band"]]
    return d


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--np", type=int, default=2)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--basis", default=None)
    a = ap.parse_args()
    os.makedirs(os.path.join(ROOT, OUT), exist_ok=True)
    os.makedirs(os.path.dirname(os.path.join(ROOT, IMG)), exist_ok=True)

    basis = a.basis or ("out/study/basis.h5" if os.path.exists(os.path.join(ROOT, "out/study/basis.h5"))
                        else OUT + "/basis.h5")
    if not os.path.exists(os.path.join(ROOT, basis)):
        print("selection_fig5: candidate basis (reduce, every fixed-interface mode below 1000 Hz) -> " + basis,
              flush=True)
        sh(mpi(a.np) + ["reduce"] + MODEL + ["-cb_fmax", "1000", "-cb_write_basis", "-cb_xdmf", "0", "-out", basis],
           OUT + "/reduce.log")
    with h5py.File(os.path.join(ROOT, basis), "r") as f:
        n_cand = int(f["/rom"].attrs["n_modes"])
        n_b = int(f["/rom"].attrs["n_boundary_dofs"])
    print("selection_fig5: candidates from %s: %d fixed-interface modes, %d boundary DOFs" % (basis, n_cand, n_b),
          flush=True)

    res = []
    for key, m, opt, val, label in CRITERIA:
        val = val or str(n_cand)
        runs = {}
        for tag, fan in [("band", F_BAND), ("wide", F_WIDE)]:
            out = "%s/%s_%s_%s.h5" % (OUT, m, key, tag)
            if not (a.reuse and os.path.exists(os.path.join(ROOT, out))):
                print("selection_fig5: %s, analysis cutoff %g Hz" % (label, fan), flush=True)
                sh(mpi(a.np) + ["select"] + MODEL +
                   ["-select_from", basis, "-select_method", m, opt, val, "-select_fmax_analysis", "%g" % fan,
                    "-select_mac_threshold", "%g" % THRESHOLD, "-out", out], out.replace(".h5", ".log"))
            runs[tag] = load(out, m)
        res.append((key, m, label, runs))

    summary = report(res)
    with open(os.path.join(ROOT, OUT, "summary.json"), "w") as f:
        json.dump({"basis": basis, "n_candidates": n_cand, "n_boundary_dofs": n_b, "band_hz": F_BAND,
                   "wide_hz": F_WIDE, "mac_threshold": THRESHOLD, "criteria": summary}, f, indent=1)
    plot(res, n_cand)
    print("selection_fig5: wrote %s and %s/summary.json" % (IMG, OUT))


def report(res):
    b0 = res[0][3]["band"]
    w0 = res[0][3]["wide"]
    n_fom, n_fom_w = len(b0["fom_hz"]), len(w0["fom_hz"])
    print("\nEIM superelements vs the full model (clamp mount, interface free), MAC > %.2f" % THRESHOLD)
    print("  band %g Hz: %d full-model modes (%.1f .. %.1f Hz); up to %g Hz: %d full-model modes"
          % (F_BAND, n_fom, b0["fom_hz"][0], b0["fom_hz"][-1], F_WIDE, n_fom_w))
    print("\n  %-26s %4s %9s %5s %9s %9s %9s %6s %10s %14s"
          % ("criterion", "N", "retained%", "DOFs", "SE<500Hz", "MAC>0.95", "subspace", "sum", "worst df%",
             "MAC>0.95<1kHz"))
    groups = clusters(b0["fom_hz"])
    out = []
    for key, m, label, r in res:
        b, w = r["band"], r["wide"]
        N, nb = b["n_selected"], b["n_b"]
        # The same count from the wide run, restricted to the band on both sides (its full-model
        # solve picks its own basis inside clusters of repeated modes: pairwise MAC may differ).
        jb = int(np.sum(w["fom_hz"] <= F_BAND))
        kb = int(np.sum(w["rom_frequencies_hz"] <= F_BAND))
        wide_band = int(np.sum(w["mac"][:jb, :kb].max(axis=1, initial=0) > THRESHOLD))
        unmatched = [j for j in range(n_fom) if b["best_mac"][j] <= THRESHOLD]
        row = {"key": key, "method": m, "label": label, "n_selected": N, "retained_fraction": b["retained_fraction"],
               "n_boundary_dofs": nb, "dofs": nb + N, "rom_modes_in_band": b["n_rom_modes_in_band"],
               "fom_modes_in_band": n_fom, "mac_matches": b["n_mac_matches"],
               "subspace_mac_matches": b["n_subspace_mac_matches"],
               "worst_frequency_error": b["worst_frequency_error"],
               "unmatched_fom_hz": [float(b["fom_hz"][j]) for j in unmatched],
               "rom_modes_below_wide": w["n_rom_modes_in_band"], "fom_modes_below_wide": len(w["fom_hz"]),
               "mac_matches_below_wide": w["n_mac_matches"], "wide_run_mac_matches_in_band": wide_band,
               "wide_run_fom_modes_in_band": jb, "subspace_mac_sum": float(np.sum(b["subspace_mac"])),
               "subspace_mac_sum_per_group": [float(np.sum(b["subspace_mac"][g])) for g in groups],
               "mac_matches_per_group": [int(np.sum(b["best_mac"][g] > THRESHOLD)) for g in groups]}
        out.append(row)
        print("  %-26s %4d %9.2f %5d %9d %6d/%-2d %6d/%-2d %6.2f %10.3f %11d/%-2d"
              % (label, N, 100 * b["retained_fraction"], nb + N, b["n_rom_modes_in_band"], b["n_mac_matches"],
                 n_fom, b["n_subspace_mac_matches"], n_fom, row["subspace_mac_sum"],
                 100 * b["worst_frequency_error"], w["n_mac_matches"], len(w["fom_hz"])))
    print("\n  N: fixed-interface modes kept; DOFs: %d boundary DOFs + N; SE<500Hz: superelement modes in the band;"
          % out[0]["n_boundary_dofs"])
    print("  MAC>0.95: full-model modes in the band whose best pairwise MAC with an in-band superelement mode")
    print("  exceeds 0.95; subspace: the same with the subspace MAC (docs/select/README.md); sum: the subspace")
    print("  MAC summed over the band's full-model modes (dimension of the band's full-model modal space that the")
    print("  in-band superelement modes represent); last column: the pairwise count with superelement and")
    print("  full-model modes below %g Hz (the figure)." % F_WIDE)
    print("\n  subspace MAC summed per group of full-model modes (frequencies within 1 %%), band %g Hz:" % F_BAND)
    print("  %-26s %s" % ("group [Hz] (modes)", " ".join("%13s" % ("%.0f (%d)" % (b0["fom_hz"][g[0]], len(g)))
                                                         for g in groups)))
    for row in out:
        print("  %-26s %s" % (row["label"], " ".join("%13.2f" % v for v in row["subspace_mac_sum_per_group"])))
    print("\n  full-model modes matched pairwise (best MAC > 0.95) per group, band %g Hz:" % F_BAND)
    for row in out:
        print("  %-26s %s" % (row["label"], " ".join("%10d/%-2d" % (m, len(g)) for m, g in
                                                     zip(row["mac_matches_per_group"], groups))))
    for row in out:
        if row["wide_run_mac_matches_in_band"] != row["mac_matches"]:
            print("  note: %s: the %g Hz run's own pairs give %d/%d in the band (vs %d/%d above)"
                  % (row["label"], F_WIDE, row["wide_run_mac_matches_in_band"], row["wide_run_fom_modes_in_band"],
                     row["mac_matches"], row["fom_modes_in_band"]))
    return out


def plot(res, n_cand):
    n = len(res)
    fig, axs = plt.subplots((n + 1) // 2, 2, figsize=(11, 5.0 * ((n + 1) // 2)), sharex=True, sharey=True)
    axs = axs.ravel()
    for ax in axs[n:]:
        ax.set_visible(False)
    ymax = max(r["wide"]["n_b"] + r["wide"]["n_selected"] for _, _, _, r in res) + 4
    xmax = max(len(r["wide"]["fom_hz"]) for _, _, _, r in res) + 2
    norm = plt.Normalize(THRESHOLD, 1.0)
    sc = None
    for ax, (key, m, label, r) in zip(axs, res):
        w, b = r["wide"], r["band"]
        N, nb = w["n_selected"], w["n_b"]
        j, k = np.nonzero(w["mac"] > THRESHOLD)
        sc = ax.scatter(j + 1, k + 1, c=w["mac"][j, k], cmap="viridis", norm=norm, s=18, zorder=3,
                        label="pairwise MAC > %.2f" % THRESHOLD)
        # Full-model modes that the superelement's modes below 1000 Hz represent as a space
        # (subspace MAC, any pairing: clusters of repeated modes), as a rug along the x axis.
        js = np.nonzero(w["subspace_mac"] > THRESHOLD)[0]
        ax.plot(js + 1, np.full(len(js), 0.0), "|", color="0.45", ms=9, mew=1.2, clip_on=False, zorder=4,
                label="subspace MAC > %.2f (rug)" % THRESHOLD)
        ax.plot([0, xmax], [0, xmax], color="0.8", lw=0.6, zorder=1)
        ax.axhline(nb + N, color="k", ls=(0, (2, 2)), lw=1.0, label="superelement DOFs: %d + %d = %d"
                   % (nb, N, nb + N))
        ax.axhline(N, color="k", ls=(0, (8, 4)), lw=1.0, label="internal modes kept: %d" % N)
        ax.axvline(b["n_rom_modes_in_band"] + 0.5, color="k", lw=1.2,
                   label="superelement modes < %g Hz: %d" % (F_BAND, b["n_rom_modes_in_band"]))
        ax.axvline(len(b["fom_hz"]) + 0.5, color="tab:red", lw=0.9, ls=":",
                   label="full-model modes < %g Hz: %d" % (F_BAND, len(b["fom_hz"])))
        ax.set_xlim(0, xmax)
        ax.set_ylim(0, ymax)
        ax.set_title("%s (N = %d)\npairwise MAC > %.2f: %d/%d modes < %g Hz, %d/%d < %g Hz"
                     % (label, N, THRESHOLD, b["n_mac_matches"], len(b["fom_hz"]), F_BAND, w["n_mac_matches"],
                        len(w["fom_hz"]), F_WIDE), fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", framealpha=0.9)
    for ax in axs[max(n - 2, 0):n]:
        ax.set_xlabel("full-model mode (ascending frequency)")
        ax.xaxis.set_tick_params(labelbottom=True)
    for ax in axs[0:n:2]:
        ax.set_ylabel("superelement mode (ascending frequency)")
    fig.suptitle("Stator, %d candidates < %g Hz: MAC between superelement and full-model modes below %g Hz "
                 "(seed 000 Fig. 5)" % (n_cand, F_WIDE, F_WIDE), fontsize=11)
    fig.tight_layout(rect=(0, 0, 0.9, 0.97))
    cax = fig.add_axes((0.915, 0.3, 0.015, 0.4))
    fig.colorbar(sc, cax=cax, label="MAC")
    fig.savefig(os.path.join(ROOT, IMG), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
