#!/usr/bin/python3
"""Where the energy of a reduced contact run sits, mode by mode (docs/contact.md, issue 28):

    /usr/bin/python3 run/contact_energy_modes.py --sim SIM.h5 [SIM.h5 ...] [--top 8]

For a `morse simulate` file (written with -sim_output_every small enough to resolve the modes it
asks about) and the reduced model it names (`/sim@rom`, or --rom), the eigenpairs (omega_i, phi_i)
of (K~, M~), M~-orthonormal, give the modal coordinates eta = Phi^T M~ q and the energy of each
mode, E_i = eta_i'^2 / 2 + omega_i^2 eta_i^2 / 2 (eta' by central differences of the output; the
sum of the E_i is the quadratic energy of eq. 46 that `/sim/energy` holds, which the script
checks). Prints, for each run: the largest energy and its time, the modes holding 99 % of the
energy averaged over the second half with their frequency and share, the same at the time of the
largest energy, and the largest |u| of each boundary (contact) node from the first n_b coordinates
against the largest radial displacement of the contact nodes. Linear energy only: for a nonlinear
run V(q) is not included (the script says so).
"""
import argparse
import os
import sys

import h5py
import numpy as np
import scipy.linalg as sl


def model(rom):
    with h5py.File(rom, "r") as f:
        g = f["nlrom"]
        M, K = g["M"][:], g["K"][:]
        nb = int(g.attrs["n_boundary_dofs"]) if "n_boundary_dofs" in g.attrs else 0
        mass = g.attrs.get("boundary_mass", b"carrying")
        mass = mass.decode() if isinstance(mass, bytes) else mass
    if mass != "carrying":
        sys.exit("contact_energy_modes: %s: a %s boundary (M~ singular): not handled" % (rom, mass))
    return M, K, nb


def analyse(path, rom_arg, top):
    with h5py.File(path, "r") as f:
        if "sim/q" not in f:
            sys.exit("contact_energy_modes: %s: no /sim/q (a `morse simulate` file)" % path)
        q, t = f["sim/q"][:], f["sim/time"][:]
        e_file = f["sim/energy"][:] if "sim/energy" in f else None
        rom = rom_arg or f["sim"].attrs.get("rom")
        if isinstance(rom, bytes):
            rom = rom.decode()
        linear = bool(f["sim"].attrs.get("linear", 1))
        ur = f["sim/contact/radial_displacement"][:] if "sim/contact/radial_displacement" in f else None
    if not rom or not os.path.exists(rom):
        sys.exit("contact_energy_modes: %s: its model %r is not on disk (give --rom)" % (path, rom))
    M, K, nb = model(rom)
    if M.shape[0] != q.shape[1]:
        sys.exit("contact_energy_modes: %s has %d coordinates, %s has %d" % (path, q.shape[1], rom, M.shape[0]))
    w2, Phi = sl.eigh(K, M)
    w = np.sqrt(np.maximum(w2, 0.0))
    fhz = w / (2 * np.pi)
    eta = q @ (M @ Phi)  # (n_out, r)
    dt = np.diff(t)
    if not np.allclose(dt, dt[0], rtol=1e-9):
        sys.exit("contact_energy_modes: %s: output times not uniform" % path)
    dt = dt[0]
    etad = np.gradient(eta, dt, axis=0)
    E = 0.5 * etad**2 + 0.5 * w2[None, :] * eta**2
    Et = E.sum(1)
    print("%s (model %s, r = %d, output every %.3g s, %d samples)%s" %
          (path, rom, q.shape[1], dt, t.size, "" if linear else "  [nonlinear: V(q) not counted]"))
    if e_file is not None:
        rel = np.max(np.abs(Et - e_file)) / max(np.max(np.abs(e_file)), 1e-300)
        print("  check: sum of the modal energies against /sim/energy: largest difference %.2e of its largest" % rel)
    k = int(np.argmax(Et))
    h = t.size // 2
    Em = E[h:].mean(0)
    print("  largest energy %.4g J at t = %.4g s; mean over the second half %.4g J" % (Et[k], t[k], Em.sum()))

    def table(shares, label):
        order = np.argsort(shares)[::-1]
        acc = 0.0
        print("  %s:" % label)
        print("    %5s %10s %8s" % ("mode", "f [Hz]", "share"))
        for n, i in enumerate(order):
            print("    %5d %10.1f %7.2f%%" % (i + 1, fhz[i], 100 * shares[i]))
            acc += shares[i]
            if acc >= 0.99 or n + 1 >= top:
                break
        # energy by frequency band
        bands = [(0, 2000), (2000, 5000), (5000, 15000), (15000, np.inf)]
        s = ", ".join("%g-%g Hz %.1f%%" % (a, b, 100 * shares[(fhz >= a) & (fhz < b)].sum()) for a, b in bands)
        print("    by band: %s" % s)

    table(Em / Em.sum(), "modes holding the second half's mean energy")
    table(E[k] / E[k].sum(), "modes at the largest energy")
    if ur is not None:
        print("  contact nodes: largest |u_r| %.4g mm; RMS over the second half %s mm" %
              (1e3 * np.max(np.abs(ur)), " ".join("%.3g" % (1e3 * np.sqrt(np.mean(ur[h:, j]**2)))
                                                  for j in range(ur.shape[1]))))
    if nb >= 3 and nb % 3 == 0:
        ub = q[:, :nb].reshape(t.size, nb // 3, 3)
        mag = np.linalg.norm(ub, axis=2)
        print("  boundary nodes (the first %d coordinates): largest |u| %s mm; RMS |u| over the second half %s mm"
              % (nb, " ".join("%.3g" % (1e3 * x) for x in mag.max(0)),
                 " ".join("%.3g" % (1e3 * np.sqrt(np.mean(mag[h:, j]**2))) for j in range(nb // 3))))
    return fhz, Em


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sim", nargs="+", required=True)
    ap.add_argument("--rom", default=None, help="the reduced model (default: the one the file names)")
    ap.add_argument("--top", type=int, default=8)
    a = ap.parse_args()
    for p in a.sim:
        analyse(p, a.rom, a.top)


if __name__ == "__main__":
    main()
