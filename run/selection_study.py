#!/usr/bin/python3
"""Seed 000 §3.3 on morse's stator: every selection method at several criteria, judged by the
unbalance ramp-up of run/engine.opts (bearing loads against the full Craig–Bampton reference,
run time, Table 1's score). Called by run/selection_study (which builds morse first).

Writes out/study/ (superelements, ramp-ups, study.json), docs/select/benchmark.md (every number in
it comes from here), docs/select/img/benchmark_*.png, and bench/results/selection_study_<UTC>.json;
with --interface 78 (the seed's 13 six-DOF interface points) out/study78/, docs/select/benchmark78.md,
docs/select/img/benchmark78_*.png and bench/results/selection_study78_<UTC>.json.

usage: run/selection_study.py [--runs R] [--np N] [--reuse] [--criteria f90,f95,...] [--interface 39|78]
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import time

import h5py
import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
METHODS = ["frequency", "lpf", "eim", "veim", "deim", "omr", "cmschi", "ebr", "imr"]
LABEL = {"frequency": "CB (frequency)", "lpf": "LPF", "eim": "EIM", "veim": "VEIM", "deim": "DEIM",
         "omr": "OMR", "cmschi": "CMSχ", "ebr": "EBR", "imr": "IMR"}
# Criteria: the seed's 90 % and 95 %, a stricter 99 %, and fixed counts in the seed's proportions
# (292 and 610 of its 1,650 candidates: 18 % and 37 % of ours).
CRITERIA = {"f90": ("-select_fraction", "0.90", "90 %"), "f95": ("-select_fraction", "0.95", "95 %"),
            "f99": ("-select_fraction", "0.99", "99 %"), "n13": ("-select_num_modes", "13", "13 modes"),
            "n26": ("-select_num_modes", "26", "26 modes")}
# Seed 000 Table 1, as printed (method, N, Diff, mass %, time, loads worst/best/mean, displacements
# worst/best/mean, score).
SEED_TABLE1 = [
    ("CB", "610", "0", "", "1.01", "4.2", "0.2", "1.1", "2", "1", "1", "8.9"),
    ("CB", "292", "−187", "", "0.45", "26.4", "3.5", "10.2", "11", "3", "7", "5.5"),
    ("LPF", "610", "−112", "98.3", "0.66", "4.4", "0.2", "1.5", "3", "1", "2", "11.9"),
    ("LPF", "327", "−231", "95.0", "0.37", "5.3", "1.1", "2.6", "2", "1", "2", "13.7"),
    ("LPF", "292", "−257", "94.2", "0.30", "5.8", "1.3", "3.3", "4", "1", "3", "13.7"),
    ("EIM", "610", "−105", "96.7", "0.63", "3.9", "0.3", "1.2", "2", "1", "1", "12.5"),
    ("EIM", "485", "−154", "95.0", "0.51", "4.4", "0.5", "1.7", "3", "1", "2", "13.2"),
    ("EIM", "292", "−245", "90.0", "0.33", "13.0", "1.9", "5.0", "5", "2", "3", "11.7"),
    ("VEIM", "292", "−198", "99.7", "0.51", "5.4", "0.5", "1.8", "2", "1", "2", "13.1"),
    ("VEIM", "100", "−375", "95.0", "0.12", "45.9", "9.4", "24.9", "11", "5", "8", "8.8"),
    ("EBR", "338", "−167", "99.0", "0.58", "9.0", "1.6", "4.0", "3", "2", "2", "10.2"),
    ("EBR", "292", "−209", "98.4", "0.45", "22.0", "2.1", "9.3", "9", "2", "6", "6.2"),
]
MODEL = ["-mesh", "meshes/stator.msh", "-clamp", "mount", "-boundary", "interface"]
# The seed's interface: each of the 13 interface nodes a six-DOF point (an RBE3 spider over the
# nodes within 3 cm, docs/stator.md), 78 boundary DOFs; the engine's bearings and lugs then sit on
# the points (the sets <set>_spiders).
MODEL78 = ["-mesh", "meshes/stator.msh", "-clamp", "mount", "-mesh_spiders", "interface", "-mesh_spider_radius", "0.03",
           "-boundary", "interface_spiders"]
RAMPUP78 = (["-rampup_stator_casing_clamp", "suspension1_spiders,suspension2_spiders,suspension3_spiders"] +
            sum([["-rampup_bearing_%s_nodes" % b, ",".join("bearing%d_spiders" % i for i in range(1, 6))]
                 for b in ("fan1", "lp1", "pgb_ring")], []) +
            ["-rampup_bearing_hp1_nodes", ",".join("bearing%d_spiders" % i for i in range(6, 11))])
# The variant being run (main() sets it): "" the 39-DOF interface, "78" the six-DOF points.
V = {"tag": "", "model": MODEL, "out": "out/study", "rampup": []}


def trf():
    """The turbine rear frame of model A (run/engine.opts): the coarse stator, reduced once, never selected."""
    return V["out"] + "/trf_se.h5"


def sh(cmd, log=None):
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if log:
        with open(log, "w") as f:
            f.write(r.stdout + r.stderr)
    if r.returncode != 0:
        sys.exit("selection_study: failed: %s\n%s%s" % (" ".join(cmd), r.stdout[-3000:], r.stderr[-3000:]))
    return r.stdout


def mpi(n):
    return ["mpiexec", "--oversubscribe", "--bind-to", "none", "-n", str(n), "build/morse"]


def rampup(se, out, extra=(), reference=None):
    cmd = mpi(1) + ["rampup", "-options_file", "run/engine.opts", "-rampup_stator_casing_file", se,
                    "-rampup_stator_trf_file", trf(), "-out", out] + V["rampup"]
    if reference:
        cmd += ["-rampup_reference", reference]
    sh(cmd + list(extra), out.replace(".h5", ".log"))
    with h5py.File(os.path.join(ROOT, out), "r") as f:
        r = f["/rampup"]
        # The selected stator's modes (the rear frame's are the same in every run).
        d = {"seconds": float(r.attrs["seconds"]), "steps": int(r.attrs["steps"]),
             "stator_modes": int(f["/rampup/stators/casing"].attrs["n_modes"]), "n_dofs": int(r.attrs["n_dofs"]),
             "n_bearings": int(r["bearing_force"].shape[1])}
        if reference:
            e = f["/rampup/error"]
            for k in ["force_worst", "force_best", "force_mean", "displacement_worst", "displacement_best",
                      "displacement_mean", "force_global_worst", "force_global_mean", "force_scale"]:
                d[k] = float(e.attrs[k])
    return d


def timed(se, out, runs, extra=()):
    """Median over `runs` of the integration time (the file's /rampup@seconds)."""
    t = [rampup(se, out, extra)["seconds"] for _ in range(runs)]
    return statistics.median(t), min(t), max(t)


def score(eps_mean, t, t_ref):
    s1 = 10 - 100 * eps_mean if 100 * eps_mean < 10 else 0.0
    s2 = 10 * (1 - t / t_ref) if t < t_ref else 0.0
    return s1 + s2


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5, help="timing repetitions (median)")
    ap.add_argument("--np", type=int, default=2, help="ranks of reduce/select")
    ap.add_argument("--reuse", action="store_true", help="reuse existing superelements in out/study")
    ap.add_argument("--criteria", default=",".join(CRITERIA))
    ap.add_argument("--doc-only", action="store_true", help="redo the plots and the page from out/study/study.json")
    ap.add_argument("--interface", choices=["39", "78"], default="39",
                    help="39: the 13 interface nodes' translations (docs/select/benchmark.md); 78: each a six-DOF "
                         "point through an RBE3 spider, the seed's interface (docs/select/benchmark78.md, out/study78)")
    a = ap.parse_args()
    if a.interface == "78":
        V.update(tag="78", model=MODEL78, out="out/study78", rampup=RAMPUP78)
    if a.doc_only:
        with open(os.path.join(ROOT, V["out"], "study.json")) as f:
            res = json.load(f)
        plots(res, V["out"])
        write_doc(res)
        return
    crit = a.criteria.split(",")
    out = V["out"]
    os.makedirs(os.path.join(ROOT, out), exist_ok=True)
    t0 = time.time()
    stages = {}

    # 1. The reference superelement: every fixed-interface mode below 5x the top frequency of
    # interest (200 Hz, the HP spool at 12,000 rpm): 1000 Hz. Its basis feeds every selection.
    basis = out + "/basis.h5"
    ts = time.time()
    if not (a.reuse and os.path.exists(os.path.join(ROOT, basis))):
        print("selection_study: reference superelement (reduce, candidates below 1000 Hz)", flush=True)
        sh(mpi(a.np) + ["reduce"] + V["model"] + ["-cb_fmax", "1000", "-cb_write_basis", "-cb_xdmf", "0", "-out", basis],
           os.path.join(ROOT, out, "reduce.log"))
    if not (a.reuse and os.path.exists(os.path.join(ROOT, trf()))):
        sh(mpi(a.np) + ["reduce", "-mesh", "meshes/stator_coarse.msh", "-clamp", "mount", "-boundary", "interface",
                        "-cb_fmax", "1000", "-out", trf()], os.path.join(ROOT, out, "reduce_trf.log"))
    stages["reduce"] = time.time() - ts
    reused = stages["reduce"] < 1.0
    with h5py.File(os.path.join(ROOT, basis), "r") as f:
        n_cand = int(f["/rom"].attrs["n_modes"])
        n_b = int(f["/rom"].attrs["n_boundary_dofs"])

    # 2. The reference ramp-up (condensed and dense step), timed.
    ts = time.time()
    print("selection_study: reference ramp-up", flush=True)
    ref = rampup(basis, out + "/ref.h5")
    ref["t_med"], ref["t_min"], ref["t_max"] = timed(basis, out + "/ref_t.h5", a.runs)
    ref["td_med"], ref["td_min"], ref["td_max"] = timed(basis, out + "/ref_dense.h5", a.runs, ["-rampup_dense"])
    with h5py.File(os.path.join(ROOT, out, "ref.h5"), "r") as f:
        fr = f["/rampup/stators/casing/frequencies_hz"][:]
        ref["f_min_hz"], ref["f_max_hz"] = float(fr.min()), float(fr.max())
    _, F, names = history(out + "/ref.h5")
    names = (names.decode() if isinstance(names, bytes) else names).split(",")
    ref["ranges"] = {n: float((F[:, b, :].max(axis=0) - F[:, b, :].min(axis=0)).max()) for b, n in enumerate(names)}
    stages["reference_rampup"] = time.time() - ts

    # 3. Every method at every criterion.
    rows = []
    ts_sel = ts_ramp = 0.0
    for c in crit:
        opt, val, label = CRITERIA[c]
        for m in METHODS:
            se = "%s/se_%s_%s.h5" % (out, m, c)
            ts = time.time()
            if not (a.reuse and os.path.exists(os.path.join(ROOT, se))):
                sh(mpi(a.np) + ["select"] + V["model"] + ["-select_from", basis, "-select_method", m, opt, val,
                                                      "-select_fmax_analysis", "500", "-select_check", "false",
                                                      "-out", se],  # the MAC is Fig. 5's (run/selection_fig5.py)
                   os.path.join(ROOT, se.replace(".h5", ".log")))
            ts_sel += time.time() - ts
            with h5py.File(os.path.join(ROOT, se), "r") as f:
                g = f["/select/" + m]
                N = int(g.attrs["n_selected"])
                frac = float(g.attrs["retained_fraction"])
            ts = time.time()
            r = rampup(se, "%s/ramp_%s_%s.h5" % (out, m, c), reference=out + "/ref.h5")
            r["t_med"], r["t_min"], r["t_max"] = timed(se, "%s/ramp_%s_%s_t.h5" % (out, m, c), a.runs)
            r["td_med"], r["td_min"], r["td_max"] = timed(se, "%s/ramp_%s_%s_dense.h5" % (out, m, c), a.runs,
                                                          ["-rampup_dense"])
            ts_ramp += time.time() - ts
            r.update(method=m, criterion=c, criterion_label=label, N=N, retained=frac,
                     diff=r["stator_modes"] - ref["stator_modes"], time=r["t_med"] / ref["t_med"],
                     time_dense=r["td_med"] / ref["td_med"])
            r["score"] = score(r["force_mean"], r["t_med"], ref["t_med"])
            r["score_dense"] = score(r["force_mean"], r["td_med"], ref["td_med"])
            rows.append(r)
            print("  %-9s %-8s N=%3d diff=%4d eps_F worst %.3g%% mean %.3g%%  t %.3f  t_dense %.3f  S %.1f / %.1f"
                  % (m, label, N, r["diff"], 100 * r["force_worst"], 100 * r["force_mean"], r["time"],
                     r["time_dense"], r["score"], r["score_dense"]), flush=True)
    stages["select"] = ts_sel
    stages["rampups"] = ts_ramp
    stages["total"] = time.time() - t0

    res = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"), "runs": a.runs,
           "n_candidates": n_cand, "n_boundary_dofs": n_b, "reference": ref, "rows": rows,
           "stage_seconds": stages, "reference_reused": reused, "engine": "run/engine.opts", "mesh": "meshes/stator.msh",
           "interface": V["tag"] or "39", "model_options": V["model"], "rampup_options": V["rampup"]}
    with open(os.path.join(ROOT, out, "study.json"), "w") as f:
        json.dump(res, f, indent=1)
    stamp = res["date"].replace("-", "").replace(":", "")
    os.makedirs(os.path.join(ROOT, "bench/results"), exist_ok=True)
    with open(os.path.join(ROOT, "bench/results/selection_study%s_%s.json" % (V["tag"], stamp)), "w") as f:
        json.dump(res, f, indent=1)
    plots(res, out)
    write_doc(res)
    print("selection_study: done in %.0f s (select %.0f s, ramp-ups %.0f s)" % (stages["total"], ts_sel, ts_ramp))


