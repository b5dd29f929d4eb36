#!/usr/bin/python3
"""Odd engine orders on a two-lobe casing (docs/contact.md, "Odd engine orders: period doubling"):

    /usr/bin/python3 run/contact_odd_orders.py --map SWEEP.h5 [--f1 LO:HI] [--sim SIM.h5 ...] [--revs 4]

A casing of two lobes forces the blade with the period pi/|Omega| (half a revolution): its
steady responses hold the even engine orders only. An odd order k that persists is a response
of twice that period (period doubling). Its principal parametric resonance: the contact modulates
the blade's stiffness with the period pi/|Omega|, whose harmonic n (frequency 2 n |Omega|/2 pi) sets
the 1B into resonance at half that frequency when n |Omega| / 2 pi is the 1B line of the blade in
contact, f: odd n gives the odd order n.

--map: the speeds of a `morse sweep` file at which the largest odd order line exceeds 0.2 times
the largest even one (elsewhere their ratio is round-off), grouped in bands of one order, each with
the band the condition predicts for a 1B line between --f1 LO and HI [Hz].
--sim: `morse simulate` files (the first contact node's u_r, -sim_output_every small): the complex
amplitude of orders 1 to 6 over windows of --revs revolutions, so the growth of an odd order (an
instability, saturating on a limit cycle) is told from a decaying forced transient.
"""
import argparse
import math

import h5py
import numpy as np


def map_bands(path, f1):
    with h5py.File(path, "r") as f:
        w = np.abs(f["/sweep/omega"][:])
        o = np.argsort(w)
        w, eo, st = w[o], f["/sweep/order_amplitude"][:][o], f["/sweep/status"][:][o]
    ok = st == 0
    odd, even = np.nan_to_num(eo[:, 0::2], nan=0.0), np.nan_to_num(eo[:, 1::2], nan=0.0)
    k = 1 + 2 * np.argmax(odd, axis=1)
    ratio = odd.max(axis=1) / np.maximum(even.max(axis=1), 1e-300)
    print("%s: %d speeds; largest odd line over largest even one: median %.2g" % (path, w.size, np.median(ratio[ok])))
    hit = ok & (ratio > 0.2)
    for n in sorted(set(k[hit])):
        s = hit & (k == n)
        lo, hi = 2 * math.pi * f1[0] / n, 2 * math.pi * f1[1] / n
        i = np.argmax(np.where(s, odd.max(axis=1), 0))
        print("  eo%-2d at %d speeds, %.0f-%.0f rad/s (predicted %.0f-%.0f for a 1B at %.0f-%.0f Hz); largest "
              "%.3g mm at %.0f rad/s, line %.0f Hz" % (n, s.sum(), w[s].min(), w[s].max(), lo, hi, f1[0], f1[1],
                                                       1e3 * odd[i].max(), w[i], n * w[i] / (2 * math.pi)))
        inside = int(((w[s] >= lo * 0.99) & (w[s] <= hi * 1.01)).sum())
        print("      %d of the %d inside the predicted band (1 %% margin)" % (inside, s.sum()))


def sim_orders(path, revs):
    with h5py.File(path, "r") as f:
        t = f["/sim/time"][:]
        u = f["/sim/contact/radial_displacement"][:, 0]
        meta = f["/meta/options"][()].decode() if "/meta/options" in f else ""
    w = None
    for tok, nxt in zip(meta.split(), meta.split()[1:]):
        if tok == "-sim_omega":
            w = abs(float(nxt))
    if w is None:
        raise SystemExit("%s: no -sim_omega in /meta/options" % path)
    T = revs * 2 * math.pi / w
    print("%s: |Omega| %g rad/s, windows of %g revolutions; u_r of the first contact node, amplitude [mm] and "
          "phase [rad] of each order" % (path, w, revs))
    t0, rows = t[0], []
    while t0 + T <= t[-1] + 1e-12:
        m = (t >= t0) & (t < t0 + T)
        uu = u[m] - u[m].mean()
        rows.append((t0 + T / 2, [2 * np.mean(uu * np.exp(-1j * k * w * t[m])) for k in range(1, 7)]))
        t0 += T
    step = max(1, len(rows) // 10)
    for tm, a in rows[::step] + [rows[-1]]:
        print("  t %.3f s  " % tm + "  ".join("eo%d %.3g (%+.2f)" % (k + 1, 1e3 * abs(a[k]), np.angle(a[k]))
                                             for k in range(6)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--map", nargs="*", default=[])
    ap.add_argument("--f1", default="845:900", help="the 1B line of the blade in contact, LO:HI [Hz]")
    ap.add_argument("--sim", nargs="*", default=[])
    ap.add_argument("--revs", type=float, default=4.0)
    a = ap.parse_args()
    f1 = [float(x) for x in a.f1.split(":")]
    for p in a.map:
        map_bands(p, f1)
    for p in a.sim:
        sim_orders(p, a.revs)


if __name__ == "__main__":
    main()
