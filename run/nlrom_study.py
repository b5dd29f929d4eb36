#!/usr/bin/python3
"""Seed 003 §4 on the embedded blade: which nonlinear reduced model is right, and how fast.

    /usr/bin/python3 run/nlrom_study.py [--mesh meshes/blade_coarse.msh] [--out out/nlrom_study] [--quick]

Drives morse (fom, nlrom, simulate, compare) through the seed's study and writes
<out>/study.json, which run/plot_nlrom_study.py turns into docs/img/nlrom_*.png:

  fig7   CB (3 constraint + 12 fixed-interface modes, r = 15) with STEP, without and with POD
         filtering of the nonlinear forces (r_f = 10, from the training run), against the fom.
  fig8   W_ij (eq. 24) of the 28 modal derivatives of the 7 CB modes (3 + 4), the 10 selected.
  fig9   best-10 against all-28 against random-10 modal derivatives (3 + 4 + MD), with I.
  fig10  I against r for POD (3 Guyan + POD), CB with POD filtering (3 + (r - 3) fixed modes) and
         CB + MD (3 + 4 + (r - 7) derivatives), training = test = 300 N at LE in e_y, 2000 rad/s,
         10 periods.
  fig12  the same bases under 300 N at 1000 rad/s (10 periods of 2000 rad/s are simulated and
         compared: the fom runs the same 0.0314 s).
  fig13  the same bases under 300 N at 2000 rad/s spread over the 8 tip nodes.
  fig14  POD (3 + 10) trained on N_t tip nodes, tested on N_e tip nodes, N_t, N_e = 1..8.
  tables offline t1, t2, t3 (r = 20) and online times, the fom time on the same problem.

Loads: the seed's A = 300 N is the total force; on N nodes each node carries 300/N N. Training
runs last one period (0.00314 s), test runs ten. The fom uses the seed's step (1e-4 s) and its
modal damping (5e-4 on the first 10 modes); the reduced models get the same damping on their own
first 10 modes (all r modes when r < 10). Every reduced model is integrated twice, up to the end
of the fom record: with the fom's own scheme and step (-sim_scheme trapezoidal, 1e-4 s), so that
I measures the reduction error alone (the figures: roms[name]["cases"]), and with explicit
central differences (eq. 40-41) at 0.9 x its critical step, at most 1e-7 s, rounded down to a
whole number of steps per 1e-4 s (roms[name]["central"]["cases"]); the latter also carries the
fom's own time-discretization error at 1e-4 s.
Nested tip sets tip1 ⊂ ... ⊂ tip8 are ordered by distance from LE (-mesh_node_sets).
"""

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MORSE = os.path.join(ROOT, "build", "morse")
W_TRAIN = 2000.0
PERIOD = 2 * math.pi / W_TRAIN
T_TRAIN, T_TEST = PERIOD, 10 * PERIOD
FOM_DT = 1e-4
AMPLITUDE = 300.0