def history(path):
    with h5py.File(os.path.join(ROOT, path), "r") as f:
        r = f["/rampup"]
        return r["omega"][:] * 60 / (2 * np.pi), r["bearing_force"][:], r.attrs["bearings"]


def plots(res, out):
    img = os.path.join(ROOT, "docs/select/img")
    os.makedirs(img, exist_ok=True)
    rows, ref = res["rows"], res["reference"]
    # Fig. 7: run time against the stator modes in the range.
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, (key, title) in enumerate([("t_med", "morse's condensed step (cost linear in N)"),
                                      ("td_med", "dense step (a multibody code's LU: O(n³))")]):
        x = np.array([r["stator_modes"] for r in rows] + [ref["stator_modes"]])
        y = np.array([r[key] for r in rows] + [ref[key]])
        for m in METHODS:
            xs = [r["stator_modes"] for r in rows if r["method"] == m]
            ys = [r[key] for r in rows if r["method"] == m]
            ax[k].plot(xs, ys, "o", label=LABEL[m], ms=5)
        ax[k].plot([ref["stator_modes"]], [ref[key]], "k*", ms=12, label="reference")
        p = np.polyfit(x, y, 2 if k else 1)
        xx = np.linspace(0, x.max() * 1.05, 50)
        ax[k].plot(xx, np.polyval(p, xx), "k--", lw=0.8, label="fit, degree %d" % (2 if k else 1))
        ax[k].set_xlabel("stator modes in the range (≤ 2.5 × top spin frequency)")
        ax[k].set_ylabel("ramp-up time [s] (median of %d)" % res["runs"])
        ax[k].set_title(title, fontsize=10)
        ax[k].grid(alpha=0.3)
    ax[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "benchmark%s_time.png" % V["tag"]), dpi=110)
    plt.close(fig)
    # Bearing loads over speed: reference, the best two rows by score, CB by frequency at 95 %.
    best = sorted(rows, key=lambda r: -r["score_dense"])[:2]
    shown = [("reference (CB, all %d candidates)" % res["n_candidates"], out + "/ref.h5", "k", 1.4)]
    for r, col in zip(best, ["tab:red", "tab:blue"]):
        shown.append(("%s %s" % (LABEL[r["method"]], r["criterion_label"]),
                      "%s/ramp_%s_%s.h5" % (out, r["method"], r["criterion"]), col, 0.8))
    if any(r["method"] == "frequency" and r["criterion"] == "n13" for r in rows):
        shown.append(("CB (frequency) 13 modes", out + "/ramp_frequency_n13.h5", "tab:green", 0.8))
    nb = history(out + "/ref.h5")[1].shape[1]
    fig, ax = plt.subplots((nb + 1) // 2, 2, figsize=(11, 2.6 * ((nb + 1) // 2)))
    for a in ax.flat[nb:]:
        a.set_visible(False)
    for lab, path, col, lw in shown:
        rpm, F, names = history(path)
        names = (names.decode() if isinstance(names, bytes) else names).split(",")
        for b in range(F.shape[1]):
            a = ax.flat[b]
            a.plot(rpm, np.hypot(F[:, b, 0], F[:, b, 1]), color=col, lw=lw, label=lab if b == 0 else None)
            a.set_title("bearing %s: |F| = (F_x² + F_y²)^½" % names[b], fontsize=10)
            a.set_xlabel("driving (LP) speed [rpm]")
            a.set_ylabel("|F| [N]")
            a.grid(alpha=0.3)
    ax.flat[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "benchmark%s_loads.png" % V["tag"]), dpi=110)
    plt.close(fig)
    # Accuracy against the stator modes lost from the range.
    fig, ax = plt.subplots(figsize=(7, 4))
    for m in METHODS:
        xs = [-r["diff"] for r in rows if r["method"] == m]
        ys = [100 * max(r["force_mean"], 1e-6) for r in rows if r["method"] == m]
        ax.semilogy(xs, ys, "o", label=LABEL[m], ms=5)
    ax.axhline(10, color="k", lw=0.8, ls="--")
    ax.text(0.5, 11, "S1 = 0 above", fontsize=8)
    ax.set_xlabel("stator modes of the range missing against the reference (−Diff)")
    ax.set_ylabel("mean eq. 24 error of the load features [%]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "benchmark%s_error_vs_diff.png" % V["tag"]), dpi=110)
    plt.close(fig)
    # Error of each load feature against the reference, per bearing, for the best rows and CB 13.
    fig, ax = plt.subplots(figsize=(9, 3.8))
    for lab, path, col, lw in shown[1:]:
        rpm, F, _ = history(path)
        _, Fr, _ = history(out + "/ref.h5")
        rng = Fr.max(axis=0) - Fr.min(axis=0)
        e = np.abs(F - Fr) / rng
        ax.semilogy(rpm, np.maximum(e.max(axis=(1, 2)), 1e-12), color=col, lw=0.8, label=lab)
    ax.set_xlabel("driving (LP) speed [rpm]")
    ax.set_ylabel("max over the load features of |F - F_ref| / range")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(img, "benchmark%s_error.png" % V["tag"]), dpi=110)
    plt.close(fig)


