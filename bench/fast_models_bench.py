#!/usr/bin/python3
"""Step rates and accuracy of the fast reduced models of the coarse blade rubbing the ovalized
casing, and the cost of seed 003's full interaction map with each (issue 28 §4).

usage:
    /usr/bin/python3 bench/fast_models_bench.py                       # rates, r = 54 and 79, 2-rank builds, 3 runs
    /usr/bin/python3 bench/fast_models_bench.py --accuracy --reuse /tmp/fmb   # + accuracy at r = 79 (~12 min more)
    /usr/bin/python3 bench/fast_models_bench.py --quick --r 54        # smoke test: 1 rank, 2,000 steps, 1 run
    /usr/bin/python3 bench/fast_models_bench.py --quick --r 54 --accuracy --acc-tfinal 0.012

The models: `morse nlrom` on meshes/blade_coarse.msh, boundary `tip` (8 contact nodes, 24 DOFs), CB +
modal derivatives (r = 54: 10 fixed-interface modes + 20 derivatives; r = 79: 15 + 40, the seed's),
exact tensors, the LE training load, modal damping 5e-4 on all modes; built on --ranks ranks (1 with
--quick), in three variants:
  - carrying:    the mass-carrying model (the default);
  - mass-scaled: -nlrom_mass_scaling_fmax F (selective mass scaling: the modes above F moved to F;
                 same scheme and contact algorithm);
  - massless:    -nlrom_boundary_mass massless -nlrom_massless_fmax F -nlrom_massless_interior scaled.
F = --fmax (20,000 Hz).

The case: `morse simulate` on one core, 1,450 rad/s, contact set `tip`, casing clearance 3.56e-4 m,
2 lobes, growth rate -casing_alpha given explicitly (so runs of different lengths see the same
casing): 106.3 1/s for the accuracy runs (the distortion reaches the clearance at ln 2 / alpha =
6.5 ms), --rate-alpha 1e4 1/s for the rate runs (at 69 us, so that every rate run has contact). Time steps (--dt-*): carrying 5e-8 s; mass-scaled 8e-6 s linear, 1e-6 s
nonlinear; massless 4e-6 s linear, 1e-6 s nonlinear (geometric stiffening at mm-size tip motions
raises the frequencies of the nonlinear models above the linear critical step's).

Parts:
  - rates: for every r of --r, variant, linear and nonlinear, mu = --mu (0.15): steps/s of a run of
    --steps steps (20,000; 2,000 with --quick), --steps-linear (200,000; 20,000 with --quick) for the
    linear models (morse prints the loop time to 0.1 ms), output every --every (1000) steps, median
    of --repeat runs (3; 1 with --quick), rounds interleaved over the models. Whether a run reached
    the casing is recorded (the carrying runs at 5e-8 s end before the contact starts). A run that fails (the
    nonlinear massless model reaches a limit point of its boundary equilibrium at about 10 ms) is
    recorded with its time, and the model is timed again on a run ending at 90 % of that time.
    From the rate: simulated seconds per core-hour and the cost of the seed's full map: the speeds
    --map-omega-min..--map-omega-max (750..2,200 rad/s, the seed's, 1 rad/s apart: 1,451 speeds), --map-revolutions
    (200) each, i.e. sum over the speeds of 200 * 2 pi / Omega of simulated time, in core-hours =
    that / dt / (steps/s) / 3600, and its ratio to the carrying model (same r, same kind).
  - accuracy (--accuracy, off by default; the carrying nonlinear run alone is 600,000 steps, about
    10 minutes at r = 79): at r = --acc-r (79; the last of --r if 79 is not in it), t_final
    --acc-tfinal (0.03 s; 0.008 s with --quick), output every --acc-output-dt (8e-6 s, a multiple of
    every step), linear with mu = 0 and mu = --mu, nonlinear with mu = 0: from the output files,
    RMS of /sim/contact/radial_displacement at the first and last contact nodes, max |radial|, mean
    and max of the summed /sim/contact/normal (samples: one step's force every output row; their
    max depends on the step) and of the summed normal component of /sim/contact/mean_force (the
    impulse over each output interval: the step-independent measure), and their relative
    differences against the carrying model. A failed run is recorded with its time and run again
    to 95 % of it; that model is then compared with the carrying one over the shorter window.
--reuse DIR keeps the ROMs and the accuracy runs in DIR (each with a .json sidecar holding its
command line and parsed output) and reuses them when the command is unchanged; without it a
temporary directory is used and removed.

Writes bench/results/fast_models_<UTC>.json: machine (node, CPU, cores, BLAS, git state, binary
mtime), the arguments, every command line, the ROM builds (offline times, stage table, peaks,
critical steps), every rate run (steps, loop seconds, steps/s, process wall, max RSS, the CPU other
processes used, contact activity), the medians, simulated s per core-hour, map core-hours, the
ratios, and the accuracy metrics with their relative differences.
Exit status 0 on success (failures of the nonlinear massless model are results, not errors), 2 if
a ROM build or a carrying run failed.
"""

