#!/usr/bin/env python3
"""Critical steps of massless-boundary models against mass-carrying ones (issue 27), and the cost of
the rotor 37 rubbing run.

For each model (the coarse blade with 8 tip nodes: CB r = 54, CB + MD r = 54 and r = 79; the NASA
rotor 37 blade with 16 tip nodes, CB r = 98, read from ../shared/meshes/rotor37-nlstep when
present), `morse nlrom -nlrom_forces none` builds the mass-carrying model and the massless ones
with -nlrom_massless_fmax 0 (all but the residual modes dynamic), 20, 10 and 5 kHz; the critical
step of each is what `morse simulate` reports with the contact set (massless: the dynamic modes
with the contact normals held), read from its refusal of a too large step. Then the rotor 37
case of run/rubbing_rotor37 (50 revolutions at 1,000 steps per revolution, linear, massless) is
timed, median of --repeat runs. Prints a table and writes bench/results/massless_<UTC>.json.
usage: bench/massless_bench.py [--repeat N] [--ranks N]
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
MORSE = os.path.join(ROOT, "build", "morse")
DECK = os.path.join(ROOT, "..", "shared", "meshes", "rotor37-nlstep", "blade.inp")
TIP37 = "188,190,192,194,196,198,200,203,253,255,257,259,261,263,265,267"
COARSE = ["-mesh", os.path.join(ROOT, "meshes", "blade_coarse.msh"), "-clamp", "root", "-boundary", "tip",
          "-load_sets", "LE", "-load_LE_dir", "y", "-load_LE_amplitude", "300", "-load_LE_omega", "2000",
          "-nlrom_training_tfinal", "0.0314"]
R37 = ["-mesh", DECK, "-clamp", "*BOUNDARY", "-mesh_node_sets", "tip16,resp", "-mesh_node_set_tip16", TIP37,
       "-mesh_node_set_resp", "1353", "-boundary", "tip16"]
CASE_COARSE = ["-contact_set", "tip", "-contact_mu", "0.15", "-casing_clearance", "3.56e-4", "-casing_lobes", "2",
               "-sim_omega", "1450"]
CASE_R37 = ["-contact_set", "tip16", "-contact_mu", "0.15", "-casing_clearance", "0.356", "-casing_bump_height",
            "0.712", "-casing_lobes", "2", "-casing_width", repr(0.15 * math.pi), "-casing_alpha", "1e12",
            "-sim_omega", "1344"]


def sh(cmd, ranks=1, check=True):
    full = (["mpirun", "-n", str(ranks)] if ranks > 1 else []) + [MORSE] + cmd
    r = subprocess.run(full, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if check and r.returncode != 0:
        sys.exit("massless_bench: failed: %s\n%s" % (" ".join(full), r.stdout[-2000:]))
    return r.stdout


def critical_step(rom, case, tmp):
    out = sh(["simulate", "-rom", rom, "-sim_linear", "-sim_revolutions", "1", "-sim_dt", "1", "-out",
              os.path.join(tmp, "probe.h5")] + case, check=False)
    for line in out.splitlines():
        if "critical step" in line:
            return float(line.split("critical step")[1].split()[0])
    sys.exit("massless_bench: no critical step in\n" + out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--ranks", type=int, default=2)
    a = ap.parse_args()
    env_ok = os.path.exists(MORSE) or sys.exit("massless_bench: build morse first (run/build)")
    models = [("coarse blade, CB, r = 54 (24 + 30)", COARSE + ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", "30"],
               CASE_COARSE),
              ("coarse blade, CB + MD, r = 54 (24 + 10 + 20)",
               COARSE + ["-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", "10", "-nlrom_num_derivatives", "20"],
               CASE_COARSE),
              ("coarse blade, CB + MD, r = 79 (24 + 15 + 40)",
               COARSE + ["-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", "15", "-nlrom_num_derivatives", "40"],
               CASE_COARSE)]
    if os.path.exists(DECK):
        models.append(("rotor 37, CB, r = 98 (48 + 50)", R37 + ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", "50"],
                       CASE_R37))
    else:
        print("massless_bench: the rotor 37 deck is absent (%s): its rows are skipped" % DECK)
    rec = {"models": {}, "machine": os.uname().nodename}
    tmp = tempfile.mkdtemp(prefix="massless_bench_")
    print("%-46s %-12s %-9s %-12s %s" % ("model", "carrying", "fmax", "massless", "ratio"))
    for label, args, case in models:
        rom = os.path.join(tmp, "carrying.h5")
        sh(["nlrom"] + args + ["-nlrom_forces", "none", "-out", rom], a.ranks)
        hc = critical_step(rom, case, tmp)
        rows = []
        for fmax in (0, 20000, 10000, 5000):
            rom = os.path.join(tmp, "massless.h5")
            out = sh(["nlrom"] + args + ["-nlrom_forces", "none", "-nlrom_boundary_mass", "massless",
                                         "-nlrom_massless_fmax", str(fmax), "-out", rom], a.ranks)
            nd = int(out.split("massless boundary (MacNeal): ")[1].split()[0])
            h = critical_step(rom, case, tmp)
            rows.append({"fmax_hz": fmax, "dynamic_modes": nd, "critical_step": h, "ratio": h / hc})
            print("%-46s %.3e s  %5d Hz  %.3e s  %6.1fx  (%d dynamic modes)" % (label, hc, fmax, h, h / hc, nd))
        rec["models"][label] = {"carrying_critical_step": hc, "massless": rows}
    if os.path.exists(DECK):
        rom = os.path.join(tmp, "r37.h5")
        sh(["nlrom"] + R37 + ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", "50", "-nlrom_forces", "none",
                              "-nlrom_damping_modal", "0.005", "-nlrom_damping_modes", "50", "-nlrom_boundary_mass",
                              "massless", "-out", rom], a.ranks)
        times = []
        for _ in range(a.repeat):
            t0 = time.time()
            out = sh(["simulate", "-rom", rom, "-sim_linear", "-sim_revolutions", "50", "-sim_dt",
                      repr(2 * math.pi / 1344 / 1000), "-sim_output_every", "10", "-sim_monitor", "resp", "-out",
                      os.path.join(tmp, "run.h5")] + CASE_R37)
            times.append(time.time() - t0)
            loop = float(out.split("steps in")[1].split()[0])
        rec["rotor37_50_revolutions"] = {"process_seconds": times, "median_seconds": statistics.median(times),
                                         "loop_seconds_last": loop, "steps": 50000}
        print("rotor 37, 50 revolutions at 1000 steps/rev, linear massless: median %.2f s per run (process), "
              "%d runs" % (statistics.median(times), a.repeat))
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    path = os.path.join(HERE, "results", "massless_%s.json" % time.strftime("%Y-%m-%dT%H%M%SZ", time.gmtime()))
    with open(path + ".tmp", "w") as f:
        json.dump(rec, f, indent=1)
    os.replace(path + ".tmp", path)
    print("massless_bench: wrote %s" % path)


if __name__ == "__main__":
    main()
