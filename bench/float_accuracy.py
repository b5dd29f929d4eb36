#!/usr/bin/python3
"""The accuracy of float coefficients (`morse sweep -sweep_float`) on the blade (issue 29).

usage:
    /usr/bin/python3 bench/float_accuracy.py                          # coarse blade, r79, 8 speeds
    /usr/bin/python3 bench/float_accuracy.py --rom FILE.h5 --speeds 1100:1800:50 --revolutions 20
    /usr/bin/python3 bench/float_accuracy.py --keep DIR --reuse --roundoff     # + the lane kernel in double

The model is the nonlinear map's (run/contact_study.py, stage maps): CB + 15 fixed-interface modes
+ 40 modal derivatives on the 8 tip nodes (r = 79), exact tensors, every mode damped (0.05 %),
selective mass scaling to 20 kHz, built here unless --rom is given. The same `morse sweep`
(the seed's casing, mu = 0.15, --dt, --revolutions per speed, -sweep_rotation negative) runs
twice on --ranks ranks, with double and with float coefficients (the potential kernel both
times), and for every speed the script compares what a map shows:
  - the RMS and the mean of the radial LE displacement over the second half of the run,
  - its amplitude spectrum (the largest difference, relative to the double spectrum's peak, and
    whether the dominant frequency is the same),
  - the largest total contact force and the energy at the end.
With --roundoff the double sweep runs a third time with the lane kernel (the same arithmetic
summed in another order: round-off differences only), and is compared the same way: where that
differs as much as float does, the difference is the response's sensitivity to any perturbation
(a chaotic or path-dependent response), not float's precision. Writes
bench/results/float_accuracy_<UTC>.json (summary per speed, timings, git). Exit 0, or 2 if
morse failed.
"""

import argparse
import datetime
import json
import os
import shutil
import sys
import tempfile

import h5py
import numpy as np

from benchlib import RESULTS, ROOT, git_info, run_mpi

CASING = ["-contact_set", "tip", "-contact_mu", "0.15", "-casing_clearance", "3.56e-4", "-casing_lobes", "2"]


def speeds_of(text):
    lo, hi, step = (float(x) for x in text.split(":"))
    return lo, hi, step


