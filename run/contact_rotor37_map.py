#!/usr/bin/python3
"""The linear interaction map of the seed's own blade, the NASA rotor 37 deck of NLstep, with morse's
contact and friction (docs/contact.md, "Why the linear 1B responses sit below the free 1B"): does
friction soften the contact 1B of this blade as it does the embedded blade's?

    /usr/bin/python3 run/contact_rotor37_map.py [--deck ../shared/meshes/rotor37-nlstep/blade.inp]
        [--out out/rotor37_map] [--senses negative,positive] [--range 258:770:8] [--refine 1]
        [--revs 200] [--mu 0.15] [--ranks 1] [--sliding relative|rotation]

The deck is the seed's blade in NLstep's units (N, mm, t, s), 2.54 times larger; its free 1B is
312.1 Hz against the seed's 905.8 Hz. The study keeps the seed's set-up in the deck's scale:
  - model: linear Craig-Bampton, the 8 contact nodes of the seed (every other tip node of the deck:
    188, 192, 196, 200, 253, 257, 261, 265) as boundary (24 constraint modes) and 55 fixed-interface
    modes (r = 79, the seed's size), xi = 5e-4 on every mode, mass-scaled to 6.9 kHz (the maps'
    20 kHz times 312.1 / 905.8: the same modes moved as on the embedded blade's maps);
  - casing: the seed's, lengths times 2.54 (clearance 0.904 mm, bump 1.808 mm), 2 lobes, 99 % of
    the distortion at 20 % of the run; mu = --mu;
  - speeds: the seed's map range times 312.1 / 905.8 (258-755 rad/s covers the seed's
    750-2,190 rad/s), a coarse grid refined to --refine rad/s where neighbours differ, --revs
    revolutions per speed, step 0.5 of the critical step (2 digits); the monitor is node 188, the tip end at
    z = 68.6 mm, theta = -0.047 rad (node 267 is the other end; which one is the leading edge is not
    stated by the deck, so both senses of rotation are run).
For each sense it prints the RMS maxima with their dominant engine-order line (the largest of
/sweep/order_amplitude) and its frequency over the free 1B, and the share of the speeds above twice
the median RMS whose dominant line lies below the free 1B. The deck is read at run time only;
nothing of it is written outside --out. Skips with a notice when the deck is absent. About
10 minutes on one core.
"""
import argparse
import math
import os
import subprocess
import sys

import h5py
import numpy as np

from nlrom_study import env  # MPI settings for running as root, one thread per rank

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TIP8 = "188,192,196,200,253,257,261,265"
SCALE_F = 312.1 / 905.8  # the deck's free 1B over the seed's


def run(cmd, log, ranks):
    full = ["mpiexec", "--allow-run-as-root", "-n", str(ranks)] + [str(c) for c in cmd]
    with open(log, "w") as fh:
        res = subprocess.run(full, stdout=fh, stderr=subprocess.STDOUT, env=env())
    if res.returncode != 0:
        sys.exit("contact_rotor37_map: failed, see %s: %s" % (log, " ".join(full)))


