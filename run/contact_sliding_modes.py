#!/usr/bin/python3
"""The frequencies of a reduced blade model sliding on the casing (theory §10.7, docs/contact.md,
"Why the linear maps were not physical"):

    /usr/bin/python3 run/contact_sliding_modes.py [--rom out/contact_study/rom_r54.h5] [--mu 0.15]
                                                  [--sim SIM.h5 [SIM.h5 ...]]

For a set A of tip nodes held on the casing (n_k . u_k fixed) with friction forces -mu lambda_k
sign(Omega) e_theta, the motions q = Z y (Z: null space of the rows n_k^T B_k) obey
W^T M Z y'' + W^T C Z y' + W^T K Z y = 0, W the null space of the rows (n_k - mu sign(Omega)
e_theta,k)^T B_k (the unknown forces drop out). Prints, for both senses of rotation: the 1B with
each node held alone, with and without friction; the lowest 1B over the sets of two and three
nodes; the sets of 1, 2, 3, 4 and 8 nodes with a flutter (an eigenvalue with a positive real
part above 1/s), the worst with its frequency; and the ratio n.M^-1 d / n.M^-1 n of each node
(the contact compliance with friction over the one without: near 0 would jam).

With --sim (`morse simulate` files of the same model with -contact_set, output every step or
nearly): for each run, the contact states over its second half (the analysed half of a sweep): the
sets of nodes in contact (λ > 0) that hold 90 % of the time (at most 8), each with its share of the
time and of the normal impulse and the 1B of the blade held there with the run's mu and sign of
Omega and with mu = 0 (the empty set: the free 1B); the largest lines of the LE (first contact
node) radial displacement (Hann window); and the time-weighted mean of the held 1B over the states,
sum_i s_i f_i (s_i the share of state i, the states outside the 90 % counted at the free 1B), which
a blade that advances through each state's phase at that state's own frequency would oscillate at.
"""
import argparse
import collections
import itertools
import os
import sys

import h5py
import numpy as np
import scipy.linalg as sl

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def contact_states(path, bn, f_free, first_bending):
    """Print the contact states of a simulate run over its second half (see the docstring)."""
    with h5py.File(path, "r") as f:
        if "sim/contact/normal" not in f:
            sys.exit("contact_sliding_modes: %s: no /sim/contact (a `morse simulate` run with -contact_set)" % path)
        g = f["sim/contact"]
        lam, ids, ur = g["normal"][:], [int(x) for x in g["node_ids"][:]], g["radial_displacement"][:]
        mu, omega = float(g.attrs["mu"]), float(g.attrs["omega"])
        t = f["sim/time"][:]
    if sorted(ids) != sorted(int(x) for x in bn):
        sys.exit("contact_sliding_modes: %s: contact nodes %s are not the model's boundary nodes %s" % (path, ids, bn))
    h = t.size // 2
    L = lam[h:]
    sgn = 1.0 if omega >= 0 else -1.0
    keys = [tuple(ids[i] for i in np.flatnonzero(row > 0)) for row in L]  # each sample's set in contact
    states = collections.Counter(keys)
    n, imp = len(L), L.sum(0)
    print("%s: Omega %g rad/s, mu %g, %d samples over the second half; contact states holding 90 %% of it:"
          % (path, omega, mu, n))
    covered, mean_f = 0.0, 0.0
    for st, cnt in states.most_common(8):
        share = cnt / n
        nodes = list(st)
        fm = first_bending(nodes, mu, sgn) if nodes else f_free
        f0 = first_bending(nodes, 0.0, sgn) if nodes else f_free
        rows = [k for k, key in enumerate(keys) if key == st]
        ishare = L[rows].sum() / max(imp.sum(), 1e-300)
        print("  %-48s time %5.3f  impulse %5.3f  held 1B %7.1f Hz (mu = 0: %7.1f)" %
              (str(nodes) if nodes else "none (free)", share, ishare, fm, f0))
        covered += share
        mean_f += share * fm
        if covered >= 0.9:
            break
    mean_f += (1.0 - covered) * f_free
    y = ur[h:, 0] - ur[h:, 0].mean()
    win = np.hanning(y.size)
    A = 2 * np.abs(np.fft.rfft(y * win)) / win.sum()
    fr = np.fft.rfftfreq(y.size, t[1] - t[0])
    peaks = [k for k in range(1, A.size - 1) if A[k] >= A[k - 1] and A[k] > A[k + 1]]
    peaks = sorted(peaks, key=lambda k: -A[k])[:4]
    print("  node %d u_r: RMS %.3f mm; largest lines %s" % (ids[0], 1e3 * np.sqrt(np.mean(ur[h:, 0] ** 2)),
                                                         ", ".join("%.1f Hz %.3f mm" % (fr[k], 1e3 * A[k]) for k in peaks)))
    print("  time-weighted mean of the held 1B over the states: %.1f Hz (free 1B %.1f Hz)" % (mean_f, f_free))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rom", default=os.path.join(ROOT, "out", "contact_study", "rom_r54.h5"))
    ap.add_argument("--mu", type=float, default=0.15)
    ap.add_argument("--sim", nargs="*", default=[], help="simulate files whose contact states to analyse")
    ap.add_argument("--sim-only", action="store_true", help="with --sim: skip the tables of single nodes and sets")
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
    f_free = np.sqrt(w[0]) / (2 * np.pi)
    print("%s: r = %d, free 1B %.1f Hz, mu = %g, tip nodes %s" % (a.rom, r, f_free, a.mu, bn))
    for path in a.sim:
        contact_states(path, bn, f_free, first_bending)
    if a.sim and a.sim_only:
        return
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