def read(path):
    with h5py.File(path, "r") as f:
        g = f["sweep"]
        return {"omega": np.array(g["omega"]), "rms": np.array(g["rms"]), "mean": np.array(g["mean"]),
                "max_force": np.array(g["max_contact_force"]), "status": np.array(g["status"]),
                "spectrum": np.array(g["spectrum"]), "frequencies": np.array(g["frequency"]),
                "energy_end": np.array(g["energy_balance"])[:, 5]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default=os.path.join(ROOT, "meshes", "blade_coarse.msh"))
    ap.add_argument("--rom", help="a morse nlrom file with the tip boundary (default: built here)")
    ap.add_argument("--speeds", default="1100:1800:100", help="lo:hi:step [rad/s]")
    ap.add_argument("--revolutions", type=float, default=10.0)
    ap.add_argument("--dt", type=float, default=5e-7, help="the nonlinear map's step (run/contact_study.py)")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--keep", help="directory to keep the ROM and the sweep files in")
    ap.add_argument("--roundoff", action="store_true",
                    help="also run the double sweep with the lane kernel (-sweep_kernel lane: the same arithmetic "
                         "summed in another order), to compare float's difference with that of round-off alone")
    ap.add_argument("--reuse", action="store_true", help="with --keep: reuse the sweep files already there")
    ap.add_argument("--variants", default="float",
                    help="comma-separated variants compared with the double potential kernel: float (float "
                         "coefficients), lane (as --roundoff), perturbed (every speed times 1 + 1e-12: a "
                         "perturbation of round-off size at the potential kernel's speed)")
    args = ap.parse_args()
    morse = os.path.join(ROOT, "build", "morse")
    if not os.path.exists(morse):
        sys.exit("float_accuracy: build morse first (run/test or cmake --build build)")
    work = args.keep or tempfile.mkdtemp(prefix="float_accuracy_")
    os.makedirs(work, exist_ok=True)
    timings = {}
    rom = args.rom or os.path.join(work, "rom_r79_ms.h5")
    if not os.path.exists(rom):
        res, _ = run_mpi("nlrom", [morse, "nlrom", "-mesh", args.mesh, "-clamp", "root", "-boundary", "tip",
                                   "-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", "15",
                                   "-nlrom_num_derivatives", "40", "-nlrom_training_tfinal", "0.0314",
                                   "-nlrom_damping_modal", "5e-4", "-nlrom_damping_modes", "all",
                                   "-nlrom_forces", "exact", "-nlrom_mass_scaling_fmax", "20000",
                                   "-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", "300",
                                   "-load_LE_omega", "2000", "-out", rom], args.ranks, work, 1)
        if res is None:
            return 2
        timings["nlrom_s"] = res.get("process_wall")
    lo, hi, step = speeds_of(args.speeds)
    files = {}
    known = {"float": ["-sweep_kernel", "potential", "-sweep_float"], "lane": ["-sweep_kernel", "lane"],
             "perturbed": ["-sweep_kernel", "potential"]}
    wanted = [v for v in args.variants.split(",") if v]
    if args.roundoff and "lane" not in wanted:
        wanted.append("lane")
    for v in wanted:
        if v not in known:
            sys.exit("float_accuracy: --variants: unknown variant '%s' (float, lane, perturbed)" % v)
    variants = {"double": ["-sweep_kernel", "potential"]}
    variants.update({v: known[v] for v in wanted})
    for prec, opts in variants.items():
        out = os.path.join(work, "sweep_%s.h5" % prec)
        scale = 1.0 + 1e-12 if prec == "perturbed" else 1.0
        if not (args.reuse and os.path.exists(out)):
            res, _ = run_mpi("sweep %s" % prec, [morse, "sweep", "-rom", rom, "-sweep_omega_min", repr(lo * scale),
                                                  "-sweep_omega_max", repr(hi * scale), "-sweep_omega_step",
                                                  repr(step * scale),
                                                  "-sim_revolutions", repr(args.revolutions), "-sim_dt",
                                                  repr(args.dt), "-sweep_rotation", "negative",
                                                  "-sweep_monitor", "LE", "-sweep_restart", "-out", out] + CASING +
                             opts, args.ranks, work, 1)
            if res is None:
                # morse sweep exits 1 when speeds failed (NaN), with a complete file that records
                # them (status != 0): those speeds are reported, the others compared.
                if not os.path.exists(out):
                    return 2
                print("float_accuracy: sweep %s reported failed speeds; comparing the others" % prec)
            else:
                timings["sweep_%s_s" % prec] = res.get("process_wall")
        files[prec] = read(out)
    d = files["double"]
    freqs = d["frequencies"]
    print("float_accuracy: %d speeds, %g revolutions each, dt %g s, %d rank(s); each variant against the double "
          "potential kernel" % (len(d["omega"]), args.revolutions, args.dt, args.ranks))
    summary = {"speeds": len(d["omega"]), "revolutions": args.revolutions, "dt": args.dt, "ranks": args.ranks,
               "timings": timings,
               "double_failed_speeds": [abs(float(w)) for w, st in zip(d["omega"], d["status"]) if st != 0]}
    if summary["double_failed_speeds"]:
        print("  the double sweep failed (NaN) at %s rad/s" % ", ".join("%.0f" % w for w in summary["double_failed_speeds"]))
    rows = []
    for name in [v for v in variants if v != "double"]:
        f = files[name]
        print("  %s:\n  %9s %10s %10s %10s %10s %10s %8s %10s" % (
            {"float": "float coefficients", "lane": "the lane kernel (double, another summation order)",
             "perturbed": "every speed times 1 + 1e-12 (potential kernel, double)"}[name],
            "|omega|", "rms [mm]", "d rms", "d mean", "d spec", "peak Hz", "same", "d force"))
        mine = []
        failed = []
        for k in range(len(d["omega"])):
            # The same speed in both files (the perturbed variant's speeds differ by 1e-12).
            match = [j for j in range(len(f["omega"]))
                     if abs(abs(f["omega"][j]) - abs(d["omega"][k])) <= 1e-9 * abs(d["omega"][k])]
            if not match:
                continue
            j = match[0]
            if d["status"][k] != 0 or f["status"][j] != 0:
                failed.append({"variant": name, "omega": float(d["omega"][k]), "status_double": int(d["status"][k]),
                               "status": int(f["status"][j])})
                print("  %9.0f   failed (status: double %d, %s %d)" % (abs(d["omega"][k]), d["status"][k], name,
                                                                      f["status"][j]))
                continue
            f_k = {key: (v[j] if hasattr(v, "__len__") and len(v) == len(f["omega"]) else v) for key, v in f.items()}
            sd, sf = d["spectrum"][k], f_k["spectrum"]
            pd = int(np.argmax(sd[1:]) + 1) if len(sd) > 1 else 0
            pf = int(np.argmax(sf[1:]) + 1) if len(sf) > 1 else 0
            row = {"variant": name, "omega": float(d["omega"][k]), "status_double": int(d["status"][k]),
                   "status": int(f_k["status"]), "rms_double": float(d["rms"][k]), "rms": float(f_k["rms"]),
                   "rms_rel": float(abs(f_k["rms"] - d["rms"][k]) / max(abs(d["rms"][k]), 1e-300)),
                   "mean_rel": float(abs(f_k["mean"] - d["mean"][k]) / max(abs(d["rms"][k]), 1e-300)),
                   "spectrum_rel": float(np.max(np.abs(sf - sd)) / max(np.max(sd[1:]) if len(sd) > 1 else 0, 1e-300)),
                   "peak_hz_double": float(freqs[pd]), "peak_hz": float(freqs[pf]),
                   "max_force_rel": float(abs(f_k["max_force"] - d["max_force"][k]) / max(d["max_force"][k], 1e-300)),
                   "energy_end_rel": float(abs(f_k["energy_end"] - d["energy_end"][k]) /
                                           max(abs(d["energy_end"][k]), 1e-300))}
            mine.append(row)
            print("  %9.0f %10.4f %10.2e %10.2e %10.2e %10.0f %8s %10.2e" % (
                abs(row["omega"]), 1e3 * row["rms_double"], row["rms_rel"], row["mean_rel"], row["spectrum_rel"],
                row["peak_hz_double"], "yes" if pd == pf else "NO", row["max_force_rel"]))
        rows += failed
        if not mine:
            continue
        worst = max(mine, key=lambda x: x["rms_rel"])
        summary[name] = {"rms_rel_median": float(np.median([x["rms_rel"] for x in mine])),
                         "rms_rel_max": worst["rms_rel"], "rms_rel_max_omega": worst["omega"],
                         "spectrum_rel_max": max(x["spectrum_rel"] for x in mine),
                         "dominant_frequency_changed": sum(x["peak_hz_double"] != x["peak_hz"] for x in mine)}
        print("  %s: RMS median %.2e, largest %.2e at %.0f rad/s; spectrum: largest %.2e of the peak; dominant "
              "frequency changed at %d of %d speeds" % (
                  name, summary[name]["rms_rel_median"], summary[name]["rms_rel_max"],
                  abs(summary[name]["rms_rel_max_omega"]), summary[name]["spectrum_rel_max"],
                  summary[name]["dominant_frequency_changed"], len(mine)))
        summary[name]["failed_speeds"] = [abs(x["omega"]) for x in failed]
        rows += mine
    stamp = datetime.datetime.utcnow().strftime("%Y-%m-%dT%H%M%SZ")
    os.makedirs(RESULTS, exist_ok=True)
    path = os.path.join(RESULTS, "float_accuracy_%s.json" % stamp)
    with open(path, "w") as fh:
        json.dump({"benchmark": "float_accuracy", "summary": summary, "speeds": rows, "args": vars(args),
                   "git": git_info()}, fh, indent=1)
    print("float_accuracy: wrote %s" % path)
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