def analyse(path, f1b):
    with h5py.File(path, "r") as f:
        w = np.abs(f["/sweep/omega"][:])
        o = np.argsort(w)
        w, rms = w[o], f["/sweep/rms"][:][o]  # the deck's unit, mm
        eo = f["/sweep/order_amplitude"][:][o]
        st = f["/sweep/status"][:][o]
    ok = st == 0
    k = 1 + np.argmax(np.nan_to_num(eo, nan=-1.0), axis=1)
    fr = k * w / (2 * math.pi)
    med = np.median(rms[ok])
    peaks = [i for i in range(w.size) if ok[i] and rms[i] > 1.3 * med and
             rms[i] == rms[ok & (np.abs(w - w[i]) <= 10.0)].max()]
    print("  %d speeds, %d failed; RMS median %.3g mm, largest %.3g mm at %g rad/s" %
          (w.size, int((~ok).sum()), med, rms[ok].max(), w[ok][np.argmax(rms[ok])]))
    for i in peaks:
        print("    %6.0f rad/s (seed scale %5.0f): RMS %.3g mm, dominant eo%d %.3g mm at %.1f Hz = %.3f x free 1B" %
              (w[i], w[i] / SCALE_F, rms[i], k[i], eo[i, k[i] - 1], fr[i], fr[i] / f1b))
    hi = ok & (rms > 2 * med)
    below = int((fr[hi] < f1b).sum())
    print("  speeds above twice the median RMS: %d, dominant line below the free 1B at %d of them" % (hi.sum(), below))
    return {"peaks": [(float(w[i]), float(rms[i]), int(k[i]), float(fr[i] / f1b)) for i in peaks],
            "high": int(hi.sum()), "high_below_1b": below}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck", default=os.path.join(ROOT, "..", "shared", "meshes", "rotor37-nlstep", "blade.inp"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "rotor37_map"))
    ap.add_argument("--senses", default="negative,positive")
    ap.add_argument("--range", default="258:770:8", help="coarse grid lo:hi:step [rad/s]")
    ap.add_argument("--refine", type=float, default=1.0, help="finest step [rad/s]; 0: no refinement")
    ap.add_argument("--revs", type=float, default=200.0)
    ap.add_argument("--mu", type=float, default=0.15)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "morse"))
    ap.add_argument("--sliding", default="relative", choices=["relative", "rotation"],
                    help="friction law (-contact_sliding): relative (Coulomb, the default) or rotation (the seed's)")
    a = ap.parse_args()
    if not os.path.exists(a.deck):
        print("contact_rotor37_map: NOTICE: %s is absent: skipped" % a.deck)
        return 0
    os.makedirs(a.out, exist_ok=True)
    rom = os.path.join(a.out, "cb79_ms6900.h5")
    if not os.path.exists(rom):
        run([a.binary, "nlrom", "-mesh", a.deck, "-clamp", "*BOUNDARY", "-mesh_node_sets", "tip8,le",
             "-mesh_node_set_tip8", TIP8, "-mesh_node_set_le", "188", "-boundary", "tip8", "-nlrom_basis", "cb",
             "-nlrom_num_fixed_modes", 55, "-nlrom_forces", "none", "-nlrom_damping_modal", "5e-4",
             "-nlrom_damping_modes", "all", "-nlrom_mass_scaling_fmax", 6900, "-out", rom],
            os.path.join(a.out, "nlrom.log"), a.ranks)
    with h5py.File(rom, "r") as f:
        K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    f1b = math.sqrt(w2[0]) / (2 * math.pi)
    hcrit = 2.0 / math.sqrt(w2[-1])
    print("rotor 37 deck, CB r = %d: free 1B %.1f Hz, critical step %.3g s" % (K.shape[0], f1b, hcrit))
    lo, hi, step = (float(x) for x in a.range.split(":"))
    for sense in a.senses.split(","):
        path = os.path.join(a.out, "map_%s_mu%g_%s.h5" % (sense, a.mu, a.sliding))
        if not os.path.exists(path + ".done"):
            run([a.binary, "sweep", "-rom", rom, "-out", path, "-sweep_omega_min", lo, "-sweep_omega_max", hi,
                 "-sweep_omega_step", step, "-sim_revolutions", a.revs, "-sim_dt", "%.2g" % (0.5 * hcrit),
                 "-sweep_rotation", sense, "-sim_linear", "-contact_set", "tip8", "-contact_mu", a.mu,
                 "-casing_clearance", 0.904, "-casing_bump_height", 1.808, "-casing_lobes", 2, "-sweep_monitor",
                 "le", "-contact_sliding", a.sliding] + (["-sweep_refine_step", a.refine] if a.refine > 0 else []),
                path + ".log", a.ranks)
            open(path + ".done", "w").close()
        print("Omega %s 0, mu = %g (%s):" % ("<" if sense == "negative" else ">", a.mu, path))
        analyse(path, f1b)
    return 0


if __name__ == "__main__":
    sys.exit(main())