import argparse
import datetime
import json
import math
import os
import re
import shutil
import sys
import tempfile

from benchlib import RESULTS, ROOT, blas_info, cpu_busy, git_info, med, parse_stage_table, run_mpi

MORSE = os.path.join(ROOT, "build", "morse")
MESH = os.path.join(ROOT, "meshes", "blade_coarse.msh")
BASIS = {54: (10, 20), 79: (15, 40)}  # r: (fixed-interface modes, modal derivatives); + 24 boundary DOFs
VARIANTS = ["carrying", "mass-scaled", "massless"]
KINDS = ["linear", "nonlinear"]
FLOAT = r"([-+0-9.eE]+|inf|nan)"


def variant_options(variant, fmax):
    if variant == "carrying":
        return []
    if variant == "mass-scaled":
        return ["-nlrom_mass_scaling_fmax", "%g" % fmax]
    return ["-nlrom_boundary_mass", "massless", "-nlrom_massless_fmax", "%g" % fmax,
            "-nlrom_massless_interior", "scaled"]


def nlrom_command(r, variant, fmax, out):
    fixed, derivatives = BASIS[r]
    return ([MORSE, "nlrom", "-mesh", MESH, "-clamp", "root", "-boundary", "tip", "-nlrom_basis", "cbmd",
             "-nlrom_num_fixed_modes", str(fixed), "-nlrom_num_derivatives", str(derivatives),
             "-nlrom_training_tfinal", "0.0314", "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "all",
             "-nlrom_forces", "exact", "-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", "300",
             "-load_LE_omega", "2000"] + variant_options(variant, fmax) + ["-out", out])


def simulate_command(a, rom, dt, t_final, every, mu, linear, out, alpha=None):
    return ([MORSE, "simulate", "-rom", rom, "-sim_omega", "%g" % a.omega, "-sim_dt", repr(dt),
             "-sim_tfinal", repr(t_final), "-sim_output_every", str(every), "-contact_set", "tip",
             "-contact_mu", "%g" % mu, "-casing_clearance", "3.56e-4", "-casing_lobes", "2",
             "-casing_alpha", "%g" % (a.casing_alpha if alpha is None else alpha)] + (["-sim_linear"] if linear else []) + ["-out", out])


def grab(pattern, text, cast=float):
    m = re.search(pattern, text)
    return cast(m.group(1)) if m else None


def failure_info(text):
    """(time of the failure [s] or None, the error line) from a failed run's output."""
    lines = [l.strip() for l in text.splitlines() if "error:" in l]
    line = lines[0] if lines else (text.strip().splitlines() or [""])[-1]
    return grab(r"at t = " + FLOAT, line), line


def parse_simulate(stdout):
    m = re.search(r"(\d+) steps in ([0-9.]+) s \(", stdout)
    d = {"critical_step": grab(r"critical step " + FLOAT + " s", stdout),
         "steps": int(m.group(1)) if m else None, "loop_seconds": float(m.group(2)) if m else None,
         "kernel": grab(r"nonlinear force kernel: (\w+)", stdout, str)}
    d["steps_per_s"] = d["steps"] / d["loop_seconds"] if m and d["loop_seconds"] > 0 else None
    b = re.search(r"massless boundary: (\d+) equilibrium iterations \(([0-9.]+) per step\), (\d+) tangents", stdout)
    if b:
        d.update({"boundary_iterations": int(b.group(1)), "boundary_iterations_per_step": float(b.group(2)),
                  "tangent_updates": int(b.group(3))})
    d["max_normal_force_printed"] = grab(r"max normal force " + FLOAT + " N", stdout)
    return d


