#!/usr/bin/python3
"""Figures and tables of seed 003 §4 from run/nlrom_study.py's output.

usage: /usr/bin/python3 run/plot_nlrom_study.py OUT_DIR IMG_DIR [--component x|y|z]

Reads OUT_DIR/study.json and the HDF5 files it names (a file that is no longer at its recorded
path is looked up by name in OUT_DIR), writes into IMG_DIR

  nlrom_fig7.png   LE displacement against time: fom, CB r = 15 (STEP) without and with POD
                   filtering of the nonlinear forces (case LE2000)
  nlrom_fig8.png   W_ij of the modal derivatives of the 7 CB modes, (W_ij / max W)^(1/4) as the seed,
                   bars in pair order (i, then j), the derivatives in the fig9_best10 basis highlighted
  nlrom_fig9.png   fom against best-10, all-28 and random-10 modal derivatives: (a) the first two
                   periods, (b) the last two periods
  nlrom_fig10.png  I against r for POD, CB + POD filtering, CB + MD (300 N at LE, 2000 rad/s)
  nlrom_fig12.png  the same bases at 1000 rad/s
  nlrom_fig13.png  the same bases with the load spread over the tip nodes
                   (Figs. 10, 12, 13: panel (a) the runs with the fom's scheme and step, roms[..]["cases"];
                   panel (b) the central-difference runs, roms[..]["central"]["cases"]; a missing point is a
                   run that diverged)
  nlrom_fig14.png  I of POD (3 + 10) trained on N_t tip nodes and tested on N_e tip nodes

and prints seed 003 Tables 2-3 (offline and online times) as Markdown, also written to
OUT_DIR/tables.md. --component chooses the displacement component of Figs. 7 and 9 (default y,
the load direction; the seed's Fig. 7 caption says e_x). A figure whose data are missing is
skipped with a message; the exit status is 0 unless study.json itself cannot be read.
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

FAMILIES = (  # prefix of the roms entries, label, marker (seed Figs. 10, 12, 13: ●, ◆, ▲), colour
    ("pod_r", "POD", "o", "C0"),
    ("cbf_r", "CB + POD filtering", "D", "C1"),
    ("cbmd_r", "CB + modal derivatives", "^", "C2"),
)
COMPONENTS = {"x": 0, "y": 1, "z": 2}
R_TABLE = 20  # basis size of seed 003 Tables 2-3
SEED_OFFLINE_MIN = {"pod": 1350, "cbf": 1360, "cbmd": 1320}
SEED_ONLINE_S = 5
SEED_FOM_S = 12000


class Skip(Exception):
    """Data for a figure or a table are missing."""


class Study:
    def __init__(self, out_dir):
        self.out = out_dir
        path = os.path.join(out_dir, "study.json")
        with open(path) as fh:
            self.d = json.load(fh)
        self.roms = self.d.get("roms") or {}
        self.foms = self.d.get("fom") or {}
        self.notes = []  # printed once at the end

    # ---- lookup helpers (raise Skip with a readable reason)
    def path(self, p):
        if not p:
            raise Skip("no file recorded")
        if os.path.exists(p):
            return p
        alt = os.path.join(self.out, os.path.basename(p))
        if os.path.exists(alt):
            return alt
        raise Skip("file %s not found (nor %s)" % (p, alt))

    def rom(self, name):
        if name not in self.roms:
            raise Skip("study.json has no roms[%r]" % name)
        return self.roms[name]

    def case(self, name, case):
        cases = self.rom(name).get("cases") or {}
        if case not in cases:
            raise Skip("roms[%r] has no case %r" % (name, case))
        return cases[case]

    def fom(self, name):
        if name not in self.foms:
            raise Skip("study.json has no fom[%r]" % name)
        return self.foms[name]

    def indicator(self, name, case):
        """I of a case: study.json, else /compare/I of the simulate file; None if neither."""
        c = self.case(name, case)
        if c.get("I") is not None:
            return float(c["I"])
        try:
            with h5py.File(self.path(c.get("sim")), "r") as f:
                return float(f["/compare/I"][0])
        except (Skip, KeyError, OSError):
            return None

    def fom_of(self, names, case, default):
        """The fom run of a case: from the first of the roms entries that has it, else default."""
        for n in names:
            c = (self.roms.get(n, {}).get("cases") or {}).get(case)
            if c and c.get("fom"):
                return c["fom"]
        return default

    def fom_series(self, fom_name, set_name, comp):
        with h5py.File(self.path(self.fom(fom_name).get("file")), "r") as f:
            return f["/fom/time"][:], f["/fom/sets/%s/u" % set_name][:, 0, comp]

    def sim_series(self, name, case, set_name, comp):
        with h5py.File(self.path(self.case(name, case).get("sim")), "r") as f:
            return f["/sim/time"][:], f["/sim/sets/%s/u" % set_name][:, 0, comp]

    def rom_size(self, name):
        """Basis size: /nlrom@r of the nlrom file (after MGS), else the study's nominal r."""
        e = self.rom(name)
        r = e.get("r")
        try:
            with h5py.File(self.path(e.get("file")), "r") as f:
                actual = int(f["/nlrom"].attrs["r"])
            if r is not None and actual != int(r):
                self.notes.append("%s: nominal r = %s, /nlrom@r = %d (plotted at %d)" % (name, r, actual, actual))
            return actual
        except (Skip, KeyError, OSError):
            if r is None:
                raise Skip("roms[%r] has no r" % name)
            return int(r)


