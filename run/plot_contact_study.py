#!/usr/bin/python3
"""Figures of seed 003 §5 (blade rubbing an ovalized casing, Figs. 17-19 and 21) from the output
directory of run/contact_study.py.

usage: /usr/bin/python3 run/plot_contact_study.py [OUT_DIR] [--img DIR]

OUT_DIR defaults to out/contact_study, DIR to docs/img. Reads the `morse simulate` files of the study
(/sim/time, /sim/q, /sim/contact/{node_ids, radial_displacement, normal}, attributes of /sim and
/sim/contact; the first contact node is LE, the last TE) and OUT_DIR/study.json (wall times). Needs
numpy, h5py, matplotlib (Agg). Writes into DIR
  contact_fig17.png   LE radial displacement [mm] vs time [ms]: nonlinear (solid) vs linear (dashed),
                      fig17_nonlinear.h5 / fig17_linear.h5.
  contact_fig18.png   the same for two time steps (legend from the dt attribute): fig18_dt.h5 (solid),
                      fig18_dt5.h5 (dashed).
  contact_fig19.png   the same for three bases: fig17_nonlinear.h5 (r79, solid), fig19_r89.h5 (dashed),
                      fig19_r54.h5 (dotted); the legend gives the relative difference of the RMS over
                      the second half of the run against r79.
  contact_forces.png  normal contact force [kN] at LE, mid-chord (contact node 3) and TE over the
                      first 2 revolutions of fig17_nonlinear.h5 (else of another nonlinear run).
  contact_fig20.png   (pod stage) the MD model's run named by study.json "pod_md" (solid) against the
                      POD ROM trained on a harmonic radial load, pod_sim_harmonic.h5 (dashed);
  contact_fig22.png   the same against the POD ROM trained on the MD contact forces, pod_sim_contact.h5;
  contact_fig21.png   (a) the normal component of /sim/contact/mean_force (the training load of (b)) at
                      LE, mid-chord and TE over the training run; (b) LE u_r of the MD run and of the full
                      model driven by those forces (pod_fom_contact.h5, /fom/sets/LE).
  contact_pod_spectra.png  Hann spectra of LE u_r over the second half of the three runs; their
                      statistics (max, RMS, mean, std, peak frequency, time in contact) are printed.
Figs. 17-19 have two panels: (a) transient = the first 20 % of the run (the casing ovalization reaches
99 % of its height at 20 %), (b) steady state = the last 2 revolutions, or the last 20 % of the run
if that is shorter. Windows come from the first (reference) file of a figure. Thin grey verticals mark
the instants the LE node passes a casing bump (theta = (2k + 1) pi / lobes, eq. 52; its initial
angle from /mesh of the rom named by the /sim attribute `rom`; no lines if that file is not found or
if a panel would get more than 50).
Lines longer than 20000 points keep the min and max of each bin. A figure is drawn when its reference
file and at least one other exist (the study may still be running); otherwise a one-line notice.
Then prints one line per simulation file of OUT_DIR (rom_* and sweep_* are not opened): revolutions,
wall seconds (study.json), solver seconds (/sim attribute), max |u_r| at LE, RMS of u_r at LE over
the second half, max normal force (the /sim/contact attribute, over all steps and nodes).
Exits non-zero only if OUT_DIR does not exist.
"""
import argparse
import glob
import json
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAX_POINTS = 20000
MAX_BUMP_LINES = 50  # more crossings in a panel (a long run's transient) would hide the curves: none
STYLES = ["-", "--", ":"]
KNOWN = ["fig17_nonlinear", "fig17_linear", "fig18_dt", "fig18_dt5", "fig19_r89", "fig19_r54"]
TWO_PI = 2 * np.pi


def attr(a, key, default=None):
    v = a.get(key, default)
    return v.decode() if isinstance(v, bytes) else v


def theta0(sim_path, rom, node_id):
    """Initial angle atan2(y, x) of node_id from the rom's /mesh, or None."""
    if not rom:
        return None
    for d in (os.path.abspath(sim_path), os.path.realpath(sim_path)):  # a symlinked file: both directories
        try:
            with h5py.File(os.path.join(os.path.dirname(d), rom), "r") as f:  # join keeps an absolute rom
                i = np.flatnonzero(f["mesh/node_ids"][()] == node_id)
                x = f["mesh/coordinates"][int(i[0])] if i.size else None
            return None if x is None else float(np.arctan2(x[1], x[0]))
        except (OSError, KeyError):
            pass
    return None