def run_record(res, cmd):
    """The numbers of a benchlib.run_mpi result worth keeping (not its stdout)."""
    sec, peak = parse_stage_table(res["stdout"])
    return {"command": " ".join(cmd), "process_wall": res["process_wall"], "max_rss_mb": res["rank_max_rss_mb"],
            "sum_max_rss_mb": res["sum_max_rss_mb"], "foreign_cpu_fraction": res["foreign_cpu_fraction"],
            "contention": res["contention"], "stage_seconds": sec, "stage_peak_mb": peak}


def binary_mtime():
    return datetime.datetime.utcfromtimestamp(os.path.getmtime(MORSE)).isoformat() + "Z"


def sidecar_load(path, cmd):
    """The stored record of `path` if its command was `cmd` (and, for a success, the file exists).
    A record made by another build of morse is reused with a warning and marked in the JSON."""
    try:
        with open(path + ".json") as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None
    if rec.get("command") != " ".join(cmd) or (not rec.get("failed") and not os.path.exists(path)):
        return None
    if rec.get("binary_mtime_utc") != binary_mtime():
        print("  WARNING: %s was made by build/morse of %s (now %s): reused anyway; delete it to redo" % (
            os.path.basename(path), rec.get("binary_mtime_utc"), binary_mtime()), flush=True)
        rec["reused_from_another_binary"] = True
    return rec


def sidecar_save(path, rec):
    rec["binary_mtime_utc"] = binary_mtime()
    with open(path + ".json.tmp", "w") as f:
        json.dump(rec, f, indent=1)
    os.replace(path + ".json.tmp", path + ".json")


def build_rom(a, r, variant, work):
    """Builds (or, with --reuse, finds) the ROM of (r, variant); returns (path, record) or (None, record)."""
    path = os.path.join(work, "rom_r%d_%s.h5" % (r, variant))
    cmd = nlrom_command(r, variant, a.fmax, path)
    rec = sidecar_load(path, cmd) if a.reuse else None
    if rec is not None and not rec.get("failed"):
        rec["reused"] = True
        print("  ROM r = %d %-11s reused (%s)" % (r, variant, path), flush=True)
        return path, rec
    print("  ROM r = %d %-11s building on %d rank(s)..." % (r, variant, a.ranks), end="", flush=True)
    fail = []
    res, full = run_mpi("nlrom r%d %s" % (r, variant), cmd, a.ranks, work, 1, failure=fail)
    if res is None:
        print(" FAILED")
        sys.stderr.write("fast_models_bench: %s\n%s\n" % (" ".join(full), fail[0]))
        return None, {"command": " ".join(cmd), "failed": True, "error": fail[0][-2000:]}
    out = res["stdout"]
    rec = run_record(res, cmd)
    rec["command"] = " ".join(cmd)
    rec["launcher"] = " ".join(full[:len(full) - len(cmd)])
    rec["ranks"] = a.ranks
    t = re.search(r"offline times t1 \(basis\) ([0-9.]+) s, t2 \(forces\) ([0-9.]+) s, t3 \(projection\) ([0-9.]+) s",
                  out)
    rec["offline_seconds"] = {"t1_basis": float(t.group(1)), "t2_forces": float(t.group(2)),
                              "t3_projection": float(t.group(3))} if t else None
    rec["mass_scaled_modes"] = grab(r"mass scaling: (\d+) modes above", out, int)
    rec["critical_step_nlrom"] = grab(r"critical step of central differences " + FLOAT + " s", out)
    rec["critical_step_unscaled"] = grab(r"\(without scaling " + FLOAT + " s\\)", out)
    rec["massless_dynamic_modes"] = grab(r"massless boundary \(MacNeal\): (\d+) dynamic modes", out, int)
    rec["r"] = grab(r"basis of (\d+) vectors", out, int)
    print(" %.1f s, max RSS %.0f MB per rank" % (rec["process_wall"], max(rec["max_rss_mb"] or [0])), flush=True)
    sidecar_save(path, rec)
    return path, rec


def simulate(a, rom, dt, t_final, every, mu, linear, out, work, alpha=None):
    """One `morse simulate` run on one core; a record with the parsed output, or with failed = True."""
    cmd = simulate_command(a, rom, dt, t_final, every, mu, linear, out, alpha)
    fail = []
    res, _ = run_mpi("simulate", cmd, 1, work, 1, failure=fail)
    if res is None:
        t, line = failure_info(fail[0])
        return {"command": " ".join(cmd), "dt": dt, "t_final": t_final, "failed": True, "failure_time": t,
                "error": line, "critical_step": grab(r"critical step " + FLOAT + " s", fail[0])}
    rec = run_record(res, cmd)
    rec.update(parse_simulate(res["stdout"]))
    rec.update({"dt": dt, "t_final": t_final, "failed": False})
    return rec