def env():
    e = dict(os.environ)
    e.update({"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
              "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_btl_vader_single_copy_mechanism": "none",
              "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
    return e


LOG = None
BINARY = MORSE  # a private copy of build/morse (a rebuild during the study must not pull it away)


class MorseFailed(Exception):
    pass


def morse(np_, args, label):
    cmd = ["mpiexec", "--allow-run-as-root", "-n", str(np_), BINARY] + [str(a) for a in args]
    t0 = time.time()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env())
    dt = time.time() - t0
    LOG.write("$ %s\n%s\n" % (" ".join(cmd), p.stdout))
    LOG.flush()
    if p.returncode != 0:
        err = [l for l in p.stdout.splitlines() if "morse: error" in l]
        msg = "%s failed (exit %d): %s" % (label, p.returncode, err[0] if err else p.stdout[-500:])
        sys.stderr.write(msg + "\n")
        raise MorseFailed(msg)
    print("  %-40s %7.1f s" % (label, dt), flush=True)
    return p.stdout, dt


def load_args(set_name, n_nodes, omega, prefix=""):
    p = "-" + prefix
    return [p + "load_sets", set_name, p + "load_%s_dir" % set_name, "y",
            p + "load_%s_amplitude" % set_name, repr(AMPLITUDE / n_nodes), p + "load_%s_omega" % set_name, repr(omega)]


def t_second_peak(omega):
    return (math.pi / 2 + 2 * math.pi) / omega


def critical_dt(rom):
    f = h5py.File(rom, "r")
    K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real.max()
    return 2.0 / math.sqrt(w2)


def offline_times(stdout):
    m = re.search(r"t1 \(basis\) ([0-9.]+) s, t2 \(forces\) ([0-9.]+) s, t3 \(projection\) ([0-9.]+) s", stdout)
    return {"t1": float(m.group(1)), "t2": float(m.group(2)), "t3": float(m.group(3))} if m else None


def main():
    global LOG
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade_coarse.msh"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "nlrom_study"))
    ap.add_argument("--quick", action="store_true", help="fewer basis sizes (a smoke run)")
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    global BINARY
    LOG = open(os.path.join(out, "morse.log"), "a")
    BINARY = os.path.join(out, "morse")
    shutil.copy2(MORSE, BINARY + ".tmp")
    os.replace(BINARY + ".tmp", BINARY)
    # Resume: full-order runs recorded by an earlier study of the same mesh are reused.
    previous = {}
    try:
        with open(os.path.join(out, "study.json")) as fh:
            old = json.load(fh)
        if old.get("mesh") == os.path.abspath(args.mesh):
            previous = {k: v for k, v in old.get("fom", {}).items() if os.path.exists(v["file"])}
    except (OSError, ValueError):
        pass
    mesh = os.path.abspath(args.mesh)
    model = ["-mesh", mesh, "-clamp", "root"]
    damp_fom = ["-fom_damping_modal", "5e-4", "-fom_damping_modes", "10"]

    # morse nlrom refuses more damped modes than the basis has (r = 5, 7, 9): all r modes then
    def damp_rom(r):
        return ["-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", str(min(10, r))]

    study = {"mesh": mesh, "fom_dt": FOM_DT, "t_train": T_TRAIN, "t_test": T_TEST, "amplitude_total_N": AMPLITUDE,
             "omega_train": W_TRAIN}

    # Tip node subsets by distance from LE (from a 1-step fom run's /mesh).
    probe = os.path.join(out, "probe.h5")
    morse(2, ["fom"] + model + load_args("LE", 1, W_TRAIN) + ["-fom_dt", FOM_DT, "-fom_tfinal", FOM_DT,
                                                              "-fom_monitor", "LE,tip", "-out", probe],
          "fom probe (mesh sets)")
    with h5py.File(probe, "r") as f:
        ids = f["/mesh/node_ids"][:]
        xyz = f["/mesh/coordinates"][:].reshape(-1, 3)
        sets = {k: f["/fom/sets/%s/node_ids" % k][:] for k in ["LE", "tip"]}
    row = {n: i for i, n in enumerate(ids)}
    le = xyz[row[sets["LE"][0]]]
    tip = sorted(sets["tip"], key=lambda n: float(np.linalg.norm(xyz[row[n]] - le)))
    ntip = len(tip)
    node_sets = ["-mesh_node_sets", ",".join("tip%d" % k for k in range(1, ntip + 1))]
    for k in range(1, ntip + 1):
        node_sets += ["-mesh_node_set_tip%d" % k, ",".join(str(int(n)) for n in tip[:k])]
    study["tip_order"] = [int(n) for n in tip]
    model += node_sets

    # ---- full-order runs
    print("== full-order runs (%s)" % os.path.basename(mesh), flush=True)
    fom = {}

    def run_fom(name, set_name, n_nodes, omega, tfinal, every):
        path = os.path.join(out, "fom_%s.h5" % name)
        if name in previous and previous[name]["t_final"] == tfinal:
            fom[name] = previous[name]
            print("  fom %s: reused %s" % (name, path), flush=True)
            study["fom"] = fom
            return path
        _, secs = morse(2, ["fom"] + model + load_args(set_name, n_nodes, omega) + damp_fom +
                        ["-fom_dt", FOM_DT, "-fom_tfinal", tfinal, "-fom_snapshot_every", every,
                         "-fom_monitor", "LE,tip", "-out", path], "fom %s" % name)
        fom[name] = {"file": path, "seconds": secs, "set": set_name, "nodes": n_nodes, "omega": omega,
                     "t_final": tfinal, "steps": int(math.ceil(tfinal / FOM_DT - 1e-9))}  # as morse fom
        study["fom"] = fom
        with open(os.path.join(out, "study.json.tmp"), "w") as fh:
            json.dump(study, fh, indent=1)
        os.replace(os.path.join(out, "study.json.tmp"), os.path.join(out, "study.json"))
        return path

    train = run_fom("train_LE", "LE", 1, W_TRAIN, T_TRAIN, 1)
    run_fom("test_LE2000", "LE", 1, W_TRAIN, T_TEST, 1)
    run_fom("test_LE1000", "LE", 1, 1000.0, T_TEST, 1)
    for k in range(1, ntip + 1):
        run_fom("train_tip%d" % k, "tip%d" % k, k, W_TRAIN, T_TRAIN, 1)
        run_fom("test_tip%d" % k, "tip%d" % k, k, W_TRAIN, T_TEST, 1)
    study["fom"] = fom

    # ---- reduced models
    test_cases = {"LE2000": ("LE", 1, W_TRAIN), "LE1000": ("LE", 1, 1000.0),
                  "tip%d" % ntip: ("tip%d" % ntip, ntip, W_TRAIN)}

    def build(name, extra, r):
        path = os.path.join(out, "rom_%s.h5" % name)
        stdout, secs = morse(2, ["nlrom"] + model + ["-boundary", "LE"] + damp_rom(r) + extra + ["-out", path],
                             "nlrom %s" % name)
        return path, offline_times(stdout), secs

    def simulate_and_compare(rom, name, cases, scheme):
        """cases: {case: (set, nodes, omega, fom name)}; one simulate run, cases spread over 2 ranks.
        scheme "trapezoidal": the fom's scheme and step (1e-4 s), so that I measures the reduction
        error alone; "central": explicit central differences at min(1e-7, 0.9 h_crit)."""
        # morse compare refuses a reduced run that ends before the fom record, and morse fom runs
        # ceil(t_final / dt) steps (T_TEST: 315 steps, to 0.0315 s). So: a whole number of steps per
        # FOM_DT (states written at the fom's times), up to the fom's end.
        hc = critical_dt(rom)
        every = 1 if scheme == "trapezoidal" else int(math.ceil(FOM_DT / min(1e-7, 0.9 * hc) - 1e-9))
        dt = FOM_DT / every
        t_end = max(fom[f]["steps"] for (_, _, _, f) in cases.values()) * FOM_DT
        name = name if scheme == "trapezoidal" else name + "_central"
        arg = ["simulate", "-rom", rom, "-sim_scheme", scheme, "-sim_dt", repr(dt), "-sim_tfinal", repr(t_end),
               "-sim_monitor", "LE,tip", "-sim_output_every", str(every), "-sim_cases", ",".join(cases),
               "-out", os.path.join(out, "sim_%s.h5" % name)]
        for c, (s, n, w, _) in cases.items():
            arg += load_args(s, n, w, prefix=c + "_")
        for c in cases:  # no stale files from an earlier study
            stale = os.path.join(out, "sim_%s_%s.h5" % (name, c))
            if os.path.exists(stale):
                os.remove(stale)
        sim_error = None
        try:
            stdout, secs = morse(min(2, len(cases)), arg, "simulate %s (%d cases)" % (name, len(cases)))
        except MorseFailed as e:  # a case that diverged (NaN) fails the command; the others have files
            stdout, secs, sim_error = "", None, str(e)
        res = {"dt": dt, "critical_dt": hc, "wall_seconds": secs, "cases": {}, "simulate_error": sim_error}
        for c, (s, n, w, fname) in cases.items():
            sim = os.path.join(out, "sim_%s_%s.h5" % (name, c))
            m = re.search(r"  %s: (\d+) steps in ([0-9.]+) s" % re.escape(c), stdout)
            if not os.path.exists(sim):
                res["cases"][c] = {"sim": None, "fom": fname, "I": None, "e": None, "error": sim_error}
                continue
            morse(1, ["compare", fom[fname]["file"], sim, "-compare_tip", "tip", "-compare_tmax",
                      repr(t_second_peak(w))], "compare %s %s" % (name, c))
            with h5py.File(sim, "r") as h:
                e = [float(x) for x in h["/compare/e"][:]]
                I = float(h["/compare/I"][0])
            res["cases"][c] = {"sim": sim, "fom": fname, "I": I, "e": e,
                               "steps": int(m.group(1)) if m else None, "seconds": float(m.group(2)) if m else None}
        return res

    std_cases = {c: (s, n, w, "test_" + c) for c, (s, n, w) in test_cases.items()}
    roms = {}

    path_json = os.path.join(out, "study.json")

    def save():
        study["roms"] = roms
        with open(path_json + ".tmp", "w") as fh:
            json.dump(study, fh, indent=1)
        os.replace(path_json + ".tmp", path_json)

    def study_rom(name, extra, family, r, cases=None):
        """Builds, simulates and compares one reduced model; a failure is recorded, not fatal."""
        try:
            path, off, secs = build(name, extra, r)
            res = simulate_and_compare(path, name, cases or std_cases, "trapezoidal")
            res["central"] = simulate_and_compare(path, name, cases or std_cases, "central")
        except MorseFailed as e:
            roms[name] = {"file": None, "family": family, "r": r, "error": str(e), "cases": {}}
            save()
            return
        roms[name] = {"file": path, "family": family, "r": r, "offline": off, "nlrom_wall_seconds": secs, **res}
        save()
        def fmt(cs):
            return ", ".join("I(%s) = %s" % (c, "%.3f" % v["I"] if v["I"] is not None else "failed") for c, v in cs.items())
        print("    %s r = %d: trapezoidal %s; central %s" % (name, r, fmt(res["cases"]), fmt(res["central"]["cases"])),
              flush=True)

    print("== Fig. 7: CB r = 15 with STEP, unfiltered and POD-filtered", flush=True)
    study_rom("fig7_cb15", ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", 12], "cb", 15)
    study_rom("fig7_cb15_filtered", ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", 12, "-nlrom_snapshots", train,
                                     "-nlrom_filter_pod", 10], "cbf", 15)
    training = load_args("LE", 1, W_TRAIN) + ["-nlrom_training_tfinal", repr(T_TRAIN)]
    print("== Fig. 8-9: modal derivatives of 3 + 4 CB modes: best 10, all 28, random 10", flush=True)
    md = ["-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", 4] + training
    study_rom("fig9_best10", md + ["-nlrom_num_derivatives", 10], "cbmd", 17)
    study_rom("fig9_all28", md + ["-nlrom_num_derivatives", 28], "cbmd", 35)
    study_rom("fig9_random10", md + ["-nlrom_num_derivatives", 10, "-nlrom_derivative_selection", "random",
                                     "-nlrom_derivative_seed", 3], "cbmd", 17)

    print("== Fig. 10, 12, 13: I against r for the three bases", flush=True)
    sizes = [7, 13, 19, 25] if args.quick else [5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27]
    for r in sizes:
        study_rom("pod_r%d" % r, ["-nlrom_basis", "pod", "-nlrom_num_pod", r - 3, "-nlrom_snapshots", train], "pod", r)
        study_rom("cbf_r%d" % r, ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", r - 3, "-nlrom_snapshots", train,
                                  "-nlrom_filter_pod", min(10, r)], "cbf", r)
        if r > 7:
            study_rom("cbmd_r%d" % r, md + ["-nlrom_num_derivatives", r - 7], "cbmd", r)

    print("== Fig. 14: POD (3 + 10) trained on N_t tip nodes, tested on N_e", flush=True)
    fig14 = np.zeros((ntip, ntip))
    tip_cases = {"tip%d" % k: ("tip%d" % k, k, W_TRAIN, "test_tip%d" % k) for k in range(1, ntip + 1)}
    for nt in range(1, ntip + 1):
        name = "fig14_pod_t%d" % nt
        study_rom(name, ["-nlrom_basis", "pod", "-nlrom_num_pod", 10, "-nlrom_snapshots", fom["train_tip%d" % nt]["file"]],
                  "pod", 13, cases=tip_cases)
        for ne in range(1, ntip + 1):
            case = roms[name]["cases"].get("tip%d" % ne, {})
            fig14[nt - 1, ne - 1] = case["I"] if case.get("I") is not None else float("nan")
    study["fig14_I"] = [[None if math.isnan(x) else x for x in row] for row in fig14.tolist()]
    save()
    print("wrote", path_json)


if __name__ == "__main__":
    main()
