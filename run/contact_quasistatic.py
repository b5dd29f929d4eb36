#!/usr/bin/python3
"""What a rigid casing imposes on a blade held statically against it, beside what contact runs
give (docs/contact.md, "The size of the contact forces"):

    /usr/bin/python3 run/contact_quasistatic.py --rom ROM.h5 [--sim RUN.h5 ...]
        [--clearance 3.56e-4] [--bump-height 2*clearance] [--width 0.15] [--lobes 2]
        [--from-revolution 100]

The quasi-static reference: the radial stiffness S of the contact nodes (the reduced model's
boundary stiffness K_bb, Craig-Bampton's static condensation of the interior, with every
boundary direction but the radial ones free), and, at 4,000 positions of the casing over one
lobe, the contact of the nodes with the casing's interference i_k (seed eq. 52-53 at full
distortion) as a linear complementarity problem: u_r >= -i (no penetration), p >= 0 (the casing
pushes), p (u_r + i) = 0, with u_r = -S^-1 p, solved by projected Gauss-Seidel. Prints the
stiffness, then the total normal force over a revolution (mean and peak) and the time in contact.
Then every contact node held together at the full interference h_b - c0 (a static solve of the
whole reduced model, K~ q = sum_k lambda_k d_k with n_k . u_k = -(h_b - c0)), without friction and
with --mu along each sense of sliding (d_k = n_k - mu sign(Omega) e_theta,k, the casing's sliding
direction at rest): the total normal force and the largest tangential displacement of a node, the
static size of what friction does to a linear blade pressed by the interference.

For each --sim file (a `morse simulate` run of the same model; its casing options are read from
/meta/options): the total normal force (mean and peak) after --from-revolution against the
quasi-static one, and the largest radial and off-radial displacement of each contact node, to
tell the global motion of the tip (all nodes alike) from a local one (the corners).
"""
import argparse
import math
import shlex

import h5py
import numpy as np


def model_nodes(rom):
    """K~ of a reduced model and the reference positions (n x 3) of its n boundary (contact) nodes."""
    with h5py.File(rom, "r") as f:
        K = f["/nlrom/K"][()]
        bnodes = f["/nlrom/boundary_nodes"][()]
        ids = f["/mesh/node_ids"][()]
        X = f["/mesh/coordinates"][()]
    where = {int(v): k for k, v in enumerate(ids)}
    return K, X[[where[int(b)] for b in bnodes]]


def radial_stiffness(K, xyz):
    """S (n x n) and the node angles of the n contact nodes of a CB reduced model."""
    n = len(xyz)
    Kbb = K[: 3 * n, : 3 * n]
    r = np.hypot(xyz[:, 0], xyz[:, 1])
    R = np.zeros((3 * n, n))
    for a in range(n):
        R[3 * a, a] = xyz[a, 0] / r[a]
        R[3 * a + 1, a] = xyz[a, 1] / r[a]
    T = np.linalg.qr(R, mode="complete")[0][:, n:]
    A, B, C = R.T @ Kbb @ R, R.T @ Kbb @ T, T.T @ Kbb @ T
    S = A - B @ np.linalg.solve(C, B.T)
    return S, np.arctan2(xyz[:, 1], xyz[:, 0])


def held_with_friction(K, xyz, depth, mu, sgn):
    """Every contact node held at u_r = -depth, friction mu along sgn e_theta: returns the total
    normal force [N] and the largest tangential displacement of a node [m] (whole reduced model)."""
    n, r = len(xyz), K.shape[0]
    rho = np.hypot(xyz[:, 0], xyz[:, 1])
    er = np.stack([xyz[:, 0] / rho, xyz[:, 1] / rho, 0 * rho], 1)
    et = np.stack([-xyz[:, 1] / rho, xyz[:, 0] / rho, 0 * rho], 1)
    G, D = np.zeros((n, r)), np.zeros((r, n))
    for a in range(n):
        G[a, 3 * a:3 * a + 3] = er[a]
        D[3 * a:3 * a + 3, a] = -er[a] - mu * sgn * et[a]  # the force on the node per unit lambda
    sol = np.linalg.solve(np.block([[K, -D], [G, np.zeros((n, n))]]), np.concatenate([np.zeros(r), -depth * np.ones(n)]))
    ub = sol[:3 * n].reshape(n, 3)
    tang = ub - np.einsum("kd,kd->k", ub, er)[:, None] * er
    return sol[r:].sum(), np.linalg.norm(tang, axis=1).max()


def interference(theta, clearance, height, width, lobes):
    period = 2 * math.pi / lobes
    x = np.mod(theta, period) - period / 2
    return height * np.exp(-((x / width) ** 2)) - clearance