def contact_activity(path):
    """Whether and from when a run touched the casing, from a simulate file. The samples
    (/sim/contact/active, one step every output row) miss most contacts; /sim/contact/mean_force
    holds the impulse of every step: its first non-zero output interval is `first_contact_interval`."""
    import h5py
    import numpy as np
    with h5py.File(path, "r") as f:
        active = np.asarray(f["/sim/contact/active"])
        t = np.asarray(f["/sim/time"])
        mf = np.asarray(f["/sim/contact/mean_force"])
        peak = float(f["/sim/contact"].attrs.get("max_normal_force", 0.0))
    hit = np.nonzero(np.abs(mf).reshape(len(t), -1).max(axis=1) > 0)[0]
    return {"output_rows": int(len(t)), "sampled_rows_in_contact": int((active > 0).sum()),
            "intervals_with_contact": int(len(hit)), "max_normal_force": peak,
            "first_contact_interval": [float(t[hit[0] - 1]), float(t[hit[0]])] if len(hit) else None}


def metrics(path, t_end=None):
    """The accuracy measures of a simulate file over [0, t_end] (the whole run without t_end)."""
    import h5py
    import numpy as np
    with h5py.File(path, "r") as f:
        t = np.asarray(f["/sim/time"])
        rad = np.asarray(f["/sim/contact/radial_displacement"])
        lam = np.asarray(f["/sim/contact/normal"])
        mf = np.asarray(f["/sim/contact/mean_force"])
        nrm = np.asarray(f["/sim/contact/normals"])
        active = np.asarray(f["/sim/contact/active"])
    keep = t <= (t_end * (1 + 1e-9) if t_end is not None else np.inf)
    t, rad, lam, mf, active = t[keep], rad[keep], lam[keep], mf[keep], active[keep]
    total = lam.sum(axis=1)
    impulse = np.einsum("tnk,nk->t", mf, nrm)[1:]  # row 0 is 0 by definition
    hit = np.nonzero(np.abs(mf).reshape(len(t), -1).max(axis=1) > 0)[0]
    return {"t_end": float(t[-1]), "output_rows": int(len(t)),
            "rms_radial_first": float(np.sqrt(np.mean(rad[:, 0] ** 2))),
            "rms_radial_last": float(np.sqrt(np.mean(rad[:, -1] ** 2))),
            "max_abs_radial": float(np.max(np.abs(rad))),
            "normal_sum_mean": float(total.mean()), "normal_sum_max": float(total.max()),
            "mean_force_normal_sum_mean": float(impulse.mean()) if len(impulse) else 0.0,
            "mean_force_normal_sum_max": float(impulse.max()) if len(impulse) else 0.0,
            "sampled_rows_in_contact": int((active > 0).sum()), "intervals_with_contact": int(len(hit)),
            "first_contact_interval": [float(t[hit[0] - 1]), float(t[hit[0]])] if len(hit) else None}


ACC_KEYS = ["rms_radial_first", "rms_radial_last", "max_abs_radial", "normal_sum_mean", "normal_sum_max",
            "mean_force_normal_sum_mean", "mean_force_normal_sum_max"]


def rel(x, ref):
    return (x - ref) / abs(ref) if ref not in (None, 0.0) and x is not None else None


def map_time(a):
    """Simulated seconds of the full map: --map-revolutions at every speed of the range."""
    n = int(round((a.map_omega_max - a.map_omega_min) / a.map_omega_step)) + 1
    speeds = [a.map_omega_min + k * a.map_omega_step for k in range(n)]
    return n, sum(a.map_revolutions * 2 * math.pi / w for w in speeds)


def step_of(a, variant, kind):
    return {("carrying", "linear"): a.dt_carrying, ("carrying", "nonlinear"): a.dt_carrying_nl,
            ("mass-scaled", "linear"): a.dt_scaled, ("mass-scaled", "nonlinear"): a.dt_scaled_nl,
            ("massless", "linear"): a.dt_massless, ("massless", "nonlinear"): a.dt_massless_nl}[(variant, kind)]


