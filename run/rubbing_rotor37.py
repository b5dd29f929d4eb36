#!/usr/bin/env python3
"""The rotor 37 rubbing case of issue 27 (see run/rubbing_rotor37 and docs/rubbing.md).

Set-up of NLstep's example 03 ("PLAUSIBLE"): 16 tip nodes in contact, mu = 0.15, the gap
g_mean (1 - 2 exp(-((theta mod pi) / pi - 1/2)^2 / 0.15^2)) with g_mean = 0.356 mm, i.e. morse's
casing with clearance 0.356 mm, bump height 0.712 mm, 2 lobes, width 0.15 pi rad, present from
t = 0 (no growth), 1344 rad/s, 50 revolutions at 1000 steps per revolution; 50 dynamic modes with
0.5 % modal damping; the response is u_y of node 1353. Units of the deck: N, mm, t, s.

Stages (each skipped if its file exists):
  nlrom   CB with 50 fixed-interface modes, linear (-nlrom_forces none): massless and mass-carrying
  runs    massless at NLstep's step (2 pi / 1344 / 1000) and 4 times smaller; mass-carrying at 0.95 and
          0.25 of its critical step
  nonlinear (--nonlinear)  CB + 10 modes + 10 modal derivatives, exact tensors, massless with the modes
          above 5 kHz quasi-static (the modal-derivative-rich ones: with them dynamic, the static
          boundary block is too stiff for its equilibrium to converge, docs/rubbing.md), same casing
Writes rubbing.json (stage times, critical steps, response statistics over the last 5
revolutions, agreement between models) and docs/img/rubbing_rotor37.png.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MORSE = os.path.join(ROOT, "build", "morse")
OMEGA = 1344.0
REVS = 50
TIP = "188,190,192,194,196,198,200,203,253,255,257,259,261,263,265,267"
CASING = ["-contact_set", "tip16", "-contact_mu", "0.15", "-casing_clearance", "0.356", "-casing_bump_height",
          "0.712", "-casing_lobes", "2", "-casing_width", repr(0.15 * math.pi), "-casing_alpha", "1e12"]


def run(cmd, log, ranks=1):
    full = (["mpirun", "-n", str(ranks)] if ranks > 1 else []) + [MORSE] + [str(c) for c in cmd]
    t0 = time.time()
    with open(log, "w") as f:
        r = subprocess.run(full, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        sys.exit("rubbing_rotor37: failed (%s): %s" % (log, " ".join(full)))
    return time.time() - t0


def grep(log, key):
    with open(log) as f:
        return [l for l in f if key in l]


def stats(path):
    import h5py
    import numpy as np
    T = 2 * math.pi / OMEGA
    with h5py.File(path, "r") as f:
        t = f["/sim/time"][:]
        uy = f["/sim/sets/resp/u"][:, 0, 1]
        lam = f["/sim/contact/normal"][:].sum(axis=1)
    m = t >= (REVS - 5) * T
    return {"t": t, "uy": uy, "mean": float(uy[m].mean()), "min": float(uy[m].min()), "max": float(uy[m].max()),
            "std": float(uy[m].std()), "mean_force": float(lam[m].mean()), "max_force": float(lam.max())}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", required=True)
    ap.add_argument("--out", default="out/rubbing_rotor37")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--nonlinear", action="store_true", help="also the CB + MD massless run with exact tensors")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rec_path = os.path.join(a.out, "rubbing.json")
    rec = json.load(open(rec_path)) if os.path.exists(rec_path) else {}
    model = ["-mesh", a.deck, "-clamp", "*BOUNDARY", "-mesh_node_sets", "tip16,resp", "-mesh_node_set_tip16", TIP,
             "-mesh_node_set_resp", "1353", "-boundary", "tip16", "-nlrom_damping_modal", "0.005",
             "-nlrom_damping_modes", "50"]
    print("rubbing_rotor37: predicted cost about 5 min on 2 cores (2 reductions of 20 s, runs of 1 to 60 s)%s"
          % (", plus the nonlinear model (about 4 min) and its run (about 4 min)" if a.nonlinear else ""))
    for bm in ("massless", "carrying"):
        path = os.path.join(a.out, "rom_%s.h5" % bm)
        if not os.path.exists(path):
            print("rubbing_rotor37: nlrom %s" % bm, flush=True)
            rec["nlrom_%s_s" % bm] = run(["nlrom"] + model + ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", 50,
                                                              "-nlrom_forces", "none", "-nlrom_boundary_mass", bm,
                                                              "-out", path],
                                         os.path.join(a.out, "nlrom_%s.log" % bm), a.ranks)
    h_ml = 2 * math.pi / OMEGA / 1000
    runs = {}

    def simulate(name, rom, dt, every, extra=()):
        path = os.path.join(a.out, name + ".h5")
        log = os.path.join(a.out, name + ".log")
        if not os.path.exists(path):
            print("rubbing_rotor37: simulate %s (dt %.4g s)" % (name, dt), flush=True)
            rec[name + "_s"] = run(["simulate", "-rom", os.path.join(a.out, rom), "-sim_omega", OMEGA,
                                    "-sim_revolutions", REVS, "-sim_dt", repr(dt), "-sim_output_every", every,
                                    "-sim_monitor", "resp"] + CASING + list(extra) + ["-out", path], log)
        crit = [l for l in grep(log, "critical step")]
        rec[name + "_critical_step"] = float(crit[0].split("critical step")[1].split()[0]) if crit else None
        runs[name] = stats(path)

    simulate("massless", "rom_massless.h5", h_ml, 1, ["-sim_linear"])
    simulate("massless_fine", "rom_massless.h5", h_ml / 4, 4, ["-sim_linear"])
    # The mass-carrying critical step, from a refused run's message.
    log = os.path.join(a.out, "carrying_probe.log")
    subprocess.run([MORSE, "simulate", "-rom", os.path.join(a.out, "rom_carrying.h5"), "-sim_linear", "-sim_omega",
                    str(OMEGA), "-sim_revolutions", "1", "-sim_dt", "1"] + CASING + ["-out", os.path.join(a.out, "x.h5")],
                   stdout=open(log, "w"), stderr=subprocess.STDOUT)
    hc = float(grep(log, "critical step")[0].split("critical step")[1].split()[0])
    simulate("carrying", "rom_carrying.h5", 0.95 * hc, 50, ["-sim_linear"])
    simulate("carrying_fine", "rom_carrying.h5", 0.25 * hc, 200, ["-sim_linear"])
    if a.nonlinear:
        path = os.path.join(a.out, "rom_nonlinear.h5")
        if not os.path.exists(path):
            print("rubbing_rotor37: nlrom CB + MD massless, exact tensors", flush=True)
            rec["nlrom_nonlinear_s"] = run(
                ["nlrom"] + model[:-4] + ["-nlrom_damping_modal", "0.005", "-nlrom_damping_modes", "10",
                                          "-nlrom_basis", "cbmd", "-nlrom_num_fixed_modes", 10,
                                          "-nlrom_num_derivatives", 10, "-load_sets", "tip16", "-load_tip16_dir", "y",
                                          "-load_tip16_amplitude", 50, "-load_tip16_omega", 1960,
                                          "-nlrom_training_tfinal", 0.02, "-nlrom_forces", "exact",
                                          "-nlrom_boundary_mass", "massless", "-nlrom_massless_fmax", 5000,
                                          "-out", path],
                os.path.join(a.out, "nlrom_nonlinear.log"), a.ranks)
        simulate("nonlinear", "rom_nonlinear.h5", h_ml, 1)
        simulate("nonlinear_linear", "rom_nonlinear.h5", h_ml, 1, ["-sim_linear"])
    import numpy as np
    ref = runs["massless_fine"]
    T = 2 * math.pi / OMEGA
    tg = np.linspace((REVS - 5) * T, REVS * T, 5001)
    R = np.interp(tg, ref["t"], ref["uy"])
    summary = {}
    for name, s in runs.items():
        U = np.interp(tg, s["t"], s["uy"])
        summary[name] = {k: s[k] for k in ("mean", "min", "max", "std", "mean_force", "max_force")}
        summary[name]["l2_vs_massless_fine"] = float(np.linalg.norm(U - R) / np.linalg.norm(R - R.mean()))
        summary[name]["seconds"] = rec.get(name + "_s")
        summary[name]["critical_step"] = rec.get(name + "_critical_step")
        print("  %-18s u_y(1353) over the last 5 revolutions: mean %.4f, range [%.4f, %.4f], std %.4f mm; mean "
              "contact force %.0f N; history vs massless (dt/4) %.3f; %s s" %
              (name, s["mean"], s["min"], s["max"], s["std"], s["mean_force"],
               summary[name]["l2_vs_massless_fine"], rec.get(name + "_s")))
    rec["summary"] = summary
    rec["carrying_critical_step"] = hc
    rec["massless_step"] = h_ml
    with open(rec_path + ".tmp", "w") as f:
        json.dump(rec, f, indent=1)
    os.replace(rec_path + ".tmp", rec_path)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(2, 1, figsize=(9, 6))
        for name, st in (("carrying", "-"), ("massless", "--")):
            s = runs[name]
            for k, (lo, hi) in enumerate(((0, 5), (REVS - 5, REVS))):
                m = (s["t"] >= lo * T) & (s["t"] <= hi * T)
                ax[k].plot(s["t"][m] / T, s["uy"][m], st, lw=0.8, label=name)
        for k in range(2):
            ax[k].set_xlabel("revolution")
            ax[k].set_ylabel("u_y of node 1353 [mm]")
            ax[k].legend()
        fig.tight_layout()
        img = os.path.join(ROOT, "docs", "img", "rubbing_rotor37.png")
        fig.savefig(img + ".tmp.png", dpi=110)
        os.replace(img + ".tmp.png", img)
        print("rubbing_rotor37: wrote %s" % img)
    except Exception as e:  # the figure is optional
        print("rubbing_rotor37: no figure (%s)" % e)
    print("rubbing_rotor37: wrote %s" % rec_path)


if __name__ == "__main__":
    main()
