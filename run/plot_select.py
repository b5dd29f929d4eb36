#!/usr/bin/python3
"""Plots and comparison table of a `morse select` run (seed 000 Fig. 3, 4, 6 and Table 1).

usage: /usr/bin/python3 run/plot_select.py FILE.h5 OUTDIR [--method NAME] [--nmac N]
                                          [--modes MODES.h5] [--r-inner R] [--r-outer R]

  FILE.h5          output of `morse select` (datasets /select/<method>/..., see docs/select/README.md)
  OUTDIR           where the PNGs and table.md go (created if needed)
  --method NAME    method of the MAC-matrix and local-mode plots (default: the one written to /rom,
                   i.e. -select_rom_method)
  --nmac N         full-model and superelement modes shown in the MAC matrix (default 20)
  --modes FILE     output of `morse modes` on the same model with -modes_nev = the number of
                   full-model modes in the analysis band: enables the local-mode analysis
  --r-inner/--r-outer  radii [m] between which nodes count as "vane" nodes (default 0.30 and 0.60,
                   the hub and casing surfaces of meshes/stator*.msh); r <= r-inner is "hub",
                   r >= r-outer "casing" (casing and flanges)

Needs h5py, numpy, matplotlib (Agg). Use Debian's /usr/bin/python3. Writes
  cumulative.png        per method: cumulative fraction of the method's own score, candidates in
                        frequency order vs ranked by decreasing score (Fig. 3)
  cumulative_<m>.png    the same for --method alone, annotated (Fig. 3 proper for m = eim)
  mac_<m>.png           MAC matrix, first N full-model modes vs the first N in-band modes of the
                        plain (frequency-order) superelement and of the --method superelement (Fig. 4)
  mac_map.png           per method, full-model modes whose best pairwise MAC (filled dot) and
                        subspace MAC (open circle) exceed the threshold (Fig. 6)
  counts.png            N selected, superelement modes in band and subspace-MAC matches per method
  local_modes.png       (with --modes) kinetic-energy share of the vanes / hub / casing of every
                        full-model mode in band, marked captured or not by the --method superelement
  table.md              the comparison table (also printed), and with --modes the local-mode tables
"""
import argparse
import os
import re
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ORDER = ["frequency", "lpf", "eim", "veim", "deim", "omr", "cmschi", "ebr", "imr"]
LABEL = {"frequency": "frequency", "lpf": "LPF", "eim": "EIM", "veim": "VEIM", "deim": "DEIM",
         "omr": "OMR", "cmschi": "CMS$\\chi$", "ebr": "EBR", "imr": "IMR"}
TEXT_LABEL = {"frequency": "frequency", "lpf": "LPF", "eim": "EIM", "veim": "VEIM", "deim": "DEIM",
              "omr": "OMR", "cmschi": "CMSchi", "ebr": "EBR", "imr": "IMR"}
# XDMF topology codes -> number of nodes
XDMF_NODES = {6: 4, 38: 10, 8: 6, 40: 15, 9: 8, 48: 20}


def s(x):
    return x.decode() if isinstance(x, bytes) else str(x)