def rates_part(a, roms, work, rec):
    """Rate runs, interleaved rounds; fills rec['rates'] and returns False if a carrying run failed."""
    configs = [(r, v, k) for r in a.r for v in VARIANTS for k in KINDS if roms.get((r, v))]
    steps = {c: a.steps_linear if c[2] == "linear" else a.steps for c in configs}
    runs = {c: [] for c in configs}
    failures = {c: [] for c in configs}
    ok = True
    out = os.path.join(work, "rate.h5")
    for rep in range(a.repeat):
        for c in configs:
            r, v, k = c
            dt = step_of(a, v, k)
            while True:
                n = steps[c]
                x = simulate(a, roms[c[:2]], dt, n * dt, a.every, a.mu, k == "linear", out, work, a.rate_alpha)
                x["round"] = rep + 1
                if not x["failed"]:
                    x["requested_steps"] = n
                    x["contact"] = contact_activity(out)
                    runs[c].append(x)
                    print("  rate r = %d %-11s %-9s run %d: %6d steps, %9.0f steps/s" % (
                        r, v, k, rep + 1, x["steps"], x["steps_per_s"]), flush=True)
                    break
                failures[c].append(x)
                print("  rate r = %d %-11s %-9s run %d: FAILED at t = %s s: %s" % (
                    r, v, k, rep + 1, x["failure_time"], x["error"][:120]), flush=True)
                tf = x["failure_time"]
                shorter = int(0.9 * tf / dt) // a.every * a.every if tf else 0
                if v == "carrying":
                    ok = False
                if shorter < a.every or shorter >= n:
                    break
                steps[c] = shorter  # time the model on a run that ends before the failure
    rec["rates"] = {"runs": {}, "summary": {}}
    t_map = rec["map"]["simulated_seconds"]
    for c in configs:
        r, v, k = c
        key = "r%d/%s/%s" % c
        dt = step_of(a, v, k)
        sps = med([x["steps_per_s"] for x in runs[c]])
        s = {"r": r, "variant": v, "kind": k, "dt": dt, "mu": a.mu, "runs": len(runs[c]),
             "steps_per_run": steps[c] if runs[c] else None,
             "simulated_seconds_per_run": steps[c] * dt if runs[c] else None,
             "critical_step": next((x["critical_step"] for x in runs[c] + failures[c] if x.get("critical_step")), None),
             "steps_per_s_median": sps,
             "steps_per_s_samples": [x["steps_per_s"] for x in runs[c]],
             "steps_per_s_min": min([x["steps_per_s"] for x in runs[c]]) if runs[c] else None,
             "steps_per_s_max": max([x["steps_per_s"] for x in runs[c]]) if runs[c] else None,
             "max_rss_mb_median": med([(x["max_rss_mb"] or [None])[0] for x in runs[c]]),
             "intervals_with_contact_last_run": runs[c][-1]["contact"]["intervals_with_contact"] if runs[c] else None,
             "first_contact_interval_last_run": runs[c][-1]["contact"]["first_contact_interval"] if runs[c] else None,
             "failed_runs": len(failures[c]),
             "failure_time": failures[c][0]["failure_time"] if failures[c] else None,
             "failure": failures[c][0]["error"] if failures[c] else None}
        if sps:
            s["simulated_seconds_per_core_hour"] = sps * dt * 3600.0
            s["map_core_hours"] = t_map / dt / sps / 3600.0
        for extra in ("boundary_iterations_per_step", "kernel"):
            vals = [x.get(extra) for x in runs[c] if x.get(extra) is not None]
            if vals:
                s[extra] = vals[-1] if extra == "kernel" else med(vals)
        rec["rates"]["runs"][key] = {"successful": runs[c], "failed": failures[c]}
        rec["rates"]["summary"][key] = s
    for key, s in rec["rates"]["summary"].items():
        ref = rec["rates"]["summary"].get("r%d/carrying/%s" % (s["r"], s["kind"]))
        if ref and ref.get("map_core_hours") and s.get("map_core_hours"):
            s["ratio_steps_per_s_vs_carrying"] = s["steps_per_s_median"] / ref["steps_per_s_median"]
            s["ratio_dt_vs_carrying"] = s["dt"] / ref["dt"]
            s["speedup_map_vs_carrying"] = ref["map_core_hours"] / s["map_core_hours"]
    return ok