def load(path, quiet=False):
    """The contact history of a simulate file as a dict, or None if missing, unreadable or (quiet) another kind."""
    if not os.path.isfile(path):
        return None
    try:
        with h5py.File(path, "r") as f:
            s, c = f["sim"].attrs, f["sim/contact"].attrs
            d = {"t": f["sim/time"][()], "ur": f["sim/contact/radial_displacement"][()],
                 "fn": f["sim/contact/normal"][()], "ids": f["sim/contact/node_ids"][()], "r": f["sim/q"].shape[1],
                 "dt": float(s["dt"]), "linear": int(attr(s, "linear", 0)), "rom": attr(s, "rom", ""),
                 "secs": attr(s, "seconds"), "omega": float(c["omega"]), "lobes": int(attr(c, "lobes", 2)),
                 "fmax": attr(c, "max_normal_force")}
    except KeyError as e:
        if not quiet:
            print(f"  {os.path.basename(path)}: not a contact simulation file ({e})")
        return None
    except OSError as e:  # still being written
        print(f"  {os.path.basename(path)}: not readable yet ({e})")
        return None
    d["path"], d["name"] = path, os.path.basename(path)
    d["th0"] = theta0(path, d["rom"], int(d["ids"][0]))
    d["T"], d["rev"], d["model"] = float(d["t"][-1]), TWO_PI / abs(d["omega"]), f"r{d['r']}"
    d["rms"] = float(np.sqrt(np.mean(d["ur"][d["t"] >= 0.5 * d["T"], 0] ** 2)))
    return d


def decimate(t, y, n=MAX_POINTS):
    """At most n points: the min and the max of each of n/2 bins, in time order."""
    if len(t) <= n:
        return t, y
    m, k = n // 2, -(-len(t) // (n // 2))
    yp = np.pad(y, (0, m * k - len(y)), mode="edge").reshape(m, k)
    base = np.arange(m)[:, None] * k
    idx = np.sort(np.minimum(np.hstack([yp.argmin(1)[:, None], yp.argmax(1)[:, None]]) + base, len(t) - 1), axis=1)
    return t[idx.ravel()], y[idx.ravel()]


def bump_lines(ax, run, lo, hi):
    """Grey verticals where the LE node passes a casing bump within [lo, hi] s."""
    if run["th0"] is None:
        return False
    per, w = TWO_PI / run["lobes"], run["omega"]
    p0, p1 = sorted([(run["th0"] + w * lo - per / 2) / per, (run["th0"] + w * hi - per / 2) / per])
    ks = range(int(np.ceil(p0)), int(np.floor(p1)) + 1)
    if len(ks) > MAX_BUMP_LINES:
        return False
    for k in ks:
        ax.axvline(1e3 * (per / 2 + k * per - run["th0"]) / w, color="0.6", lw=0.6, zorder=0)
    return True


def windows(ref):
    T, t0 = ref["T"], float(ref["t"][0])
    long_run = 0.2 * (T - t0) > 0.99 * 2 * ref["rev"]  # 10 revolutions end a few output samples short
    wb = 2 * ref["rev"] if long_run else 0.2 * (T - t0)
    nb = "last 2 revolutions" if long_run else "last 20 % of the run"
    return [(t0, t0 + 0.2 * (T - t0), "(a) transient: first 20 % of the run"), (T - wb, T, f"(b) steady state: {nb}")]


def plot_ur(runs, labels, fname, title, img):
    ref = runs[0]
    for r in runs[1:]:
        if abs(r["T"] - ref["T"]) > 0.01 * ref["T"]:
            print(f"  note: {r['name']} ends at {1e3 * r['T']:.3g} ms, {ref['name']} at {1e3 * ref['T']:.3g} ms")
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    lines = False
    for ax, (lo, hi, head) in zip(axes, windows(ref)):
        for r, ls, lab in zip(runs, STYLES, labels):
            sel = (r["t"] >= lo) & (r["t"] <= hi)
            t, y = decimate(r["t"][sel], r["ur"][sel, 0])
            ax.plot(1e3 * t, 1e3 * y, ls, lw=0.9, label=lab)
        lines = bump_lines(ax, ref, lo, hi)
        ax.set_xlim(1e3 * lo, 1e3 * hi)
        ax.set_title(head, fontsize=10)
        ax.set(xlabel="time [ms]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("LE radial displacement $u_r$ [mm]")
    h, lab = axes[0].get_legend_handles_labels()
    if lines:
        h.append(Line2D([], [], color="0.6", lw=0.6))
        lab.append("LE passes a casing bump")
    fig.legend(h, lab, loc="lower center", ncol=len(h), fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 1))  # room for the legend under the panels
    save(fig, img, fname)


