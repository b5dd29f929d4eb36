#!/usr/bin/python3
"""The blade's first frequencies with its contact nodes free, held radially (sliding on the
casing) and held in every direction (stuck), for the embedded blades and the NASA rotor 37 deck
(docs/contact.md, "Where morse differs": the nonlinear 1B/eo8 band above the seed's):

    /usr/bin/python3 run/contact_held_modes.py [--out out/held_modes] [--deck ../shared/meshes/rotor37-nlstep/blade.inp]
        [--fixed 20] [--ranks 1]

For each blade it builds a linear Craig-Bampton model with `morse nlrom -nlrom_basis cb
-nlrom_forces none` whose boundary is the contact nodes (the constraint modes come first, so the
boundary coordinates are the nodes' x, y, z), then solves, in that basis:
  - free:           K q = w^2 M q;
  - radially held:  the same with e_r . u = 0 at every contact node (e_r the node's radial unit
                    vector about z: a node sliding on the casing), by the null space of the
                    constraints (Rayleigh-Ritz in the CB basis: an upper bound);
  - stuck:          every boundary coordinate held (exactly the fixed-interface modes).
and prints the first four frequencies and their ratios to the free 1B. The ratios do not depend
on the deck's units or scale (the rotor 37 deck is the seed's blade scaled by 2.54, in mm).

Blades: meshes/blade.msh (60k, the maps' blade), meshes/blade_coarse.msh, and the rotor 37 deck
(skipped with a notice when absent) with its 16 contact nodes and with 8 of them (every other one,
the seed's count). Nothing of the deck is written outside --out. About 1.5 minutes on one core.
"""
import argparse
import json
import os
import subprocess
import sys

import h5py
import numpy as np
import scipy.linalg as sl

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TIP16 = "188,190,192,194,196,198,200,203,253,255,257,259,261,263,265,267"
TIP8 = "188,192,196,200,253,257,261,265"


def held_frequencies(rom):
    """(free, radially held, stuck) frequencies [Hz] of a CB model whose boundary is the contact nodes."""
    with h5py.File(rom, "r") as f:
        K, M = f["/nlrom/K"][()], f["/nlrom/M"][()]
        bd = f["/nlrom/boundary_dofs"][()]
        ids, X = f["/mesh/node_ids"][()], f["/mesh/coordinates"][()]
        V0 = f["/nlrom/basis"][: len(bd)]
    pos = {int(n): i for i, n in enumerate(ids)}
    for k, (n, c) in enumerate(bd):  # coordinate k is the displacement of its boundary DOF
        if abs(V0[k, pos[int(n)], c - 1] - 1.0) > 1e-8:
            sys.exit("contact_held_modes: %s: column %d is not the unit displacement of node %d, component %d"
                     % (rom, k, n, c))
    nodes = sorted({int(n) for n, _ in bd})
    C = np.zeros((len(nodes), K.shape[0]))
    for i, n in enumerate(nodes):
        x = X[pos[n]]
        er = np.array([x[0], x[1], 0.0]) / np.hypot(x[0], x[1])
        for k, (m, c) in enumerate(bd):
            if int(m) == n:
                C[i, k] = er[c - 1]

    def freqs(Z):
        w = sl.eigh(Z.T @ K @ Z, Z.T @ M @ Z, eigvals_only=True)
        return np.sqrt(np.maximum(w, 0.0)) / (2 * np.pi)

    r = K.shape[0]
    return len(nodes), freqs(np.eye(r)), freqs(sl.null_space(C)), freqs(np.eye(r)[:, len(bd):])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(ROOT, "out", "held_modes"))
    ap.add_argument("--deck", default=os.path.join(ROOT, "..", "shared", "meshes", "rotor37-nlstep", "blade.inp"))
    ap.add_argument("--fixed", type=int, default=20, help="fixed-interface modes of each CB model")
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "morse"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    cases = [("blade (60k)", ["-mesh", os.path.join(ROOT, "meshes", "blade.msh"), "-clamp", "root", "-boundary", "tip"]),
             ("blade_coarse", ["-mesh", os.path.join(ROOT, "meshes", "blade_coarse.msh"), "-clamp", "root",
                               "-boundary", "tip"])]
    if os.path.exists(a.deck):
        deck = ["-mesh", a.deck, "-clamp", "*BOUNDARY", "-mesh_node_sets", "tip16,tip8", "-mesh_node_set_tip16", TIP16,
                "-mesh_node_set_tip8", TIP8]
        cases += [("rotor 37, 16 nodes", deck + ["-boundary", "tip16"]), ("rotor 37, 8 nodes", deck + ["-boundary", "tip8"])]
    else:
        print("contact_held_modes: NOTICE: %s is absent: rotor 37 skipped" % a.deck)
    rec = {}
    for name, model in cases:
        rom = os.path.join(a.out, "cb_%s.h5" % "".join(ch if ch.isalnum() else "_" for ch in name))
        if not os.path.exists(rom):
            cmd = ["mpiexec", "--allow-run-as-root", "-n", str(a.ranks), a.binary, "nlrom"] + model + \
                ["-nlrom_basis", "cb", "-nlrom_num_fixed_modes", str(a.fixed), "-nlrom_forces", "none", "-out", rom]
            res = subprocess.run(cmd, capture_output=True, text=True)
            if res.returncode != 0:
                sys.exit("contact_held_modes: morse nlrom failed for %s:\n%s" % (name, res.stdout[-2000:] + res.stderr[-2000:]))
        n, free, radial, stuck = held_frequencies(rom)
        print("%s: %d contact nodes, r = %d" % (name, n, free.size))
        rec[name] = {"contact_nodes": n}
        for tag, f in (("free", free), ("radially held", radial), ("stuck", stuck)):
            print("  %-14s %s Hz;  / free 1B: %s" % (tag, " ".join("%8.1f" % x for x in f[:4]),
                                                     " ".join("%.3f" % (x / free[0]) for x in f[:4])))
            rec[name][tag] = [float(x) for x in f[:4]]
    with open(os.path.join(a.out, "held_modes.json"), "w") as fh:
        json.dump(rec, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