def accuracy_part(a, roms, work, rec):
    """Accuracy runs at r = a.acc_r; fills rec['accuracy']; False if a carrying run failed."""
    r = a.acc_r
    cases = [("linear", 0.0), ("linear", a.mu), ("nonlinear", 0.0)]
    rec["accuracy"] = {"r": r, "t_final": a.acc_tfinal, "output_dt": a.acc_output_dt, "omega": a.omega,
                       "cases": {}}
    ok = True
    for kind, mu in cases:
        case = "%s_mu%g" % (kind, mu)
        rows = {}
        for v in VARIANTS:
            if not roms.get((r, v)):
                continue
            dt = step_of(a, v, kind)
            every = int(round(a.acc_output_dt / dt))
            if every < 1 or abs(every * dt - a.acc_output_dt) > 1e-9 * a.acc_output_dt:
                sys.exit("fast_models_bench: --acc-output-dt %g is not a multiple of the %s %s step %g" % (
                    a.acc_output_dt, v, kind, dt))
            t_final = a.acc_tfinal
            row = {"variant": v, "dt": dt, "output_every": every}
            while True:
                path = os.path.join(work, "acc_r%d_%s_%s_t%g.h5" % (r, v, case, t_final))
                cmd = simulate_command(a, roms[(r, v)], dt, t_final, every, mu, kind == "linear", path)
                x = sidecar_load(path, cmd) if a.reuse else None
                if x is not None:
                    x["reused"] = True
                else:
                    print("  accuracy r = %d %-11s %-9s mu = %-4g: %g s at dt %g (%d steps)..." % (
                        r, v, kind, mu, t_final, dt, int(round(t_final / dt))), end="", flush=True)
                    x = simulate(a, roms[(r, v)], dt, t_final, every, mu, kind == "linear", path, work)
                    print(" FAILED at t = %s s" % x["failure_time"] if x["failed"] else
                          " %.1f s (%.0f steps/s)" % (x["process_wall"], x["steps_per_s"]), flush=True)
                    sidecar_save(path, x)
                if not x["failed"]:
                    row["run"] = x
                    row["path"] = path
                    break
                row.setdefault("failed_runs", []).append(x)
                row["failure_time"] = row.get("failure_time", x["failure_time"])
                if v == "carrying":
                    ok = False
                tf = x["failure_time"]
                shorter = math.floor(0.95 * tf / a.acc_output_dt) * a.acc_output_dt if tf else 0.0
                if shorter < a.acc_output_dt or shorter >= t_final:
                    break
                t_final = round(shorter, 12)  # the model up to its failure, compared over that window
            rows[v] = row
        ref = rows.get("carrying")
        for v, row in rows.items():
            if "path" not in row:
                continue
            window = row["run"]["t_final"] if row.get("failed_runs") else None
            row["metrics"] = metrics(row["path"], window)
            row["window"] = row["metrics"]["t_end"]
            if ref and "path" in ref:
                m_ref = metrics(ref["path"], window)
                row["carrying_metrics_same_window"] = m_ref
                row["relative_difference_vs_carrying"] = {k: rel(row["metrics"][k], m_ref[k]) for k in ACC_KEYS}
        for row in rows.values():
            row.pop("path", None)
        rec["accuracy"]["cases"][case] = {"kind": kind, "mu": mu, "models": rows}
    return ok