def load(path):
    d = {"methods": {}}
    with h5py.File(path, "r") as f:
        sel = f["/select"]
        d["f_fom"] = sel["fom/frequencies_hz"][...]
        d["f_an"] = float(sel.attrs["fmax_analysis_hz"])
        d["thr"] = float(sel.attrs["mac_threshold"])
        d["cb_in_band"] = int(sel.attrs["cb_modes_in_band"])
        d["f_fi"] = f["/cb/fixed_interface/frequencies_hz"][...]
        d["rom_method"] = s(f["/rom"].attrs.get("selection_method", b"")) if "/rom" in f else ""
        d["options"] = s(f["/meta/options"][()]) if "/meta/options" in f else ""
        d["coords"] = f["/mesh/coordinates"][...]
        d["topology"] = f["/mesh/topology"][...]
        names = [k for k in sel.keys() if k not in ("fom", "effective_mass")]
        names.sort(key=lambda k: ORDER.index(k) if k in ORDER else len(ORDER))
        for k in names:
            g = sel[k]
            m = {key: g[key][...] for key in ("scores", "score_fractions", "ranking", "cumulative", "selected",
                                              "rom_frequencies_hz", "mac", "best_mac", "subspace_mac")}
            m.update({key: float(v) for key, v in g.attrs.items()})
            d["methods"][k] = m
    # Truncation target from the recorded options (default 0.95).
    opts = d["options"]
    mf = re.search(r"-select_fraction\s+(\S+)", opts)
    mn = re.search(r"-select_num_modes\s+(\S+)", opts)
    d["fraction"] = float(mf.group(1)) if mf else (None if mn else 0.95)
    d["num_modes"] = int(mn.group(1)) if mn else None
    return d


def n_to_reach(cum, target):
    """Shortest prefix whose cumulative fraction reaches target (as morse truncates)."""
    idx = np.nonzero(cum >= target * (1 - 1e-12))[0]
    return int(idx[0]) + 1 if len(idx) else len(cum)


