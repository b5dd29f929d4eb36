#!/usr/bin/python3
"""The frequencies of a reduced blade model sliding on the casing (theory §10.7, docs/contact.md,
"Why the linear maps were not physical"):

    /usr/bin/python3 run/contact_sliding_modes.py [--rom out/contact_study/rom_r54.h5] [--mu 0.15]

For a set A of tip nodes held on the casing (n_k . u_k fixed) with friction forces -mu lambda_k
sign(Omega) e_theta, the motions q = Z y (Z: null space of the rows n_k^T B_k) obey
W^T M Z y'' + W^T C Z y' + W^T K Z y = 0, W the null space of the rows (n_k - mu sign(Omega)
e_theta,k)^T B_k (the unknown forces drop out). Prints, for both senses of rotation: the 1B with
each node held alone, with and without friction; the lowest 1B over the sets of two and three
nodes; the sets of 1, 2, 3, 4 and 8 nodes with a flutter (an eigenvalue with a positive real
part above 1/s), the worst with its frequency; and the ratio n.M^-1 d / n.M^-1 n of each node
(the contact compliance with friction over the one without: near 0 would jam).
"""
import argparse
import itertools
import os

import h5py
import numpy as np
import scipy.linalg as sl

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rom", default=os.path.join(ROOT, "out", "contact_study", "rom_r54.h5"))
    ap.add_argument("--mu", type=float, default=0.15)
    a = ap.parse_args()
    with h5py.File(a.rom, "r") as f:
        K, M, C = f["nlrom/K"][:], f["nlrom/M"][:], f["nlrom/C"][:]
        ids = list(f["mesh/node_ids"][:])
        X, V, bn = f["mesh/coordinates"][:], f["nlrom/basis"][:], list(f["nlrom/boundary_nodes"][:])
    r = K.shape[0]
    dof, pos = {}, {}
    for nid in bn:  # the boundary coordinate of u_x of each node: its basis column is 1 there
        j = ids.index(nid)
        pos[nid] = X[j]
        dof[nid] = next(c for c in range(r) if abs(V[c, j, 0] - 1) < 1e-9)

    def directions(nid, sgn):
        x = pos[nid]
        rho = np.hypot(x[0], x[1])
        return np.array([-x[0] / rho, -x[1] / rho, 0.0]), sgn * np.array([-x[1] / rho, x[0] / rho, 0.0])

    def pencil(nodes, mu, sgn):
        N, D = np.zeros((len(nodes), r)), np.zeros((len(nodes), r))
        for i, nid in enumerate(nodes):
            n, t = directions(nid, sgn)
            N[i, dof[nid]:dof[nid] + 3], D[i, dof[nid]:dof[nid] + 3] = n, n - mu * t
        Z, W = sl.null_space(N), sl.null_space(D)
        return W.T @ M @ Z, W.T @ C @ Z, W.T @ K @ Z

    def first_bending(nodes, mu, sgn):
        Mr, _, Kr = pencil(nodes, mu, sgn)
        ev = np.linalg.eigvals(np.linalg.solve(Mr, Kr))
        return np.sqrt(ev[np.argmin(ev.real)].astype(complex)).real / (2 * np.pi)

    def growth(nodes, mu, sgn):
        Mr, Cr, Kr = pencil(nodes, mu, sgn)
        m = Mr.shape[0]
        A = np.block([[np.zeros((m, m)), np.eye(m)], [-np.linalg.solve(Mr, Kr), -np.linalg.solve(Mr, Cr)]])
        ev = np.linalg.eigvals(A)
        k = np.argmax(ev.real)
        return ev[k].real, abs(ev[k].imag) / (2 * np.pi)

    w = np.sort(sl.eigh(K, M, eigvals_only=True))
    print("%s: r = %d, free 1B %.1f Hz, mu = %g, tip nodes %s" % (a.rom, r, np.sqrt(w[0]) / (2 * np.pi), a.mu, bn))
    Mi = np.linalg.inv(M)
    for sgn in (1.0, -1.0):
        print("Omega %s 0:" % (">" if sgn > 0 else "<"))
        print("  1B, one node held, mu = 0 [Hz]:    ", " ".join("%.1f" % first_bending([n], 0.0, sgn) for n in bn))
        print("  1B, one node held, mu = %g [Hz]: " % a.mu,
              " ".join("%.1f" % first_bending([n], a.mu, sgn) for n in bn))
        print("  1B, all held, mu = 0 / %g: %.1f / %.1f Hz" % (a.mu, first_bending(bn, 0.0, sgn),
                                                              first_bending(bn, a.mu, sgn)))
        low = min((first_bending(list(s), a.mu, sgn), s) for k in (2, 3) for s in itertools.combinations(bn, k))
        print("  lowest 1B over the sets of 2 and 3 nodes: %.1f Hz %s" % (low[0], low[1]))
        for k in (1, 2, 3, 4, len(bn)):
            res = sorted(((growth(list(s), a.mu, sgn), s) for s in itertools.combinations(bn, k)), reverse=True)
            bad = sum(1 for (g, _), _ in res if g > 1.0)
            (g, f), s = res[0]
            print("  %d node(s) sliding: %d of %d sets flutter; worst %.3g 1/s at %.0f Hz %s" % (k, bad, len(res), g,
                                                                                           f, s))
        ratios = []
        for nid in bn:
            n, t = directions(nid, sgn)
            B = Mi[dof[nid]:dof[nid] + 3, dof[nid]:dof[nid] + 3]
            ratios.append(n @ B @ (n - a.mu * t) / (n @ B @ n))
        print("  n.M^-1 d / n.M^-1 n per node: %s" % " ".join("%.3f" % x for x in ratios))
    worst0 = max(growth(bn, 0.0, 1.0)[0], max(growth([n], 0.0, 1.0)[0] for n in bn))
    print("mu = 0: largest real part with all or one node held: %.3g 1/s" % worst0)


if __name__ == "__main__":
    main()