def print_summary(a, rec):
    print()
    print("fast_models_bench: rates on one core, mu = %g, output every %d steps, median of %d run(s)" % (
        a.mu, a.every, a.repeat))
    print("  'steps' is the length of a run; 'sim s/c-h' simulated seconds per core-hour; 'speed-up' the map's "
          "core-hours of the carrying model (same r and kind) over the model's")
    print("  full map: %d speeds %g..%g rad/s, %g revolutions each = %.1f s simulated" % (
        rec["map"]["speeds"], a.map_omega_min, a.map_omega_max, a.map_revolutions, rec["map"]["simulated_seconds"]))
    print("  %-3s %-11s %-9s %8s %9s %6s %9s %11s %12s %9s %7s  %s" % (
        "r", "model", "kind", "dt [s]", "crit [s]", "steps", "steps/s", "sim s/c-h", "map core-h", "speed-up",
        "RSS MB", "notes"))
    for s in rec["rates"]["summary"].values():
        notes = []
        if s["failed_runs"]:
            notes.append("FAILED at t = %.4g s; timed on %d steps" % (s["failure_time"] or float("nan"),
                                                                      s["steps_per_run"] or 0))
        if s.get("intervals_with_contact_last_run") == 0:
            notes.append("no contact")
        elif s.get("first_contact_interval_last_run"):
            notes.append("first contact in (%.3g, %.3g] s" % tuple(s["first_contact_interval_last_run"]))
        if s.get("boundary_iterations_per_step") is not None:
            notes.append("%.2f eq. it/step" % s["boundary_iterations_per_step"])
        sps = s["steps_per_s_median"]
        print("  %-3d %-11s %-9s %8.1e %9.3e %6s %9s %11s %12s %9s %7s  %s" % (
            s["r"], s["variant"], s["kind"], s["dt"], s["critical_step"] or float("nan"),
            s["steps_per_run"] or "-", "%.0f" % sps if sps else "-",
            "%.4g" % s["simulated_seconds_per_core_hour"] if sps else "-",
            "%.4g" % s["map_core_hours"] if sps else "-",
            "x%.1f" % s["speedup_map_vs_carrying"] if s.get("speedup_map_vs_carrying") else "-",
            "%.0f" % s["max_rss_mb_median"] if s.get("max_rss_mb_median") else "-", "; ".join(notes)))
    acc = rec.get("accuracy")
    if not acc:
        return
    print()
    print("fast_models_bench: accuracy at %g rad/s, r = %d, t_final %g s, against the carrying model "
          "(relative differences)" % (acc["omega"], acc["r"], acc["t_final"]))
    short = {"rms_radial_first": "rms rad 1st", "rms_radial_last": "rms rad last", "max_abs_radial": "max|rad|",
             "normal_sum_mean": "mean sum lam", "normal_sum_max": "max sum lam",
             "mean_force_normal_sum_mean": "mean impulse", "mean_force_normal_sum_max": "max impulse"}
    print("  %-16s %-11s %8s  " % ("case", "model", "window") + " ".join("%12s" % short[k] for k in ACC_KEYS))
    for case, c in acc["cases"].items():
        for v, row in c["models"].items():
            if "metrics" not in row:
                print("  %-16s %-11s FAILED at t = %s s (no output)" % (case, v, row.get("failure_time")))
                continue
            vals = row["metrics"]
            d = row.get("relative_difference_vs_carrying", {})
            if v == "carrying":
                cells = ["%12.4g" % vals[k] for k in ACC_KEYS]
            else:
                cells = ["%+11.2f%%" % (100 * d[k]) if d.get(k) is not None else "%12s" % "-" for k in ACC_KEYS]
            note = " (failed at t = %.4g s: window to it)" % row["failure_time"] if row.get("failed_runs") else ""
            print("  %-16s %-11s %8.4g  " % (case, v, row["window"]) + " ".join(cells) + note)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: 1 rank, --steps 2000, --repeat 1, --acc-tfinal 0.008 unless given")
    ap.add_argument("--r", default="54,79", help="reduced sizes, from 54 and 79 (default 54,79)")
    ap.add_argument("--ranks", type=int, default=None, help="ranks of the ROM builds (default 2; 1 with --quick)")
    ap.add_argument("--repeat", type=int, default=None, help="rate runs per model (default 3; 1 with --quick)")
    ap.add_argument("--steps", type=int, default=None,
                    help="steps of a nonlinear rate run (default 20000; 2000 with --quick)")
    ap.add_argument("--steps-linear", type=int, default=None,
                    help="steps of a linear rate run (default 200000; 20000 with --quick): morse prints the loop "
                         "time to 0.1 ms and a linear step takes about 5 us")
    ap.add_argument("--every", type=int, default=1000, help="output every K steps in the rate runs")
    ap.add_argument("--mu", type=float, default=0.15, help="friction of the rate runs and of the accuracy case")
    ap.add_argument("--fmax", type=float, default=20000.0, help="mass scaling / massless cap [Hz]")
    ap.add_argument("--omega", type=float, default=1450.0)
    ap.add_argument("--casing-alpha", type=float, default=106.3)
    ap.add_argument("--rate-alpha", type=float, default=1e4,
                    help="casing growth rate of the rate runs [1/s]: 1e4 reaches the clearance at 69 us, so "
                         "every rate run is timed with contact")
    ap.add_argument("--dt-carrying", type=float, default=5e-8)
    ap.add_argument("--dt-carrying-nl", type=float, default=5e-8)
    ap.add_argument("--dt-scaled", type=float, default=8e-6)
    ap.add_argument("--dt-scaled-nl", type=float, default=1e-6)
    ap.add_argument("--dt-massless", type=float, default=4e-6)
    ap.add_argument("--dt-massless-nl", type=float, default=1e-6)
    ap.add_argument("--map-omega-min", type=float, default=750.0)
    ap.add_argument("--map-omega-max", type=float, default=2200.0)
    ap.add_argument("--map-omega-step", type=float, default=1.0)
    ap.add_argument("--map-revolutions", type=float, default=200.0)
    ap.add_argument("--accuracy", action="store_true", help="run the accuracy part (long: see above)")
    ap.add_argument("--acc-r", type=int, default=None, help="r of the accuracy part (79; the last --r without 79)")
    ap.add_argument("--acc-tfinal", type=float, default=None, help="default 0.03 s; 0.008 s with --quick")
    ap.add_argument("--acc-output-dt", type=float, default=8e-6)
    ap.add_argument("--no-rates", action="store_true", help="skip the rate part (e.g. only --accuracy)")
    ap.add_argument("--reuse", metavar="DIR", help="keep ROMs and accuracy runs in DIR and reuse them")
    a = ap.parse_args()
    a.r = [int(x) for x in a.r.split(",")]
    if any(r not in BASIS for r in a.r):
        sys.exit("fast_models_bench: --r takes sizes from %s" % sorted(BASIS))
    a.ranks = a.ranks or (1 if a.quick else 2)
    a.repeat = a.repeat or (1 if a.quick else 3)
    a.steps = a.steps or (2000 if a.quick else 20000)
    a.steps_linear = a.steps_linear or (20000 if a.quick else 200000)
    a.acc_tfinal = a.acc_tfinal or (0.008 if a.quick else 0.03)
    a.acc_r = a.acc_r or (79 if 79 in a.r else a.r[-1])
    if a.acc_r not in BASIS:
        sys.exit("fast_models_bench: --acc-r takes a size from %s" % sorted(BASIS))
    if a.steps % a.every or a.steps_linear % a.every:
        sys.exit("fast_models_bench: --steps and --steps-linear must be multiples of --every")
    if not os.path.exists(MORSE):
        sys.exit("fast_models_bench: build morse first (run/build)")
    mtime = os.path.getmtime(MORSE)
    if a.reuse:
        os.makedirs(a.reuse, exist_ok=True)
        work = os.path.abspath(a.reuse)
    else:
        work = tempfile.mkdtemp(prefix="fast_models_bench_")
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    rec = {"machine": {"node": os.uname().nodename, "cpu": model, "cpus": os.cpu_count(),
                       "cpu_busy_at_start": cpu_busy(), "blas": blas_info(MORSE), "git": git_info(),
                       "binary": MORSE, "binary_mtime_utc": binary_mtime()},
           "args": vars(a), "work_dir": work, "basis": {str(r): {"boundary_dofs": 24, "fixed_modes": BASIS[r][0],
                                                                 "derivatives": BASIS[r][1]} for r in BASIS},
           "roms": {}}
    print("fast_models_bench: work directory %s; ROMs on %d rank(s), simulations on one core" % (work, a.ranks),
          flush=True)
    n_speeds, t_map = map_time(a)
    rec["map"] = {"speeds": n_speeds, "omega_min": a.map_omega_min, "omega_max": a.map_omega_max,
                  "omega_step": a.map_omega_step, "revolutions": a.map_revolutions, "simulated_seconds": t_map}
    status = 0
    roms = {}
    need = sorted(set(a.r if not a.no_rates else []) | ({a.acc_r} if a.accuracy else set()))
    for r in need:
        for v in VARIANTS:
            path, rr = build_rom(a, r, v, work)
            rec["roms"]["r%d/%s" % (r, v)] = rr
            if path:
                roms[(r, v)] = path
            else:
                status = 2
    if not a.no_rates:
        if not rates_part(a, roms, work, rec):
            status = 2
    if a.accuracy:
        if not accuracy_part(a, roms, work, rec):
            status = 2
    if os.path.getmtime(MORSE) != mtime:
        print("fast_models_bench: WARNING: build/morse changed during the run")
        rec["machine"]["binary_changed_during_run"] = True
    rec.setdefault("rates", {"summary": {}})
    print_summary(a, rec)
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "fast_models_%s%s.json" % (stamp, "_quick" if a.quick else ""))
    with open(path + ".tmp", "w") as f:
        json.dump(rec, f, indent=1)
    os.replace(path + ".tmp", path)
    print("fast_models_bench: wrote %s" % path)
    if not a.reuse:
        shutil.rmtree(work, ignore_errors=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