def write_doc(res):
    rows, ref = res["rows"], res["reference"]
    crit_order = [c for c in CRITERIA if any(r["criterion"] == c for r in rows)]
    L = []
    L.append("# Seed 000 §3.3 on morse's stator: selection methods judged by an unbalance ramp-up\n")
    L.append("*Generated by `run/selection_study` on %s (every number on this page comes from it; %d timing "
             "runs per case, medians). Raw data: `bench/results/selection_study%s_*.json`.*\n"
             % (res["date"], res["runs"], V["tag"]))
    L.append("""## Setup

* **Stator superelement**: `meshes/stator.msh` (146,202 free DOFs, clamped at `mount`), Craig–Bampton on
  the 13 interface nodes%s (%d boundary DOFs). **Reference**: every fixed-interface mode below 1000 Hz,
  5× the top frequency of interest (seed 000 §3.3): **%d candidates**.
* **Engine** (`run/engine.opts`, seed 000 model A, Fig. 2(A)): the fan, LP and HP spools as Timoshenko
  rotors (fan, LPT, HPC, HPT disks); a linearized planetary gearbox (ratio 3) between the LP shaft and
  the fan shaft, its lateral stiffness between sun and carrier and through the ring's mount into the
  stator; seven bearings, none on the ground: fan, LP front, the gearbox ring and HP front in this
  stator's hub bore (the mean of five bore nodes each), the HP rear bearing intershaft on the LP shaft,
  the LP rear bearing in a turbine rear frame (the coarse stator, reduced once and never selected); the
  suspension lugs clamped; 2 %% modal damping of the stator modes. Unbalance 5·10⁻⁴ kg m on the LPT
  (seed 000 §3.1). Linear ramp of the speeds imposed at the two turbines, LP 0 → 5000 rpm in 4 s (HP:
  2.4×, 12,000 rpm = 200 Hz, the top frequency of interest; fan: 1/3), against the fan's aerodynamic
  torque (10.6 MW at the top speed); Newmark average acceleration, dt = 10⁻⁴ s, 40,000 steps. The
  torsion (drives, gearbox, torque) is uncoupled from the lateral motion in this linear model, so it
  does not change the bearing loads ([rampup-theory.md](../rampup-theory.md) §4.3).
* **Range**: each superelement enters the assembly through its own modal basis with the lugs clamped,
  truncated at 2.5 × 200 = 500 Hz. The reference keeps **%d stator modes**; "Diff" is each row's count
  minus that.
* **Criteria**: 90 %%, 95 %% and 99 %% of each method's own score (the seed's 90 and 95 %%), and fixed counts
  of 13 and 26 modes (18 %% and 37 %% of the candidates, the seed's 292 and 610 of 1650).
* **Errors**: seed 000 eq. 24 per load feature (F_x, F_y of the %d bearings: %d features) and per
  displacement feature (x, y of the rotor at each bearing), worst/best/mean.
* **Time**: the ramp-up's integration loop (the file's `/rampup@seconds`), median of %d runs, normalized by
  the reference's. Two step solvers: morse's condensed step, whose cost is linear in the stator modes
  ([rampup-theory.md](../rampup-theory.md) §5), and the dense step (`-rampup_dense`: LU of the whole
  effective matrix each step, the O(n³) of a multibody code's constraint solve).
* **Score** S = S1 + S2 (seed §3.3): S1 = 10 − ε_mean[%%] if ε_mean < 10 %%, else 0; S2 = 10 (1 − t/t_ref) if
  t < t_ref, else 0 (this form of S2 reproduces every row of the seed's Table 1; the test
  `RampupErrors.ScoreReproducesSeedTable1` checks it). **S** uses the dense-step time (the seed's
  situation), **S\\*** morse's condensed-step time.

Reference run: %d modes of this stator, the rear frame's and the rotor DOFs: %d DOFs; condensed %.3f s (%.1f µs/step), dense %.3f s.
""" % (" as six-DOF points (an RBE3 spider each over the nodes within 3 cm; `-mesh_spiders interface "
       "-mesh_spider_radius 0.03`, the bearings and lugs on the points)" if V["tag"] == "78" else "",
       res["n_boundary_dofs"], res["n_candidates"], ref["stator_modes"], ref["n_bearings"],
       2 * ref["n_bearings"], res["runs"], ref["stator_modes"], ref["n_dofs"], ref["t_med"], 1e6 * ref["t_med"] / ref["steps"], ref["td_med"]))
    L.append("## Table 1 on morse's stator\n")
    L.append("| method | criterion | N | Diff | retained % | time (dense) | time (condensed) | loads ε worst % | "
             "best % | mean % | displ. ε worst % | best % | mean % | loads vs largest: worst % | mean % | "
             "S /20 | S\\* /20 |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for m in METHODS:
        for c in crit_order:
            for r in rows:
                if r["method"] == m and r["criterion"] == c:
                    L.append("| %s | %s | %d | %+d | %.1f | %.2f | %.2f | %.3g | %.3g | %.3g | %.3g | %.3g | %.3g | "
                             "%.3g | %.3g | %.1f | %.1f |"
                             % (LABEL[m], r["criterion_label"], r["N"], r["diff"], 100 * r["retained"],
                                r["time_dense"], r["time"], 100 * r["force_worst"], 100 * r["force_best"],
                                100 * r["force_mean"], 100 * r["displacement_worst"], 100 * r["displacement_best"],
                                100 * r["displacement_mean"], 100 * r["force_global_worst"],
                                100 * r["force_global_mean"], r["score_dense"], r["score"]))
    L.append("")
    L.append("N: fixed-interface modes kept; retained: the method's own score fraction (EIM's for frequency "
             "order); time: normalized by the reference (1.00 = %.3f s dense, %.3f s condensed); loads vs "
             "largest: each bearing's deviation max |F - F_ref| against the largest load range of any bearing "
             "and direction (%.4g N), so that a lightly loaded bearing cannot set the verdict alone "
             "(`/rampup/error/bearing_force_global`).\n"
             % (ref["td_med"], ref["t_med"], rows[0].get("force_scale", float("nan")) if rows else float("nan")))
    L.append("For comparison, seed 000's Table 1 (model A, 1,650 candidates, 494 stator modes in the reference's "
             "range; time of its multibody code, ∝ N²):\n")
    L.append("| method | N | Diff | mass % | time | loads ε worst % | best % | mean % | displ. ε worst % | best % | "
             "mean % | S /20 |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for t in SEED_TABLE1:
        L.append("| " + " | ".join(t) + " |")
    L.append("")
    best = sorted(rows, key=lambda r: -r["score_dense"])
    L.append("## Ranking\n")
    L.append("Best five rows by S (dense-step time, the seed's situation):\n")
    L.append("| rank | method | criterion | S | ε_mean loads % | time (dense) |")
    L.append("|---|---|---|---|---|---|")
    for k, r in enumerate(best[:5]):
        L.append("| %d | %s | %s | %.1f | %.3g | %.2f |" % (k + 1, LABEL[r["method"]], r["criterion_label"],
                                                          r["score_dense"], 100 * r["force_mean"], r["time_dense"]))
    L.append("")
    per_method = {}
    for r in rows:
        per_method[r["method"]] = max(per_method.get(r["method"], -1), r["score_dense"])
    order = sorted(per_method, key=lambda m: -per_method[m])
    L.append("Best score per method (over the criteria): " + ", ".join(
        "%s %.1f" % (LABEL[m], per_method[m]) for m in order) + ".\n")
    bs = sorted(rows, key=lambda r: -r["score"])
    # Discussion: every number computed here.
    def row(m, c):
        return next(r for r in rows if r["method"] == m and r["criterion"] == c)
    same = all(row("lpf", c)["N"] == row("eim", c)["N"] and row("lpf", c)["force_worst"] == row("eim", c)["force_worst"]
               for c in crit_order)
    full = [r for r in rows if r["diff"] == 0]
    lost = [r for r in rows if r["diff"] <= -10]
    fails = [r for r in rows if r["force_mean"] >= 0.10]
    # Which bearing carries the worst load feature of each truncated row.
    worst_at = {}
    for r in rows:
        path = os.path.join(ROOT, "%s/ramp_%s_%s.h5" % (V["out"], r["method"], r["criterion"]))
        if r["diff"] < 0 and os.path.exists(path):
            with h5py.File(path, "r") as f:
                e = f["/rampup/error/bearing_force"][:]
                names = f["/rampup"].attrs["bearings"]
                names = (names.decode() if isinstance(names, bytes) else names).split(",")
            b = names[int(np.argmax(e.max(axis=1)))]
            worst_at[b] = worst_at.get(b, 0) + 1
    spread = 100 * (ref["td_max"] - ref["td_min"]) / ref["td_med"]
    spread_c = 100 * (ref["t_max"] - ref["t_min"]) / ref["t_med"]
    rank_of = {(r["method"], r["criterion"]): k + 1 for k, r in enumerate(best)}
    L.append("## Discussion\n")
    P = []
    P.append("**Winner.** By S (the seed's situation, time of the dense step), the best row is %s at %s (S = %.1f, "
             "ε_mean = %.2g %%, time %.2f)." % (LABEL[best[0]["method"]], best[0]["criterion_label"],
                                               best[0]["score_dense"], 100 * best[0]["force_mean"],
                                               best[0]["time_dense"]))
    if "f95" in crit_order:
        re, rl = rank_of[("eim", "f95")], rank_of[("lpf", "f95")]
        # "Agrees" only when both are among the best five rows: the ranks move with the timing noise.
        verdict = ("morse's stator agrees, with a caveat: LPF and EIM keep the same modes here (below), so the gap "
                   "between their ranks is timing noise alone" if max(re, rl) <= 5 else
                   "this run neither confirms nor refutes it: LPF and EIM keep the same modes here (below), so their "
                   "different ranks are timing noise, and the spread of the times (below) exceeds the score "
                   "differences between the best rows")
        P.append(" EIM at 95 %% ranks %d and LPF at 95 %% ranks %d of %d rows. Seed 000 concludes that EIM and LPF "
                 "are the best methods (Table 1: S = 13.2 and 13.7 at 95 %%, times 0.51 and 0.37): %s."
                 % (re, rl, len(rows), verdict))
    P.append(" The scores are lower and closer together than the seed's because the time term is smaller: the "
             "reference assembly has %d stator modes against %d rotor DOFs, so dropping stator modes shortens "
             "the dense step by at most %.0f %%, while the seed's 494 stator modes dominated its model. Differences "
             "of a few tenths of a point are within the timing noise (the reference's dense time spreads by "
             "%.0f %% over its %d runs, the condensed one by %.0f %%).\n"
             % (ref["stator_modes"], ref["n_dofs"] - ref["stator_modes"], 100 * (1 - min(r["time_dense"] for r in rows)),
                spread, res["runs"], spread_c))
    L.append("".join(P))
    if same:
        L.append("**EIM = LPF.** They keep the same modes at every criterion here (equal N and equal errors). "
                 "EIM adds the interface mass to LPF's participation; on this stator it changes no ranking, which "
                 "is the seed's explanation for their equal results (\"the mass at the interface has little effect "
                 "... structures with distributed mass and relatively small interfaces\").\n")
    L.append("**Accuracy follows the modes of the range.** Every row that keeps all %d stator modes of the range "
             "(Diff = 0, %d rows) has ε_mean ≤ %.2g %%; every row that loses 10 or more (%d rows) has ε_mean ≥ %.2g %%. "
             "What matters is not N but which modes stay in the range "
             "(below: the error against the modes lost). %s\n"
             % (ref["stator_modes"], len(full), 100 * max(r["force_mean"] for r in full) if full else float("nan"),
                len(lost), 100 * min(r["force_mean"] for r in lost) if lost else float("nan"),
                "The rows that fail S1 (ε_mean ≥ 10 %%) are %s: they lose %d to %d stator modes of the range."
                % (", ".join("%s %s" % (LABEL[r["method"]], r["criterion_label"]) for r in fails),
                   min(-r["diff"] for r in fails), max(-r["diff"] for r in fails)) if fails else
                "No row fails S1 (ε_mean ≥ 10 %%): the worst mean load error is %.3g %%."
                % (100 * max(r["force_mean"] for r in rows))))
    L.append("**The load errors are far below the seed's** (worst eq. 24 load error %.3g %% over every row, against "
             "3.9–45.9 %% in the seed's Table 1). What the runs show: every bearing of this model A carries a load "
             "of the same order (ranges below, %.3g–%.4g N), and the unbalance turns with the LP spool, so it "
             "excites 0–%.0f Hz while the stator's modes in the range lie at %.1f–%.1f Hz. The engine of the "
             "previous record (two grounded rear bearings, the HP spool loaded only through the stator) gave eq. 24 "
             "worst load errors of 1.5–69 %% because its HP bearings carried about 0.01 N (closing note of stop 40). "
             "Why the seed's errors are larger is not settled by a run here (its stator has 494 modes in the "
             "range against %d, and the seed describes its model A only in outline).\n"
             % (100 * max(r["force_worst"] for r in rows), min(ref["ranges"].values()) if ref.get("ranges") else 0,
                max(ref["ranges"].values()) if ref.get("ranges") else 0, 5000 / 60.0,
                ref.get("f_min_hz", float("nan")), ref.get("f_max_hz", float("nan")), ref["stator_modes"]))
    L.append("![error against modes lost](img/benchmark%s_error_vs_diff.png)\n" % V["tag"])
    L.append("**With morse's integrator, selection buys accuracy per mode, not time.** The condensed step costs "
             "%.1f µs per step for the reference and is linear in the stator modes (bench/rampup_bench.py), so "
             "t/t_ref stays between %.2f and %.2f (noise) and S\\* only measures accuracy: its best row is %s at %s "
             "(S\\* = %.1f). The seed's time savings come from its multibody solver's cost, N² there and O(n³) "
             "for the dense step here.\n"
             % (1e6 * ref["t_med"] / ref["steps"], min(r["time"] for r in rows), max(r["time"] for r in rows),
                LABEL[bs[0]["method"]], bs[0]["criterion_label"], bs[0]["score"]))
    L.append("**Where this differs from the seed.** %d candidates (the seed: 1,650) and %d stator modes in the "
             "range (494); %s; "
             "linear bearings and a linear gearbox (the seed's model A is 'linearized' too); the unbalance on "
             "the LPT as in the seed (over the rows that lose modes of the range, the worst load feature "
             "is at bearing %s). The seed's times are hours; these are seconds, so its time column is a "
             "solver property, reproduced here by the dense step.\n"
             % (res["n_candidates"], ref["stator_modes"],
                "the interface of 13 six-DOF points, each an RBE3 spider over the mesh nodes within 3 cm (the "
                "seed: 13 six-DOF master nodes)" if V["tag"] == "78" else
                "the interface of 13 solid nodes with 3 DOFs each (the seed: 6-DOF master nodes; "
                "`run/selection_study --interface 78` runs them: [benchmark78.md](benchmark78.md))",
                ", ".join("%s in %d rows" % kv for kv in sorted(worst_at.items(), key=lambda kv: -kv[1])) or "?"))
    if ref.get("ranges"):
        L.append("Load range of each bearing in the reference (max − min of F_x, F_y, the larger): %s.\n"
                 % ", ".join("%s %.4g N" % kv for kv in ref["ranges"].items()))
    trunc = [r for r in rows if r["diff"] < 0 and "force_global_worst" in r]
    if trunc:
        ratio = [r["force_worst"] / r["force_global_worst"] for r in trunc if r["force_global_worst"] > 0]
        L.append("**Errors against the largest load.** Over the %d rows that lose modes of the range, eq. 24's worst "
                 "load error is %.3g–%.3g %%; the same deviations against the largest load range of any bearing "
                 "(%.4g N) are %.3g–%.3g %%, %s times smaller. %s\n"
                 % (len(trunc), 100 * min(r["force_worst"] for r in trunc), 100 * max(r["force_worst"] for r in trunc),
                    trunc[0]["force_scale"], 100 * min(r["force_global_worst"] for r in trunc),
                    100 * max(r["force_global_worst"] for r in trunc),
                    "%.3g–%.3g" % (min(ratio), max(ratio)) if ratio else "?",
                    "Eq. 24 divides each bearing's deviation by its own range, so the lightly loaded bearings set "
                    "its worst." if ratio and max(ratio) > 3 else
                    "The bearings carry loads of the same order, so eq. 24's verdict and this one agree within a "
                    "factor of 3."))
    L.append("## Run time against the stator modes (seed 000 Fig. 7)\n")
    L.append("![time against modes](img/benchmark%s_time.png)\n" % V["tag"])
    L.append("## Bearing loads over the ramp-up\n")
    L.append("![bearing loads](img/benchmark%s_loads.png)\n" % V["tag"])
    L.append("![error over speed](img/benchmark%s_error.png)\n" % V["tag"])
    L.append("## Study cost\n")
    st = res["stage_seconds"]
    L.append("Whole study %.0f s on this machine (2 cores): reference superelement %s, %d selections %.0f s, "
             "ramp-ups (each case once with the error, %d times condensed and %d times dense) %.0f s. The seed's "
             "reference simulation alone took about 20 h.\n"
             % (st["total"], "reused from an earlier run (about 45 s)" if res.get("reference_reused") else
                "%.0f s" % st["reduce"], len(rows), st["select"], res["runs"], res["runs"], st["rampups"]))
    with open(os.path.join(ROOT, "docs/select/benchmark%s.md" % V["tag"]), "w") as f:
        f.write("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