def label_I(text, I):
    return "%s (I = %.3f)" % (text, I) if I is not None else "%s (I n/a)" % text


def period(study):
    return 2 * math.pi / float(study.d.get("omega_train") or 2000.0)


# ---------------------------------------------------------------- figures

def fig7(st, img, comp, cname):
    case = "LE2000"
    t, u = st.fom_series(st.fom_of(("fig7_cb15", "fig7_cb15_filtered"), case, "test_LE2000"), "LE", comp)
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ax.plot(t * 1e3, u * 1e3, "-", color="k", lw=1.4, label="full-order model")
    for name, text, style, col in (("fig7_cb15", "CB r = 15, STEP, no filtering", "-", "C3"),
                                   ("fig7_cb15_filtered", "CB r = 15, STEP, POD-filtered forces", "--", "C0")):
        try:
            tr, ur = st.sim_series(name, case, "LE", comp)
        except Skip as e:
            print("  fig7: %s left out: %s" % (name, e))
            continue
        ax.plot(tr * 1e3, ur * 1e3, style, color=col, lw=1.0, label=label_I(text, st.indicator(name, case)))
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("$u_%s$ at LE [mm]" % cname)
    ax.set_title("seed 003 Fig. 7: Craig-Bampton (3 + 12) with STEP, 300 N at LE, 2000 rad/s")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save(fig, img, "nlrom_fig7.png")


def fig8(st, img):
    e = st.rom("fig9_best10")
    with h5py.File(st.path(e.get("file")), "r") as f:
        if "/nlrom/derivatives/pairs" not in f:
            raise Skip("%s has no /nlrom/derivatives" % e.get("file"))
        pairs = f["/nlrom/derivatives/pairs"][:].reshape(-1, 2).astype(int)
        w = f["/nlrom/derivatives/weights"][:].astype(float)
        sel = f["/nlrom/derivatives/selected"][:].astype(int)
        attrs = f["/nlrom"].attrs
        n_b = int(attrs.get("n_boundary_dofs", 3))
        n_fixed = int(attrs.get("n_fixed_modes", 4))
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))  # by pair: i, then j (the seed's order)
    pairs, w, sel = pairs[order], w[order], sel[order]
    wmax = w.max() if w.size and w.max() > 0 else 1.0
    h = (np.clip(w, 0, None) / wmax) ** 0.25
    x = np.arange(len(w))
    fig, ax = plt.subplots(figsize=(10, 4))
    colors = np.where(sel == 1, "C0", "0.75")
    ax.bar(x, h, color=colors, edgecolor="0.3", linewidth=0.4)
    ax.set_xticks(x)
    ax.set_xticklabels(["%d,%d" % (i, j) for i, j in pairs], rotation=90, fontsize=7)
    ax.set_xlim(-0.7, len(w) - 0.3)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("pair i,j of Craig-Bampton coordinates (sorted by i, then j)")
    ax.set_ylabel("$(W_{ij} / \\max W)^{1/4}$")
    ax.set_title("seed 003 Fig. 8: weights of the %d modal derivatives (eq. 24), %d in the basis (blue)"
                 % (len(w), int(sel.sum())))
    ax.text(0.99, 0.97, "coordinates 1-%d: $u_b$ of node LE (x, y, z)\ncoordinates %d-%d: fixed-interface modes 1-%d"
            % (n_b, n_b + 1, n_b + n_fixed, n_fixed), transform=ax.transAxes, ha="right", va="top", fontsize=8,
            bbox=dict(facecolor="white", edgecolor="0.7"))
    fig.tight_layout()
    out = save(fig, img, "nlrom_fig8.png")
    rank = np.argsort(-w, kind="stable")
    n_sel = int(sel.sum())
    top = ", ".join("%d,%d (%.3g)" % (pairs[k][0], pairs[k][1], h[k]) for k in rank[:max(n_sel, 10)])
    print("  fig8: highest weights, (W/max W)^(1/4): %s" % top)
    chosen = ", ".join("%d,%d" % tuple(p) for p in pairs[sel == 1])
    print("  fig8: in the basis: %s" % chosen)
    if set(rank[:n_sel]) != set(np.nonzero(sel == 1)[0]):
        print("  fig8: note: the basis is not the %d highest weights (modified Gram-Schmidt dropped some)" % n_sel)
    return out