def plot_forces(run, img):
    n = run["fn"].shape[1]
    sel = run["t"] <= run["t"][0] + 2 * run["rev"]
    fig, ax = plt.subplots(figsize=(10, 4), constrained_layout=True)
    for j, ls, where in [(0, "-", "LE"), (n // 2 - 1, "-", "mid-chord"), (n - 1, "--", "TE")]:
        t, y = decimate(run["t"][sel], run["fn"][sel, j])
        ax.plot(1e3 * t, 1e-3 * y, ls, lw=0.9, label=f"{where} (node {run['ids'][j]})")
    if bump_lines(ax, run, float(run["t"][0]), float(run["t"][sel][-1])):
        ax.plot([], [], color="0.6", lw=0.6, label="LE passes a casing bump")
    ax.set_xlim(1e3 * run["t"][0], 1e3 * run["t"][sel][-1])
    ax.set(xlabel="time [ms]", ylabel="normal contact force [kN]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(f"Normal contact force, first 2 revolutions ({run['name']}) (seed Fig. 21)", fontsize=10)
    fig.suptitle(f"Blade tip / ovalized casing, $\\Omega$ = {run['omega']:g} rad/s, {model(run)}, "
                 f"{'linear' if run['linear'] else 'nonlinear'}", fontsize=11)
    save(fig, img, "contact_forces.png")


def model(r):
    return f"{r['model']} ({os.path.basename(r['rom'])})" if r["rom"] else r["model"]


def save(fig, img, fname):
    path = os.path.join(img, fname)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    print(f"wrote {path}")


def available(runs, names, fig):
    """The loaded runs of names, or None (with a notice) unless the first and one more exist."""
    have = [runs[n] for n in names if runs.get(n)]
    missing = [n + ".h5" for n in names if not runs.get(n)]
    if not runs.get(names[0]) or len(have) < 2:
        print(f"{fig}: skipped, missing {', '.join(missing)}")
        return None
    if missing:
        print(f"{fig}: drawn without {', '.join(missing)}")
    return have


def figures(runs, img):
    w = "$\\Omega$ = {:g} rad/s".format
    have = available(runs, ["fig17_nonlinear", "fig17_linear"], "contact_fig17")
    if have:
        labels = ["linear" if r["linear"] else "nonlinear" for r in have]
        plot_ur(have, labels, "contact_fig17.png", f"LE radial displacement with and without geometric "
                f"nonlinearity (seed Fig. 17), {w(have[0]['omega'])}, {model(have[0])}", img)
    have = available(runs, ["fig18_dt", "fig18_dt5"], "contact_fig18")
    if have:
        plot_ur(have, [f"h = {r['dt']:.3g} s" for r in have], "contact_fig18.png", f"Influence of the time step "
                f"(seed Fig. 18), {w(have[0]['omega'])}, {model(have[0])}, nonlinear", img)
    have = available(runs, ["fig17_nonlinear", "fig19_r89", "fig19_r54"], "contact_fig19")
    if have:
        ref = have[0]
        labels = [f"{ref['model']} (RMS 2nd half {1e3 * ref['rms']:.3g} mm)"] + [
            f"{r['model']} (RMS {100 * (r['rms'] - ref['rms']) / (ref['rms'] or np.nan):+.1f} % vs {ref['model']})"
            for r in have[1:]]
        plot_ur(have, labels, "contact_fig19.png", f"Influence of the reduction basis (seed Fig. 19), "
                f"{w(ref['omega'])}, {' / '.join(r['model'] for r in have)}, nonlinear", img)
    run = runs.get("fig17_nonlinear") or next((r for r in runs.values() if r and not r["linear"]), None)
    if run:
        plot_forces(run, img)
    else:
        print("contact_forces: skipped, no nonlinear simulation file")


def hann_spectrum(t, y):
    """Amplitude spectrum (Hann window, mean removed) of a uniformly sampled signal: (f [Hz], A)."""
    y = y - y.mean()
    w = np.hanning(len(y))
    a = 2 * np.abs(np.fft.rfft(w * y)) / w.sum()
    return np.fft.rfftfreq(len(y), t[1] - t[0]), a


def pod_stats(r):
    """Statistics of the LE radial displacement over the second half of a run, and of its contact."""
    sel = r["t"] >= 0.5 * r["T"]
    y = r["ur"][sel, 0]
    f, a = hann_spectrum(r["t"][sel], y)
    k = 1 + int(np.argmax(a[1:]))
    fn = r["fn"][sel]
    return {"max": float(np.abs(r["ur"][:, 0]).max()), "rms": float(np.sqrt(np.mean(y ** 2))), "mean": float(y.mean()),
            "std": float(y.std()), "f_peak": float(f[k]), "a_peak": float(a[k]),
            "contact": float(np.mean((fn > 0).any(axis=1))), "fmax": r["fmax"], "spectrum": (f, a)}


def fom_le_radial(path, le):
    """(t, u_r) of node le from a morse fom file (/fom/sets/LE, e_r of the node's /mesh position)."""
    with h5py.File(path, "r") as f:
        ids = f["fom/sets/LE/node_ids"][()]
        j = int(np.flatnonzero(ids == le)[0])
        u = f["fom/sets/LE/u"][:, j, :]
        i = int(np.flatnonzero(f["mesh/node_ids"][()] == le)[0])
        x = f["mesh/coordinates"][i]
        t = f["fom/time"][()]
    er = np.array([x[0], x[1], 0.0]) / np.hypot(x[0], x[1])
    return t, u @ er


def pod_figures(out, runs, img):
    """Seed Figs. 20-22: the POD ROMs trained on (a) a harmonic load and (b) the MD model's contact forces."""
    try:
        with open(os.path.join(out, "study.json")) as fh:
            rec = json.load(fh)
    except (OSError, ValueError):
        rec = {}
    md_name = rec.get("pod_md")
    md = runs.get(md_name) if md_name else None
    if md is None:
        print("contact_fig20-22: skipped, no pod stage in study.json")
        return
    w = f"$\\Omega$ = {md['omega']:g} rad/s"
    pods = {tag: runs.get("pod_sim_" + tag) for tag in ("harmonic", "contact", "contact_linear")}
    for tags, fig, what in [(["harmonic"], "contact_fig20.png", "a harmonic radial load at LE (seed Fig. 20)"),
                            (["contact", "contact_linear"], "contact_fig22.png",
                             "the MD model's contact forces (seed Fig. 22)")]:
        have = [(t, pods[t]) for t in tags if pods[t]]
        if not have:
            print(f"{fig}: skipped, missing pod_sim_{tags[0]}.h5")
            continue
        labels = [f"modal derivatives, {md['model']}"] + [
            f"POD {r['model']} = 24 + {r['r'] - 24}" + (", trained on the linear full model" if t.endswith("linear")
                                                        else "") for t, r in have]
        plot_ur([md] + [r for _, r in have], labels, fig,
                f"LE radial displacement, MD vs POD trained on {what}, {w}, nonlinear", img)
    # Fig. 21: the training load of (b), and the full model's response to it against the MD model's.
    fom = os.path.join(out, "pod_fom_contact.h5")
    with h5py.File(md["path"], "r") as f:
        mt, mf = f["sim/contact/mean_force_time"][()], f["sim/contact/mean_force"][()]
        nrm = f["sim/contact/normals"][()]
    T_train = None
    if os.path.isfile(fom):
        with h5py.File(fom, "r") as f:
            T_train = float(f["fom/time"][-1])
    T_train = T_train or md["rev"]
    fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, constrained_layout=True)
    sel = mt <= T_train
    n = mf.shape[1]
    for j, ls, where in [(0, "-", "LE"), (n // 2 - 1, "-", "mid-chord"), (n - 1, "--", "TE")]:
        radial = np.einsum("td,d->t", mf[sel, j, :], nrm[j])  # normal component lambda >= 0
        axes[0].plot(1e3 * mt[sel], 1e-3 * radial, ls, lw=0.9, label=f"{where} (node {md['ids'][j]})")
    axes[0].set(ylabel="normal force, 1 $\\mu$s means [kN]")
    axes[0].set_title("(a) the training load of POD (b): MD contact forces over the training run (seed Fig. 21)",
                      fontsize=10)
    axes[0].legend(fontsize=8, loc="upper left")
    sel = md["t"] <= T_train
    axes[1].plot(1e3 * md["t"][sel], 1e3 * md["ur"][sel, 0], "-", lw=0.9, label=f"MD {md['model']} (with contact)")
    for path, ls, lab in [(fom, "--", "full model under the MD contact forces (morse fom)"),
                          (os.path.join(out, "pod_fom_contact_linear.h5"), ":", "the same, linear twin (-fom_linear)")]:
        if os.path.isfile(path):
            t, ur = fom_le_radial(path, int(md["ids"][0]))
            axes[1].plot(1e3 * t, 1e3 * ur, ls, lw=0.9, label=lab)
    axes[1].set(xlabel="time [ms]", ylabel="LE $u_r$ [mm]")
    axes[1].set_title("(b) LE radial displacement over the training run", fontsize=10)
    axes[1].legend(fontsize=8, loc="lower left")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.set_xlim(0, 1e3 * T_train)
    fig.suptitle(f"POD training by contact forces, {w}", fontsize=11)
    save(fig, img, "contact_fig21.png")
    # Statistics and spectra of the second half.
    have = [("MD " + md["model"], md)] + [(f"POD {tag} {r['model']}", r) for tag, r in pods.items() if r]
    fig, ax = plt.subplots(figsize=(10, 4), constrained_layout=True)
    print(f"\nFigs. 20-22, LE u_r over the second half of {md['T'] / md['rev']:.3g} revolutions:")
    print(f"{'run':<28}{'max|u_r|':>10}{'RMS':>8}{'mean':>8}{'std':>8}{'f_peak':>8}{'in contact':>11}{'max F_n':>9}"
          f"\n{'':<28}{'[mm]':>10}{'[mm]':>8}{'[mm]':>8}{'[mm]':>8}{'[Hz]':>8}{'[% time]':>11}{'[kN]':>9}")
    for (lab, r), ls in zip(have, STYLES + ["-."]):
        st = pod_stats(r)
        print(f"{lab:<28}{1e3 * st['max']:>10.3f}{1e3 * st['rms']:>8.3f}{1e3 * st['mean']:>8.3f}{1e3 * st['std']:>8.3f}"
              f"{st['f_peak']:>8.0f}{100 * st['contact']:>11.1f}{1e-3 * (st['fmax'] or 0):>9.1f}")
        f, a = st["spectrum"]
        keep = f <= 6000
        ax.plot(f[keep], 1e3 * a[keep], ls, lw=0.9, label=f"{lab}: RMS {1e3 * st['rms']:.3g} mm")
    ax.set(xlabel="frequency [Hz]", ylabel="amplitude [mm]", yscale="log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Spectrum of the LE radial displacement, second half of the run (Hann), {w}", fontsize=10)
    save(fig, img, "contact_pod_spectra.png")


def summary(out, runs):
    try:
        with open(os.path.join(out, "study.json")) as fh:
            rec = json.load(fh)
    except (OSError, ValueError):
        rec = {}
    wall = {os.path.basename(v["file"]): v.get("seconds") for v in rec.values() if isinstance(v, dict) and "file" in v}
    print(f"{'file':<26}{'revs':>7}{'wall [s]':>10}{'solver [s]':>11}{'max|u_r| LE':>13}{'RMS 2nd half':>14}"
          f"{'max F_n':>10}\n{'':<26}{'':>7}{'':>10}{'':>11}{'[mm]':>13}{'[mm]':>14}{'[kN]':>10}")
    for r in runs.values():
        if r is None:
            continue
        fmax = r["fmax"] if r["fmax"] is not None else np.abs(r["fn"]).max()
        ws, ss = wall.get(r["name"]), r["secs"]
        print(f"{r['name']:<26}{(r['T'] - r['t'][0]) / r['rev']:>7.3g}{'-' if ws is None else f'{ws:.0f}':>10}"
              f"{'-' if ss is None else f'{ss:.0f}':>11}{1e3 * np.abs(r['ur'][:, 0]).max():>13.4g}"
              f"{1e3 * r['rms']:>14.4g}{1e-3 * fmax:>10.4g}")


def main():
    p = argparse.ArgumentParser(usage="%(prog)s [OUT_DIR] [--img DIR]", description=__doc__.split("\n\n")[0])
    p.add_argument("out", nargs="?", default=os.path.join(ROOT, "out", "contact_study"), metavar="OUT_DIR")
    p.add_argument("--img", default=os.path.join(ROOT, "docs", "img"), help="where the PNGs go (default docs/img)")
    a = p.parse_args()
    if not os.path.isdir(a.out):
        sys.exit(f"plot_contact_study: {a.out}: no such directory")
    os.makedirs(a.img, exist_ok=True)
    runs = {n: load(os.path.join(a.out, n + ".h5")) for n in KNOWN}
    for path in sorted(glob.glob(os.path.join(a.out, "*.h5"))):  # other simulate files (stress_*_sim.h5)
        n = os.path.basename(path)[:-3]
        if n not in runs and not n.startswith(("rom_", "sweep_")):
            runs[n] = load(path, quiet=True)
    figures(runs, a.img)
    pod_figures(a.out, runs, a.img)
    summary(a.out, runs)


if __name__ == "__main__":
    main()