# ------------------------------------------------------------------------------------ (a) Fig. 3
def plot_cumulative(d, path):
    names = list(d["methods"])
    nc = 3
    nr = (len(names) + nc - 1) // nc
    fig, axes = plt.subplots(nr, nc, figsize=(4.2 * nc, 3.2 * nr), squeeze=False)
    for ax, k in zip(axes.flat, names):
        m = d["methods"][k]
        n = len(m["scores"])
        x = np.arange(1, n + 1)
        freq_cum = np.cumsum(m["score_fractions"])
        N = int(m["n_selected"])
        if k == "frequency":
            ax.plot(x, freq_cum, "k-", lw=1.5, label="EIM, frequency order")
        else:
            ax.plot(x, freq_cum, "-", color="tab:gray", lw=1.5, label="frequency order")
            ax.plot(x, m["cumulative"], "-", color="tab:red", lw=1.5, label="ranked")
            nf = n_to_reach(freq_cum, m["retained_fraction"])
            ax.plot([nf], [freq_cum[nf - 1]], "o", color="tab:gray", ms=5)
            ax.annotate(f"{nf}", (nf, freq_cum[nf - 1]), textcoords="offset points", xytext=(4, -12),
                        color="tab:gray", fontsize=8)
        ax.plot([N], [m["retained_fraction"]], "o", color="tab:red" if k != "frequency" else "k", ms=5)
        ax.annotate(f"N = {N}", (N, m["retained_fraction"]), textcoords="offset points", xytext=(-10, -16),
                    fontsize=8)
        if d["fraction"] is not None:
            ax.axhline(d["fraction"], color="k", ls=":", lw=0.8)
        ax.set_title(LABEL.get(k, k))
        ax.set_ylim(0, 1.02)
        ax.set_xlim(0, n + 1)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right", fontsize=7)
    for ax in axes.flat[len(names):]:
        ax.axis("off")
    for ax in axes[-1]:
        ax.set_xlabel("number of fixed-interface modes")
    for ax in axes[:, 0]:
        ax.set_ylabel("cumulative score fraction")
    fig.suptitle("Cumulative score: candidates in frequency order vs ranked (seed 000 Fig. 3)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_cumulative_one(d, k, path):
    m = d["methods"][k]
    n = len(m["scores"])
    x = np.arange(1, n + 1)
    freq_cum = np.cumsum(m["score_fractions"])
    target = m["retained_fraction"] if d["fraction"] is None else d["fraction"]
    N = int(m["n_selected"])
    nf = n_to_reach(freq_cum, target)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(x, freq_cum, "-", color="tab:gray", lw=2, label=f"{TEXT_LABEL.get(k, k)}, increasing frequency")
    ax.plot(x, m["cumulative"], "-", color="tab:red", lw=2, label=f"decreasing {TEXT_LABEL.get(k, k)}")
    ax.axhline(target, color="k", ls=":", lw=1)
    ax.plot([N, nf], [m["cumulative"][N - 1], freq_cum[nf - 1]], "ko", ms=5)
    ax.annotate(f"{N} modes ranked", (N, m["cumulative"][N - 1]), textcoords="offset points", xytext=(-130, 16),
                color="tab:red", arrowprops=dict(arrowstyle="->", lw=0.6, color="tab:red"))
    ax.annotate(f"{nf} modes in frequency order", (nf, freq_cum[nf - 1]), textcoords="offset points",
                xytext=(-60, -70), color="tab:gray", arrowprops=dict(arrowstyle="->", lw=0.6, color="tab:gray"))
    ax.set_xlabel("number of fixed-interface modes")
    ax.set_ylabel(f"cumulative {TEXT_LABEL.get(k, k)} fraction")
    ax.set_ylim(0, 1.12)
    ax.set_xlim(0, n + 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    ax.set_title(f"Cumulative {TEXT_LABEL.get(k, k)}: {target:.0%} reached with {N} ranked vs {nf} "
                 "frequency-ordered modes", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ------------------------------------------------------------------------------------ (b) Fig. 4
def plot_mac(d, k, nmac, path):
    panels = [x for x in ("frequency", k) if x in d["methods"]]
    if k == "frequency":
        panels = ["frequency"]
    fig, axes = plt.subplots(1, len(panels), figsize=(6.2 * len(panels), 5.6), squeeze=False)
    f_fom = d["f_fom"]
    for ax, name in zip(axes[0], panels):
        m = d["methods"][name]
        nin = int(m["n_rom_modes_in_band"])
        mac = m["mac"][:nmac, :min(nmac, nin)] if nin > 0 else np.zeros((min(nmac, len(f_fom)), 1))
        nv, nq = mac.shape
        im = ax.imshow(mac, vmin=0, vmax=1, cmap="Greys", origin="upper", aspect="auto")
        for i in range(nv):
            for j in range(nq):
                if mac[i, j] >= 0.1:
                    ax.text(j, i, "1" if mac[i, j] >= 0.995 else f"{mac[i, j]:.2f}"[1:], ha="center",
                            va="center", fontsize=5.5, color="w" if mac[i, j] > 0.5 else "k")
        # FOM modes the superelement does not represent (subspace MAC below the threshold): red
        for i in range(nv):
            ok = m["subspace_mac"][i] > d["thr"]
            ax.add_patch(plt.Rectangle((-0.5, i - 0.5), nq, 1, fill=False, lw=1.2 if not ok else 0,
                                       ec="tab:red" if not ok else "none"))
        rf = m["rom_frequencies_hz"]
        ax.set_xticks(range(nq))
        ax.set_xticklabels([f"{j + 1}: {rf[j]:.1f}" for j in range(nq)], rotation=90, fontsize=6)
        ax.set_yticks(range(nv))
        ax.set_yticklabels([f"{i + 1}: {f_fom[i]:.1f}" for i in range(nv)], fontsize=6)
        for i, lab in enumerate(ax.get_yticklabels()):
            if m["subspace_mac"][i] <= d["thr"]:
                lab.set_color("tab:red")
        ax.set_xlabel(f"superelement mode ({TEXT_LABEL.get(name, name)}, N = {int(m['n_selected'])}): Hz")
        ax.set_ylabel("full-model mode: Hz")
        ax.set_title(f"{TEXT_LABEL.get(name, name)}: MAC, first {nv} full-model modes\n"
                     f"(red: subspace MAC <= {d['thr']:g}, mode not represented)", fontsize=9)
        fig.colorbar(im, ax=ax, fraction=0.04)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


# ------------------------------------------------------------------------------------ (c) Fig. 6
def plot_mac_map(d, path):
    names = list(d["methods"])
    f_fom = d["f_fom"]
    n = len(f_fom)
    fig, ax = plt.subplots(figsize=(max(8, 0.22 * n + 3), 0.45 * len(names) + 2))
    x = np.arange(1, n + 1)
    for row, k in enumerate(names):
        m = d["methods"][k]
        y = len(names) - 1 - row
        sub = m["subspace_mac"] > d["thr"]
        best = m["best_mac"] > d["thr"]
        ax.plot(x[sub], np.full(sub.sum(), y), "o", mfc="none", mec="tab:blue", ms=9, mew=1.2,
                label="subspace MAC > thr" if row == 0 else None)
        ax.plot(x[best], np.full(best.sum(), y), "o", color="k", ms=4, label="best MAC > thr" if row == 0 else None)
        ax.text(n + 1.0, y, f"{int(m['n_mac_matches'])} / {int(m['n_subspace_mac_matches'])}", va="center",
                fontsize=8)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels([f"{LABEL.get(k, k)} (N={int(d['methods'][k]['n_selected'])})" for k in reversed(names)])
    ax.set_xlim(0.3, n + 3.5)
    ax.set_ylim(-0.7, len(names) - 0.3)
    step = max(1, n // 15)
    ticks = list(range(1, n + 1, step))
    if ticks[-1] != n:
        ticks.append(n)
    ax.set_xticks(ticks)
    ax.set_xticklabels([f"{t}\n{f_fom[t - 1]:.0f}" for t in ticks], fontsize=7)
    ax.set_xlabel("full-model mode (number / frequency [Hz])")
    ax.grid(axis="x", alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=2, fontsize=8)
    ax.set_title(f"Full-model modes represented by each superelement (MAC > {d['thr']:g}; "
                 "right: pairwise / subspace matches)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ------------------------------------------------------------------------------------ (d) counts
def plot_counts(d, path):
    names = list(d["methods"])
    x = np.arange(len(names))
    w = 0.27
    sel = [d["methods"][k]["n_selected"] for k in names]
    inb = [d["methods"][k]["n_rom_modes_in_band"] for k in names]
    sub = [d["methods"][k]["n_subspace_mac_matches"] for k in names]
    fig, ax = plt.subplots(figsize=(9, 4.8))
    b1 = ax.bar(x - w, sel, w, label="N selected fixed-interface modes", color="tab:red")
    b2 = ax.bar(x, inb, w, label=f"superelement modes below {d['f_an']:g} Hz", color="tab:blue")
    b3 = ax.bar(x + w, sub, w, label=f"full-model modes with subspace MAC > {d['thr']:g}", color="tab:green")
    for bars in (b1, b2, b3):
        for b in bars:
            ax.text(b.get_x() + b.get_width() / 2, b.get_height() + 0.5, f"{int(b.get_height())}", ha="center",
                    fontsize=7)
    ax.axhline(len(d["f_fi"]), color="tab:red", ls=":", lw=1, label=f"candidates ({len(d['f_fi'])})")
    ax.axhline(d["cb_in_band"], color="tab:blue", ls="--", lw=1,
               label=f"plain Craig-Bampton modes in band ({d['cb_in_band']})")
    ax.axhline(len(d["f_fom"]), color="tab:green", ls="-.", lw=1,
               label=f"full-model modes in band ({len(d['f_fom'])})")
    ax.set_xticks(x)
    ax.set_xticklabels([LABEL.get(k, k) for k in names])
    ax.set_ylabel("number of modes")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    ax.set_title("Modes kept and superelement modes in the analysis band, per method")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def table(d):
    hdr = ("| method | N | retained % | SE modes in band | MAC > thr | subspace MAC > thr | "
           "worst freq. error % |\n|---|---|---|---|---|---|---|\n")
    rows = []
    nf = len(d["f_fom"])
    for k, m in d["methods"].items():
        rows.append(f"| {TEXT_LABEL.get(k, k)} | {int(m['n_selected'])} | {100 * m['retained_fraction']:.2f} | "
                    f"{int(m['n_rom_modes_in_band'])} | {int(m['n_mac_matches'])}/{nf} | "
                    f"{int(m['n_subspace_mac_matches'])}/{nf} | {100 * m['worst_frequency_error']:.3f} |")
    head = (f"{len(d['f_fi'])} candidate fixed-interface modes ({d['f_fi'][0]:.1f}-{d['f_fi'][-1]:.1f} Hz), "
            f"analysis band {d['f_an']:g} Hz: {nf} full-model modes, plain Craig-Bampton "
            f"{d['cb_in_band']} superelement modes in band; MAC threshold {d['thr']:g}\n\n")
    # Captured dimension per cluster of near-repeated full-model modes: the sum of the subspace MAC over
    # a cluster is the dimension of the cluster's space that the superelement represents, whatever
    # basis the eigen solver picked inside the cluster (pairwise and per-mode values are not).
    cl = clusters(d["f_fom"])
    chdr = "| method | " + " | ".join(f"{d['f_fom'][c[0]]:.0f} Hz ({len(c)})" for c in cl) + " |\n"
    chdr += "|---" * (len(cl) + 1) + "|\n"
    crows = []
    for k, m in d["methods"].items():
        crows.append(f"| {TEXT_LABEL.get(k, k)} | " +
                     " | ".join(f"{m['subspace_mac'][np.array(c)].sum():.2f}" for c in cl) + " |")
    ctext = ("\nCaptured dimension per cluster of full-model modes (relative gap < 1 %; header: lowest "
             "frequency (modes in the cluster)), i.e. the sum of the subspace MAC over the cluster:\n\n")
    return head + hdr + "\n".join(rows) + "\n" + ctext + chdr + "\n".join(crows) + "\n"


# ------------------------------------------------------------------------------------ local modes
def nodal_mass_weights(coords, topology):
    """Lumped nodal volume: each element gives volume / n_nodes to each of its nodes (volume from the
    corner nodes: trilinear hexahedron with 2x2x2 Gauss, tetrahedron, wedge as 3 tetrahedra)."""
    w = np.zeros(len(coords))
    i = 0
    g = 1 / np.sqrt(3)
    sgn = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
    gauss = np.array(np.meshgrid([-g, g], [-g, g], [-g, g])).reshape(3, -1).T

    def tet(a, b, c, e):
        return abs(np.linalg.det(np.array([b - a, c - a, e - a]))) / 6

    while i < len(topology):
        code = int(topology[i])
        nn = XDMF_NODES[code]
        nodes = topology[i + 1:i + 1 + nn]
        i += 1 + nn
        x = coords[nodes]
        if code in (9, 48):
            vol = 0.0
            for p in gauss:
                f1, f2, f3 = (1 + sgn * p).T
                dn = np.stack([sgn[:, 0] * f2 * f3, f1 * sgn[:, 1] * f3, f1 * f2 * sgn[:, 2]], 1) / 8
                vol += abs(np.linalg.det(dn.T @ x[:8]))
        elif code in (6, 38):
            vol = tet(*x[:4])
        else:  # wedge: corners 0 1 2 (bottom), 3 4 5 (top)
            vol = tet(x[0], x[1], x[2], x[3]) + tet(x[1], x[2], x[3], x[4]) + tet(x[2], x[3], x[4], x[5])
        w[nodes] += vol / nn
    return w


def clusters(freq, rel=0.01):
    """Groups consecutive modes whose frequencies differ by less than rel (relative)."""
    groups, cur = [], [0]
    for j in range(1, len(freq)):
        if freq[j] <= freq[cur[0]] * (1 + rel):
            cur.append(j)
        else:
            groups.append(cur)
            cur = [j]
    groups.append(cur)
    return groups


def local_modes(d, k, modes_path, r_in, r_out, path):
    with h5py.File(modes_path, "r") as f:
        f_modes = f["/fom/frequencies_hz"][...]
        shapes = f["/fom/mode_shapes"]
        xyz = f["/mesh/coordinates"][...]
        n = min(len(f_modes), len(d["f_fom"]))
        sq = np.stack([(shapes[j] ** 2).sum(axis=1) for j in range(n)])  # [mode][node]
    out = []
    if xyz.shape != d["coords"].shape or not np.allclose(xyz, d["coords"]):
        sys.exit("plot_select: the modes file's mesh differs from the select file's")
    fdiff = np.max(np.abs(f_modes[:n] / d["f_fom"][:n] - 1))
    out.append(f"Full-model modes: {len(f_modes)} in {os.path.basename(modes_path)}, {len(d['f_fom'])} in the "
               f"select file; max relative frequency difference over the first {n}: {fdiff:.2e}")
    if len(f_modes) != len(d["f_fom"]):
        out.append("WARNING: run morse modes with -modes_nev equal to the number of full-model modes in band")
    w = nodal_mass_weights(d["coords"], d["topology"])
    r = np.hypot(xyz[:, 0], xyz[:, 1])
    vane = (r > r_in + 1e-9) & (r < r_out - 1e-9)
    hub = r <= r_in + 1e-9
    cas = r >= r_out - 1e-9
    e = sq * w[None, :]
    tot = e.sum(axis=1)
    fv, fh, fc = (e[:, vane].sum(1) / tot, e[:, hub].sum(1) / tot, e[:, cas].sum(1) / tot)
    m = d["methods"][k]
    thr = d["thr"]
    sub = m["subspace_mac"][:n]
    cap = sub > thr
    mass_share = w[vane].sum() / w.sum()
    out.append(f"Vane nodes: {r_in} < r < {r_out} m, {vane.sum()} of {len(r)} nodes, {mass_share:.1%} of the "
               "lumped mass")
    out.append("")
    out.append(f"| FOM mode | f [Hz] | vane | hub | casing | {TEXT_LABEL.get(k, k)} subspace MAC | "
               f"{TEXT_LABEL.get(k, k)} best MAC | captured |")
    out.append("|---|---|---|---|---|---|---|---|")
    for j in range(n):
        out.append(f"| {j + 1} | {d['f_fom'][j]:.2f} | {fv[j]:.4f} | {fh[j]:.2e} | {fc[j]:.2e} | {sub[j]:.3f} | "
                   f"{m['best_mac'][j]:.3f} | {'yes' if cap[j] else '**no**'} |")
    out.append("")
    ring = fh + fc
    for lab, sel in (("captured", cap), ("not captured", ~cap)):
        if sel.any():
            out.append(f"- {lab} (subspace MAC {'>' if lab == 'captured' else '<='} {thr:g}): {sel.sum()} modes, "
                       f"vane energy share min {fv[sel].min():.4f} / median {np.median(fv[sel]):.4f} / "
                       f"max {fv[sel].max():.4f}; hub + casing share min {ring[sel].min():.1e} / "
                       f"median {np.median(ring[sel]):.1e} / max {ring[sel].max():.1e}")
    out.append("")
    out.append("Clusters of near-repeated modes (relative gap < 1 %); the sums are invariant to how the solver "
               "mixes a cluster's modes:")
    out.append("")
    out.append(f"| cluster | modes | f [Hz] | mean vane share | sum of {TEXT_LABEL.get(k, k)} subspace MAC "
               "(captured dimension) |")
    out.append("|---|---|---|---|---|")
    for c in clusters(d["f_fom"][:n]):
        c = np.array(c)
        out.append(f"| {c[0] + 1}-{c[-1] + 1} | {len(c)} | {d['f_fom'][c[0]]:.2f}-{d['f_fom'][c[-1]]:.2f} | "
                   f"{np.average(fv[c], weights=tot[c] / tot[c]):.4f} | {sub[c].sum():.2f} of {len(c)} |")

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    x = np.arange(1, n + 1)
    ax1.bar(x, fv, color="tab:orange", label="vanes")
    ax1.bar(x, fh, bottom=fv, color="tab:blue", label="hub")
    ax1.bar(x, fc, bottom=fv + fh, color="tab:gray", label="casing + flanges")
    for j in range(n):
        ax1.text(x[j], 1.02, "o" if cap[j] else "x", ha="center", fontsize=8,
                 color="tab:green" if cap[j] else "tab:red")
    ax1.set_ylim(0, 1.1)
    ax1.set_xlim(0.4, n + 0.6)
    step = max(1, n // 15)
    ticks = list(range(1, n + 1, step))
    if ticks[-1] != n:
        ticks.append(n)
    ax1.set_xticks(ticks)
    ax1.set_xticklabels([f"{t}\n{d['f_fom'][t - 1]:.0f}" for t in ticks], fontsize=7)
    ax1.set_xlabel("full-model mode (number / frequency [Hz])")
    ax1.set_ylabel("kinetic-energy share")
    ax1.legend(loc="lower left", fontsize=8, framealpha=0.9)
    ax1.set_title(f"Energy share per region; top: o captured / x not captured by {TEXT_LABEL.get(k, k)} "
                  f"(subspace MAC > {thr:g})", fontsize=9)
    ringc = np.clip(ring, 1e-12, None)
    ax2.semilogx(ringc[cap], sub[cap], "o", color="tab:green", label="captured")
    ax2.semilogx(ringc[~cap], sub[~cap], "x", color="tab:red", label="not captured")
    ax2.axhline(thr, color="k", ls=":", lw=0.8)
    ax2.set_xlabel("hub + casing kinetic-energy share (1 - vane share)")
    ax2.set_ylabel(f"{TEXT_LABEL.get(k, k)} subspace MAC")
    ax2.set_ylim(0, 1.05)
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    ax2.set_title("Full-model modes: ring participation vs representation", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file")
    ap.add_argument("outdir")
    ap.add_argument("--method", default=None)
    ap.add_argument("--nmac", type=int, default=20)
    ap.add_argument("--modes", default=None)
    ap.add_argument("--r-inner", type=float, default=0.30)
    ap.add_argument("--r-outer", type=float, default=0.60)
    a = ap.parse_args()
    d = load(a.file)
    if not d["methods"]:
        sys.exit(f"plot_select: no /select/<method> group in {a.file}")
    k = a.method or d["rom_method"] or next(iter(d["methods"]))
    if k not in d["methods"]:
        sys.exit(f"plot_select: method {k} not in {a.file} (has {', '.join(d['methods'])})")
    os.makedirs(a.outdir, exist_ok=True)
    written = []

    def out(name):
        p = os.path.join(a.outdir, name)
        written.append(p)
        return p

    plot_cumulative(d, out("cumulative.png"))
    plot_cumulative_one(d, k, out(f"cumulative_{k}.png"))
    plot_mac(d, k, a.nmac, out(f"mac_{k}.png"))
    plot_mac_map(d, out("mac_map.png"))
    plot_counts(d, out("counts.png"))
    text = table(d)
    if "frequency" in d["methods"] and k != "frequency" and d["fraction"] is not None:
        fq = d["methods"]["frequency"]
        mk = d["methods"][k]
        text += (f"\nAt {d['fraction']:.0%}: {TEXT_LABEL.get(k, k)} keeps {int(mk['n_selected'])} fixed-interface "
                 f"modes, frequency order {int(fq['n_selected'])} (EIM in frequency order); superelement modes "
                 f"in band {int(mk['n_rom_modes_in_band'])} vs {int(fq['n_rom_modes_in_band'])}.\n")
    if a.modes:
        text += "\n" + local_modes(d, k, a.modes, a.r_inner, a.r_outer, out("local_modes.png"))
    with open(out("table.md"), "w") as f:
        f.write(text)
    print(text)
    for p in written:
        print(f"plot_select: wrote {p}")


if __name__ == "__main__":
    main()