def fig9(st, img, comp, cname):
    case = "LE2000"
    t, u = st.fom_series(st.fom_of(("fig9_best10", "fig9_all28", "fig9_random10"), case, "test_LE2000"), "LE", comp)
    T = period(st)
    t_end = float(t[-1])
    runs = []
    for name, text, style, col in (("fig9_all28", "all 28 derivatives", "--", "C1"),
                                   ("fig9_best10", "best 10 derivatives", "-.", "C0"),
                                   ("fig9_random10", "10 random derivatives", "-", "C3")):
        try:
            tr, ur = st.sim_series(name, case, "LE", comp)
        except Skip as e:
            print("  fig9: %s left out: %s" % (name, e))
            continue
        runs.append((tr, ur, style, col, label_I(text, st.indicator(name, case))))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    windows = ((0.0, 2 * T + 1e-12, "(a) transient: first two periods"),
               (t_end - 2 * T - 1e-12, t_end + 1e-12, "(b) steady state: last two periods"))
    for ax, (a, b, title) in zip(axes, windows):
        m = (t >= a) & (t <= b)
        ax.plot(t[m] * 1e3, u[m] * 1e3, "-", color="k", lw=1.6, label="full-order model")
        for tr, ur, style, col, lab in runs:
            mr = (tr >= a) & (tr <= b)
            ax.plot(tr[mr] * 1e3, ur[mr] * 1e3, style, color=col, lw=1.0, label=lab)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("time [ms]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("$u_%s$ at LE [mm]" % cname)
    axes[0].legend(fontsize=8, loc="best")
    fig.suptitle("seed 003 Fig. 9: CB (3 + 4) + modal derivatives, 300 N at LE, 2000 rad/s")
    fig.tight_layout()
    return save(fig, img, "nlrom_fig9.png")


def family_points(st, case):
    """{prefix: [(r, I, name)]} of the I-vs-r families for one case."""
    pts = {}
    for prefix, _, _, _ in FAMILIES:
        for name in sorted(k for k in st.roms if k.startswith(prefix)):
            try:
                I = st.indicator(name, case)
                r = st.rom_size(name)
            except Skip:
                continue
            if I is not None:
                pts.setdefault(prefix, []).append((r, I, name))
    return {k: sorted(v) for k, v in pts.items()}


def central_points(st, case):
    """{prefix: [(r, I)]} of the explicit (central-difference) runs, roms[name]["central"]."""
    pts = {}
    for prefix, _, _, _ in FAMILIES:
        for name in sorted(k for k in st.roms if k.startswith(prefix)):
            c = ((st.roms[name].get("central") or {}).get("cases") or {}).get(case) or {}
            if c.get("I") is None:
                continue
            try:
                r = st.rom_size(name)
            except Skip:
                continue
            pts.setdefault(prefix, []).append((r, float(c["I"])))
    return {k: sorted(v) for k, v in pts.items()}


def fig_I_vs_r(st, img, case, fname, title):
    pts = family_points(st, case)
    cen = central_points(st, case)
    if not pts and not cen:
        raise Skip("no pod_r*/cbf_r*/cbmd_r* entry has case %r" % case)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    panels = [(axes[0], pts, "(a) fom's scheme and step: trapezoidal, h = 1e-4 s"),
              (axes[1], {k: [(a, b, None) for a, b in v] for k, v in cen.items()},
               "(b) central differences, h = min(1e-7 s, 0.9 h_crit)")]
    for ax, data, sub in panels:
        for prefix, lab, mk, col in FAMILIES:
            if prefix not in data:
                print("  %s: no %s* entries for case %s (%s)" % (fname, prefix, case, sub[:3]))
                continue
            r, I, _ = zip(*data[prefix])
            ax.plot(r, I, "-", marker=mk, color=col, label=lab, ms=7, clip_on=False)
            print("  %s %s %s: %s" % (fname, sub[:3], lab, ", ".join("r=%d %.3f" % (a, b) for a, b in zip(r, I))))
        ax.set_ylim(0, 1)
        ax.set_xlabel("size r of the reduction basis")
        ax.set_title(sub, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    axes[0].set_ylabel("performance indicator I")
    fig.suptitle(title + "; missing points: the run diverged", fontsize=10)
    fig.tight_layout()
    return save(fig, img, fname)


def tip_case(st):
    names = set()
    for prefix, _, _, _ in FAMILIES:
        for k, e in st.roms.items():
            if k.startswith(prefix):
                names.update(c for c in (e.get("cases") or {}) if c.startswith("tip"))
    if not names:
        raise Skip("no case whose name starts with 'tip'")

    def n(c):
        try:
            return int(c[3:])
        except ValueError:
            return -1
    return max(names, key=n)


def fig13(st, img):
    case = tip_case(st)
    n = case[3:]
    return fig_I_vs_r(st, img, case, "nlrom_fig13.png",
                      "seed 003 Fig. 13: 300 N spread over the %s tip nodes, 2000 rad/s (case %s)" % (n, case))


def fig14(st, img):
    m = st.d.get("fig14_I")
    if not m:
        raise Skip("study.json has no fig14_I")
    a = np.array(m, dtype=float)
    if a.ndim != 2:
        raise Skip("fig14_I is not a matrix")
    nt, ne = a.shape
    fig, ax = plt.subplots(figsize=(6.2, 5.2))
    im = ax.imshow(a, origin="lower", cmap="viridis", vmin=0, vmax=1, aspect="equal",
                   extent=(0.5, ne + 0.5, 0.5, nt + 0.5))
    for i in range(nt):
        for j in range(ne):
            v = a[i, j]
            ax.text(j + 1, i + 1, "%.2f" % v, ha="center", va="center", fontsize=8,
                    color="k" if v > 0.6 else "w")
    ax.set_xticks(range(1, ne + 1))
    ax.set_yticks(range(1, nt + 1))
    ax.set_xlabel("$N_e$: tip nodes loaded in the test")
    ax.set_ylabel("$N_t$: tip nodes loaded in the POD training")
    ax.set_title("seed 003 Fig. 14: I of POD (3 + 10)", fontsize=10)
    fig.colorbar(im, ax=ax, label="I")
    fig.tight_layout()
    print("  fig14: diagonal %s; min %.3f at N_t=%d, N_e=%d" % (
        ", ".join("%.3f" % a[k, k] for k in range(min(nt, ne))), a.min(),
        np.unravel_index(a.argmin(), a.shape)[0] + 1, np.unravel_index(a.argmin(), a.shape)[1] + 1))
    return save(fig, img, "nlrom_fig14.png")


def save(fig, img, name):
    path = os.path.join(img, name)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- tables

def fmt(v, spec="%.3g"):
    return spec % v if isinstance(v, (int, float)) and v is not None else "n/a"


def closest(st, prefix):
    """The family members whose r is closest to R_TABLE (both neighbours on a tie)."""
    members = []
    for k in st.roms:
        if k.startswith(prefix):
            try:
                members.append((st.rom_size(k), k))
            except Skip:
                pass
    if not members:
        return []
    d = min(abs(r - R_TABLE) for r, _ in members)
    return sorted(m for m in members if abs(m[0] - R_TABLE) == d)


def sim_attr(st, c, key, attr):
    if c.get(key) is not None:
        return c[key]
    try:
        with h5py.File(st.path(c.get("sim")), "r") as f:
            return f["/sim"].attrs[attr].item()
    except (Skip, KeyError, OSError):
        return None


def fom_steps(st, name):
    e = st.fom(name)
    try:
        with h5py.File(st.path(e.get("file")), "r") as f:
            return int(f["/fom"].attrs["steps"])
    except (Skip, KeyError, OSError):
        return e.get("steps")


def tables(st):
    lines = ["# Seed 003 Tables 2-3 reproduced by morse (run/nlrom_study.py)", ""]
    mesh = st.d.get("mesh", "?")
    lines.append("Mesh: `%s`. The study has no r = %d basis; each family is shown at the size(s) closest "
                 "to %d." % (os.path.basename(str(mesh)), R_TABLE, R_TABLE))
    lines.append("")
    fam_names = {"pod_r": ("pod", "POD"), "cbf_r": ("cbf", "CB with POD filtering"),
                 "cbmd_r": ("cbmd", "CB and modal derivatives")}
    chosen = []
    for prefix, _, _, _ in FAMILIES:
        for r, name in closest(st, prefix):
            chosen.append((prefix, r, name))
    if not chosen:
        raise Skip("no pod_r*/cbf_r*/cbmd_r* entries")
    lines += ["## Table 2: offline times", "",
              "| method | r | t1 basis [s] | t2 forces [s] | t3 projection [s] | t1+t2+t3 [s] | [min] "
              "| nlrom wall [s] | seed, r = 20 [min] |",
              "|---|---|---|---|---|---|---|---|---|"]
    for prefix, r, name in chosen:
        e = st.rom(name)
        off = e.get("offline") or {}
        ts = [off.get(k) for k in ("t1", "t2", "t3")]
        tot = sum(ts) if all(isinstance(v, (int, float)) for v in ts) else None
        fam, lab = fam_names[prefix]
        lines.append("| %s | %d | %s | %s | %s | %s | %s | %s | %s |" % (
            lab, r, fmt(ts[0], "%.2f"), fmt(ts[1], "%.2f"), fmt(ts[2], "%.3f"), fmt(tot, "%.2f"),
            fmt(tot / 60 if tot is not None else None, "%.2f"), fmt(e.get("nlrom_wall_seconds"), "%.1f"),
            "{:,}".format(SEED_OFFLINE_MIN[fam])))
    lines += ["", "t1, t2, t3 as printed by `morse nlrom` (2 ranks). For POD and the POD filter the seed counts "
              "the full-order training run in t1 or t2; morse's t1/t2 do not include it (the training fom run "
              "`train_LE` took %s s of wall time)." % fmt(st.foms.get("train_LE", {}).get("seconds"), "%.1f"), ""]

    cases = []
    for _, _, name in chosen:
        for c in (st.rom(name).get("cases") or {}):
            if c not in cases:
                cases.append(c)
    lines += ["## Table 3: online times", "",
              "| method | r | dt [s] | steps | " + " | ".join("%s [s] (speed-up)" % c for c in cases) + " |",
              "|---|---|---|---|" + "---|" * len(cases)]
    fom_of_case = {}
    for prefix, r, name in chosen:
        e = st.rom(name)
        cells = []
        steps = None
        for c in cases:
            cc = (e.get("cases") or {}).get(c)
            if cc is None:
                cells.append("n/a")
                continue
            secs = sim_attr(st, cc, "seconds", "seconds")
            steps = steps or sim_attr(st, cc, "steps", "steps")
            fom_of_case.setdefault(c, cc.get("fom"))
            fs = st.foms.get(cc.get("fom"), {}).get("seconds")
            sp = fs / secs if isinstance(fs, (int, float)) and isinstance(secs, (int, float)) and secs > 0 else None
            cells.append("%s (%s)" % (fmt(secs, "%.2f"), ("x%.0f" % sp) if sp is not None else "n/a"))
        lines.append("| %s | %d | %s | %s | %s |" % (fam_names[prefix][1], r, fmt(e.get("dt"), "%.3g"),
                                                    fmt(steps, "%d"), " | ".join(cells)))
    fcells = []
    fdt = st.d.get("fom_dt")
    fsteps = None
    for c in cases:
        fn = fom_of_case.get(c)
        if fn in st.foms:
            fcells.append(fmt(st.foms[fn].get("seconds"), "%.1f"))
            fsteps = fsteps or fom_steps(st, fn)
        else:
            fcells.append("n/a")
    lines.append("| full-order model (`morse fom`) | - | %s | %s | %s |" % (fmt(fdt, "%.3g"), fmt(fsteps, "%d"),
                                                                           " | ".join(fcells)))
    lines += ["", "Reduced models: wall time of the central-difference integration on one rank (`morse simulate`, "
              "output callbacks included, reading the model excluded). Full-order model: wall time of the "
              "`morse fom` process on 2 ranks (start-up, assembly and snapshot output included), test runs "
              "%s. Speed-up = fom seconds / rom seconds of the same case. Seed 003 (r = 20, h = 1e-4 s, 0.03 s): "
              "%d s for each reduced model, %s s for the full model (SAMCEF), a factor 2,400."
              % (", ".join("%s = `%s`" % (c, fom_of_case.get(c)) for c in cases), SEED_ONLINE_S,
                 "{:,}".format(SEED_FOM_S)), ""]
    return "\n".join(lines)


# ---------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out_dir")
    ap.add_argument("img_dir")
    ap.add_argument("--component", choices=sorted(COMPONENTS), default="y",
                    help="displacement component of Figs. 7 and 9 (default y, the load direction)")
    a = ap.parse_args()
    try:
        st = Study(a.out_dir)
    except (OSError, ValueError) as e:
        sys.stderr.write("plot_nlrom_study: cannot read %s/study.json: %s\n" % (a.out_dir, e))
        return 2
    os.makedirs(a.img_dir, exist_ok=True)
    comp = COMPONENTS[a.component]
    jobs = [
        ("Fig. 7", lambda: fig7(st, a.img_dir, comp, a.component)),
        ("Fig. 8", lambda: fig8(st, a.img_dir)),
        ("Fig. 9", lambda: fig9(st, a.img_dir, comp, a.component)),
        ("Fig. 10", lambda: fig_I_vs_r(st, a.img_dir, "LE2000", "nlrom_fig10.png",
                                       "seed 003 Fig. 10: 300 N at LE, 2000 rad/s (training load)")),
        ("Fig. 12", lambda: fig_I_vs_r(st, a.img_dir, "LE1000", "nlrom_fig12.png",
                                       "seed 003 Fig. 12: 300 N at LE, 1000 rad/s")),
        ("Fig. 13", lambda: fig13(st, a.img_dir)),
        ("Fig. 14", lambda: fig14(st, a.img_dir)),
    ]
    skipped = []
    for label, job in jobs:
        print("== %s" % label)
        try:
            print("  wrote %s" % job())
        except Skip as e:
            print("  skipped: %s" % e)
            skipped.append(label)
        except (KeyError, OSError, ValueError, IndexError, TypeError) as e:
            print("  skipped (%s: %s)" % (type(e).__name__, e))
            skipped.append(label)
            plt.close("all")
    print("== Tables 2-3")
    try:
        md = tables(st)
        with open(os.path.join(a.out_dir, "tables.md"), "w") as fh:
            fh.write(md)
        print(md)
        print("(written to %s)" % os.path.join(a.out_dir, "tables.md"))
    except (Skip, KeyError, OSError, ValueError, TypeError) as e:
        print("  skipped: %s" % e)
        skipped.append("Tables 2-3")
    for n in dict.fromkeys(st.notes):
        print("note: %s" % n)
    if skipped:
        print("skipped: %s" % ", ".join(skipped))
    return 0


if __name__ == "__main__":
    sys.exit(main())