def quasi_static(S, theta, clearance, height, width, lobes, positions=4000):
    F = np.linalg.inv(S)  # radial flexibility
    n = len(theta)
    total = []
    for phi in np.linspace(0.0, 2 * math.pi / lobes, positions, endpoint=False):
        i = interference(theta + phi, clearance, height, width, lobes)
        p = np.zeros(n)
        if (i > 0).any():
            for _ in range(5000):
                old = p.copy()
                for a in range(n):
                    p[a] = max(0.0, p[a] - (F[a] @ p - i[a]) / F[a, a])
                if np.abs(p - old).max() <= 1e-12 * max(p.max(), 1.0):
                    break
        total.append(p.sum())
    return np.array(total)


def casing_of(sim, defaults):
    c = dict(defaults)
    with h5py.File(sim, "r") as f:
        opts = shlex.split(f["/meta/options"][()].decode())
    for k, v in zip(opts, opts[1:]):
        if k == "-casing_clearance":
            c["clearance"] = float(v)
        elif k == "-casing_bump_height":
            c["height"] = float(v)
        elif k == "-casing_width":
            c["width"] = float(v)
        elif k == "-casing_lobes":
            c["lobes"] = int(v)
        elif k == "-sim_omega":
            c["omega"] = float(v)
        elif k == "-contact_mu":
            c["mu"] = float(v)
    return c


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rom", required=True)
    ap.add_argument("--sim", nargs="*", default=[])
    ap.add_argument("--clearance", type=float, default=3.56e-4)
    ap.add_argument("--bump-height", type=float, default=None)
    ap.add_argument("--width", type=float, default=0.15)
    ap.add_argument("--lobes", type=int, default=2)
    ap.add_argument("--from-revolution", type=float, default=100.0)
    ap.add_argument("--mu", type=float, default=0.15, help="friction of the held case (default 0.15)")
    a = ap.parse_args()
    height = a.bump_height if a.bump_height is not None else 2 * a.clearance

    K, xyz = model_nodes(a.rom)
    S, theta = radial_stiffness(K, xyz)
    one = np.ones(len(theta))
    print(f"{a.rom}: {len(theta)} contact nodes")
    print("  radial stiffness of each node, the others free [N/m]:", " ".join(f"{1 / v:.2e}" for v in np.diag(np.linalg.inv(S))))
    print(f"  all nodes pressed together: {one @ S @ one:.3e} N/m")
    qs = quasi_static(S, theta, a.clearance, height, a.width, a.lobes)
    print(
        f"  quasi-static, casing c0 = {a.clearance * 1e3:.3f} mm, h_b = {height * 1e3:.3f} mm, {a.lobes} lobes of "
        f"{a.width} rad: total normal force mean {qs.mean() / 1e3:.2f} kN, peak {qs.max() / 1e3:.2f} kN, in "
        f"contact {100 * (qs > 0).mean():.1f} % of a revolution"
    )
    depth = height - a.clearance
    for mu, sgn, label in [(0.0, 1.0, "no friction"), (a.mu, 1.0, f"mu = {a.mu:g}, Omega > 0"),
                           (a.mu, -1.0, f"mu = {a.mu:g}, Omega < 0")]:
        lam, ut = held_with_friction(K, xyz, depth, mu, sgn)
        print(f"  every node held {depth * 1e3:.3f} mm inside, {label}: total normal force {lam / 1e3:.1f} kN, "
              f"largest tangential displacement of a node {ut * 1e3:.2f} mm")
    defaults = dict(clearance=a.clearance, height=None, width=a.width, lobes=a.lobes, omega=float("nan"), mu=float("nan"))
    for sim in a.sim:
        c = casing_of(sim, defaults)
        h = c["height"] if c["height"] is not None else 2 * c["clearance"]
        ref = quasi_static(S, theta, c["clearance"], h, c["width"], c["lobes"])
        with h5py.File(sim, "r") as f:
            t = f["/sim/time"][()]
            N = f["/sim/contact/normal"][()].sum(axis=1)
            q = f["/sim/q"][()][:, : 3 * len(theta)].reshape(len(t), len(theta), 3)
            normals = f["/sim/contact/normals"][()]
        m = t >= a.from_revolution * 2 * math.pi / abs(c["omega"])
        if not m.any():
            m = t >= t[len(t) // 2]
        ur = np.einsum("tnk,nk->tn", q[m], normals)
        off = np.linalg.norm(q[m] - ur[:, :, None] * normals[None], axis=2)
        print(
            f"{sim}: Omega {c['omega']:g} rad/s, mu {c['mu']:g}, from t = {t[m][0]:.3f} s: total normal force mean "
            f"{N[m].mean() / 1e3:.2f} kN ({N[m].mean() / ref.mean():.1f} x quasi-static), peak {N[m].max() / 1e3:.1f} kN "
            f"({N[m].max() / ref.max():.1f} x)"
        )
        print("  largest radial displacement per node [mm]:    ", " ".join(f"{v:6.2f}" for v in np.abs(ur).max(0) * 1e3))
        print("  largest off-radial displacement per node [mm]:", " ".join(f"{v:6.2f}" for v in off.max(0) * 1e3))


if __name__ == "__main__":
    main()
