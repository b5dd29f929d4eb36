#!/usr/bin/env bash
# Case chain of a Nastran deck with a rigid spider (tests/data/spider_beam.bdf: a 4x1x1 CHEXA
# cantilever, RBE2 100 from grid 9001 at the tip centre to the four tip grids, a 1.5 kg CONM2 on
# 9001, ASET1 123456 9001):
#  - mesh info reports the constraints;
#  - modes: the constraints are eliminated (4 grids x 3 translations), the model's mass is the
#    steel's 7.8 kg plus the CONM2's 1.5 kg;
#  - reduce with the point as the boundary (-boundary ASET): six boundary DOFs, node 9001
#    components 1..6; its free-DOF K, M and DOF map (-matrices_write) hold the point's six rows,
#    and reduce from those matrices gives the same superelement (the matrix path takes 6-DOF
#    labels);
#  - select on the constrained deck, and without the full-model check (-select_check false: the
#    same selection, no MAC);
#  - export: the MBDyn node 9001 at (0.4, 0.025, 0.025);
#  - nlrom on the constrained deck (CB + modal derivatives weighted by a training load, exact
#    tensors; boundary: the solid nodes at x = 0.3): its stored basis is expanded through the spider (in every column the tip grids
#    5, 10, 15, 20 move as one rigid body, as RBE2 100 makes them), and its lowest frequency bounds
#    the model's from above within 1 %;
#  - nlrom with the six-DOF point as its boundary (below: rigid constraint modes, the frequency
#    bound, a large tip load against the full nonlinear static solution);
#  - static (linear) with loads on the four dependent tip grids: their mean displacement is the
#    point's translation from the superelement's static condensation K_bb^-1 F;
#  - fom (linear) under the load applied suddenly: mean tip displacement over 10 periods = the
#    static one, peak at most twice it, the tip grids rigid in every snapshot;
#  - nlrom POD (and CB with POD filtering) from those snapshots, on the point (below);
#  - fom -load_history and -fom_initial on the deck (below);
#  - stress -fom of a snapshot of that run against an independent hex8 evaluation (below);
#  - bad input: a dependent
#    grid that is also clamped, and a circular MPC, fail naming the card and the grid; no file is
#    left.
# usage: case_constraints_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
deck=$(dirname "$0")/data/spider_beam.bdf
out=$(run modes -mesh "$deck" -clamp '*BOUNDARY' -modes_nev 4 -out "$d/modes.h5" 2>&1)
grep -q "constraints: 1 rigid element, 0 interpolation elements, 0 linear constraints, 1 six-DOF point; 12 DOF(s) eliminated, 6 point DOF(s) kept" <<<"$out" || { echo "$out"; exit 1; }
grep -q "mass 9.3$" <<<"$out" || { echo "mass: $out"; exit 1; }
info=$(run mesh info -mesh "$deck" 2>&1)
grep -q "constraints: 1 rigid element, 0 interpolation elements, 0 linear constraints, 1 six-DOF point" <<<"$info" ||
  { echo "mesh info: $info"; exit 1; }
cb=(-clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 4)
run reduce -mesh "$deck" "${cb[@]}" -matrices_write "$d/spider" -out "$d/se.h5"
run reduce -matrices_K "$d/spider_K.mtx" -matrices_M "$d/spider_M.mtx" -matrices_dofmap "$d/spider_dofmap.txt" \
  -boundary ASET -cb_num_fixed_modes 4 -out "$d/se_mtx.h5"
run select -mesh "$deck" -clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 8 -select_method eim \
  -select_num_modes 3 -out "$d/sel.h5"
run select -mesh "$deck" -clamp '*BOUNDARY' -boundary ASET -cb_num_fixed_modes 8 -select_method eim \
  -select_num_modes 3 -select_check false -out "$d/sel_nocheck.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py
d = sys.argv[1]
a, b = h5py.File(f"{d}/sel.h5", "r"), h5py.File(f"{d}/sel_nocheck.h5", "r")
assert a["/select"].attrs["checked"] == 1 and b["/select"].attrs["checked"] == 0
assert "/select/fom" in a and "/select/fom" not in b and "mac" not in b["/select/eim"]
assert (a["/select/eim/selected"][:] == b["/select/eim/selected"][:]).all()
PY
run export -export_from "$d/se.h5" -export_format mbdyn,dmig -out "$d/se"
grep -A1 "RECORD GROUP 2" "$d/se.fem" | grep -q "^9001$"
grep -A1 "RECORD GROUP 5" "$d/se.fem" | grep -q "^0.4"
grep -q "point_rows_ok" < <(grep -c "^9001 " "$d/spider_dofmap.txt" | sed 's/^6$/point_rows_ok/')
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
a, b = h5py.File(f"{d}/se.h5", "r"), h5py.File(f"{d}/se_mtx.h5", "r")
bd = a["/rom/boundary_dofs"][:]
assert bd.tolist() == [[9001, c] for c in range(1, 7)], bd
# The modes' signs are conventions of each path: compare the frequencies and the boundary blocks.
nb = 6
for k, x, y in [(k, a[k][:], b[k][:]) for k in ["/rom/frequencies_hz", "/cb/fixed_interface/frequencies_hz"]] + \
        [(k + "_bb", a[k][:nb, :nb], b[k][:nb, :nb]) for k in ["/rom/K", "/rom/M"]]:
    err = np.max(np.abs(x - y)) / np.max(np.abs(x))
    assert err < 1e-9, (k, err)
assert (b["/rom/boundary_dofs"][:] == bd).all()
# The boundary mass block holds the CONM2 and the beam: its translational diagonal exceeds 1.5 kg.
M = a["/rom/M"][:]
assert all(M[i, i] > 1.5 for i in range(3)), np.diag(M)[:3]
PY
nl=(-mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets mid -mesh_node_set_mid 4,9,14,19 -boundary mid -nlrom_basis cbmd
  -nlrom_num_fixed_modes 3 -nlrom_num_derivatives 3 -nlrom_forces exact -load_sets mid -load_mid_dir 0,1,0.5
  -load_mid_amplitude 100 -load_mid_omega 2000 -nlrom_training_tfinal 0.01)
run nlrom "${nl[@]}" -out "$d/nl.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
import scipy.linalg as sl
d = sys.argv[1]
f, m = h5py.File(f"{d}/nl.h5", "r"), h5py.File(f"{d}/modes.h5", "r")
ids = f["/mesh/node_ids"][:]
x = f["/mesh/coordinates"][:]
V = f["/nlrom/basis"][:]  # [column][node][3]
assert V.shape[0] == 12 + 3 + 3, V.shape
# RBE2 100: grids 5, 10, 15, 20 move rigidly with each other in every column: u_d = u_R + th x (x_d - x_R).
tip = [int(np.where(ids == g)[0][0]) for g in (5, 10, 15, 20)]
xr = np.array([0.4, 0.025, 0.025])
for j in range(V.shape[0]):
    u = V[j][tip]
    r = x[tip] - xr
    # least-squares rigid fit (u_R, th) of the four grids, then its residual
    A = np.zeros((12, 6)); b = u.reshape(-1)
    for k in range(4):
        A[3*k:3*k+3, :3] = np.eye(3)
        rx, ry, rz = r[k]
        A[3*k:3*k+3, 3:] = -np.array([[0, -rz, ry], [rz, 0, -rx], [-ry, rx, 0]])
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    res = np.linalg.norm(A @ sol - b) / max(np.linalg.norm(b), 1e-300)
    assert res < 1e-9 or np.linalg.norm(b) < 1e-12, (j, res)
assert np.abs(V[:, tip]).max() > 0.1, "the tip moves in some column"
K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
w2 = sl.eigh(K, M, eigvals_only=True)
f_rom = np.sqrt(w2[0]) / (2 * np.pi)
f_full = m["/fom/frequencies_hz"][0]
assert f_full <= f_rom * (1 + 1e-9) and f_rom < 1.01 * f_full, (f_rom, f_full)
assert np.abs(f["/nlrom/B"][:]).max() > 0, "no cubic tensor"
print(f"constraints chain: nlrom f1 {f_rom:.6g} Hz (model {f_full:.6g} Hz)")
PY
# nlrom with the six-DOF point as its boundary (ASET: grid 9001, components 1..6), CB + 3 modal
# derivatives trained along y, exact tensors:
#  - the boundary coordinates are (9001, 1..6), labelled x .. rz;
#  - each constraint mode moves the tip grids rigidly by its unit DOF of the point: e_c for a
#    translation, e_c x (x_k - x_R) for a rotation (exact: RBE2 100 and the other five held);
#  - the reduced model's lowest frequency bounds the model's from above within 1 %;
#  - 100 kN along y on each tip grid: the reduced static equilibrium K q + g(q) = V^T f (Newton on
#    the stored tensors) against `morse static` of the full model, nonlinear and linear: the mean
#    tip displacement within 0.5 % (y) and 1 % (the axial shortening), where the linear answer is
#    9 % off; the linear reduced answer is the full linear one (the constraint modes are static
#    solutions);
#  - a contact set that is not on the boundary is refused naming it.
nl6=(-mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -boundary ASET
  -nlrom_basis cbmd -nlrom_num_fixed_modes 3 -nlrom_num_derivatives 3 -nlrom_forces exact -load_sets tip
  -load_tip_dir 0,1,0 -load_tip_amplitude 100 -load_tip_omega 2000 -nlrom_training_tfinal 0.01)
run nlrom "${nl6[@]}" -out "$d/nl6.h5"
tipload=(-mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -load_sets tip
  -load_tip_dir 0,1,0 -load_tip_amplitude 100000)
run static "${tipload[@]}" -out "$d/static6.h5"
run static "${tipload[@]}" -static_linear -out "$d/static6_lin.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
import scipy.linalg as sl
d = sys.argv[1]
f, m = h5py.File(f"{d}/nl6.h5", "r"), h5py.File(f"{d}/modes.h5", "r")
assert f["/nlrom/boundary_dofs"][:].tolist() == [[9001, c] for c in range(1, 7)], f["/nlrom/boundary_dofs"][:]
labels = f["/nlrom/labels"][()]
labels = (labels.decode() if isinstance(labels, bytes) else labels).split("\n")
assert labels[:6] == ["u_b node 9001 " + c for c in ("x", "y", "z", "rx", "ry", "rz")], labels[:6]
ids, X, V = f["/mesh/node_ids"][:], f["/mesh/coordinates"][:], f["/nlrom/basis"][:]
tip = [int(np.where(ids == g)[0][0]) for g in (5, 10, 15, 20)]
xr = np.array([0.4, 0.025, 0.025])
for c in range(6):
    e = np.eye(3)[c % 3]
    want = np.array([e if c < 3 else np.cross(e, X[k] - xr) for k in tip])
    err = np.abs(V[c][tip] - want).max()
    assert err < 1e-10, (c, err)
K, M = f["/nlrom/K"][:], f["/nlrom/M"][:]
f_rom = np.sqrt(sl.eigh(K, M, eigvals_only=True)[0]) / (2 * np.pi)
f_full = m["/fom/frequencies_hz"][0]
assert f_full <= f_rom * (1 + 1e-9) and f_rom < 1.01 * f_full, (f_rom, f_full)
# the reduced static equilibrium under the tip load (eq. 28's tensors, Newton with a central-difference Jacobian)
A, B, r = f["/nlrom/A"][:], f["/nlrom/B"][:], K.shape[0]
P = 100000.0
fq = sum(V[:, k, 1] * P for k in tip)
pairs = [(i, j) for i in range(r) for j in range(i, r)]
trip = [(i, j, k) for i in range(r) for j in range(i, r) for k in range(j, r)]
def res(q):
    m2 = np.array([q[i] * q[j] for i, j in pairs])
    m3 = np.array([q[i] * q[j] * q[k] for i, j, k in trip])
    return K @ q + m2 @ A + m3 @ B - fq
ql = np.linalg.solve(K, fq)
q = ql.copy()
for it in range(50):
    h = 1e-7 * np.abs(q).max()
    J = np.column_stack([(res(q + h * e) - res(q - h * e)) / (2 * h) for e in np.eye(r)])
    dq = np.linalg.solve(J, -res(q))
    q += dq
    if np.linalg.norm(dq) < 1e-12 * np.linalg.norm(q):
        break
else:
    raise AssertionError("reduced Newton did not converge")
mean = lambda qq: np.einsum("j,jkd->kd", qq, V[:, tip, :]).mean(axis=0)
u_rom, u_rom_lin = mean(q), mean(ql)
full = {}
for n in ("static6", "static6_lin"):
    s = h5py.File(f"{d}/{n}.h5", "r")
    sid = s["/mesh/node_ids"][:]
    full[n] = s["/static/u"][-1][[int(np.where(sid == g)[0][0]) for g in (5, 10, 15, 20)]].mean(axis=0)
u_full, u_lin = full["static6"], full["static6_lin"]
assert abs(u_lin[1] - u_full[1]) > 0.05 * u_full[1], (u_lin, u_full)  # the load is nonlinear
assert abs(u_rom[1] - u_full[1]) < 5e-3 * u_full[1], (u_rom, u_full)
assert abs(u_rom[0] - u_full[0]) < 1e-2 * abs(u_full[0]), (u_rom, u_full)
assert abs(u_rom_lin[1] - u_lin[1]) < 1e-8 * u_lin[1], (u_rom_lin, u_lin)
print(f"constraints chain: six-DOF boundary f1 {f_rom:.6g} Hz (model {f_full:.6g}); tip under 4 x 100 kN: "
      f"reduced {u_rom[0]:.4e}, {u_rom[1]:.5e} m, full {u_full[0]:.4e}, {u_full[1]:.5e} m (linear {u_lin[1]:.5e})")
PY
# The massless boundary on the point (MacNeal, theory §11.1): with the boundary free, its dynamic
# modes are the lowest modes of the mass-carrying CB model on the same point (1e-9).
run nlrom -mesh "$deck" -clamp '*BOUNDARY' -boundary ASET -nlrom_basis cb -nlrom_num_fixed_modes 4 -nlrom_forces exact \
  -out "$d/cb6.h5"
run nlrom -mesh "$deck" -clamp '*BOUNDARY' -boundary ASET -nlrom_basis cb -nlrom_num_fixed_modes 4 -nlrom_forces exact \
  -nlrom_boundary_mass massless -out "$d/ml6.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
import scipy.linalg as sl
d = sys.argv[1]
c, m = h5py.File(f"{d}/cb6.h5", "r"), h5py.File(f"{d}/ml6.h5", "r")
w_cb = sl.eigh(c["/nlrom/K"][:], c["/nlrom/M"][:], eigvals_only=True)
K, ns = m["/nlrom/K"][:], int(m["/nlrom"].attrs["n_static_coordinates"])
assert m["/nlrom/boundary_dofs"][:].tolist() == [[9001, k] for k in range(1, 7)]
Kc = K[ns:, ns:] - K[ns:, :ns] @ np.linalg.solve(K[:ns, :ns], K[:ns, ns:])  # static coordinates condensed, M = I
w_ml = np.sort(np.linalg.eigvalsh(0.5 * (Kc + Kc.T)))
nd = len(w_ml)
err = np.abs(w_ml / w_cb[:nd] - 1).max()
assert nd >= 1 and err < 1e-9, (w_ml, w_cb[:nd], err)
print(f"constraints chain: massless on the point: {nd} dynamic modes = the CB model's lowest to {err:.1e}")
PY
expect_error "node 5 of set tip is not a physical boundary node" "$d/nl6_contact.h5" simulate -rom "$d/nl6.h5" \
  -contact_set tip -sim_dt 1e-6 -sim_tfinal 1e-4
# static on the constrained deck: 1 kN along y and 0.5 kN along z on each of the four tip grids (all
# dependent on grid 9001), linear, against the superelement's exact static condensation at the
# point (K_bb of reduce's /rom/K: the constraint modes are static solutions): the tip grids' mean
# displacement is the point's translation (their offsets sum to zero), u_R = (K_bb^-1 F)[:3].
run static -mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -load_sets tip \
  -load_tip_dir 0,1,0.5 -load_tip_amplitude 1118.0339887498948 -static_linear -out "$d/static.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
s, se = h5py.File(f"{d}/static.h5", "r"), h5py.File(f"{d}/se.h5", "r")
ids = s["/mesh/node_ids"][:]
u = s["/static/u"][0]
tip = [int(np.where(ids == g)[0][0]) for g in (5, 10, 15, 20)]
mean = u[tip].mean(axis=0)
Kbb = se["/rom/K"][:6, :6]
F = np.array([0, 4000.0, 2000.0, 0, 0, 0])
uR = np.linalg.solve(Kbb, F)[:3]
err = np.abs(mean - uR).max() / np.abs(uR).max()
assert err < 1e-8, (mean, uR, err)
print(f"constraints chain: static tip {mean} m, condensation {uR} m ({err:.1e})")
PY
# fom (linear, undamped) under the same load applied suddenly: over 10 periods of the first mode the
# tip's mean displacement is the static one (Duhamel: u_s (1 - cos w t), whose mean is u_s to
# 1 / (w T) = 1.6 %), its peak at most 2 u_s; in every snapshot the tip grids move rigidly.
run fom -mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -load_sets tip \
  -load_tip_dir 0,1,0.5 -load_tip_amplitude 1118.0339887498948 -fom_linear -fom_dt 2e-5 -fom_tfinal 0.031 \
  -fom_snapshot_every 5 -fom_monitor tip -out "$d/fom.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
f, se = h5py.File(f"{d}/fom.h5", "r"), h5py.File(f"{d}/se.h5", "r")
uR = np.linalg.solve(se["/rom/K"][:6, :6], np.array([0, 4000.0, 2000.0, 0, 0, 0]))[:3]
U = f["/fom/snapshots/u"][:]
nid, comp = f["/fom/snapshots/dof_node_ids"][:], f["/fom/snapshots/dof_components"][:]
col = {(int(n), int(c)): j for j, (n, c) in enumerate(zip(nid, comp))}
tipu = np.array([[U[:, col[(g, c)]] for c in range(3)] for g in (5, 10, 15, 20)])  # [grid][comp][snapshot]
mean_t = tipu.mean(axis=0)  # the point's translation at each snapshot (offsets sum to zero)
avg = mean_t.mean(axis=1)
assert abs(avg[1] - uR[1]) < 0.03 * uR[1] and abs(avg[2] - uR[2]) < 0.03 * uR[2], (avg, uR)
assert np.abs(mean_t[1]).max() < 2.05 * uR[1], (np.abs(mean_t[1]).max(), uR[1])
# rigid: the four grids' y and z differ only by the rotation about x (theta_x r), equal and opposite
xr = np.array([0.4, 0.025, 0.025])
ids = f["/mesh/node_ids"][:]
X = f["/mesh/coordinates"][:]
for k in range(U.shape[0]):
    A = np.zeros((12, 6)); b = np.zeros(12)
    for i, g in enumerate((5, 10, 15, 20)):
        rx, ry, rz = X[int(np.where(ids == g)[0][0])] - xr
        A[3*i:3*i+3, :3] = np.eye(3)
        A[3*i:3*i+3, 3:] = -np.array([[0, -rz, ry], [rz, 0, -rx], [-ry, rx, 0]])
        b[3*i:3*i+3] = tipu[i, :, k]
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    assert np.linalg.norm(A @ sol - b) <= 1e-9 * max(np.linalg.norm(b), 1e-30), k
print(f"constraints chain: fom mean tip {avg} m over 10 periods, static {uR} m")
PY
# POD on the constrained deck: the fom's snapshots (nodal, every grid) restricted to the model's
# DOFs (fe::restrict_columns: the point's six DOFs from its rigid tip), the point as the boundary,
# 4 POD vectors, exact tensors, and with POD filtering of the forces:
#  - eq. 15 holds: every POD vector vanishes on the boundary, so the tip grids (rigid with the point)
#    do not move in the POD columns (a wrong restriction of the point leaves them moving);
#  - the linear POD model under the fom's load reproduces the fom's tip history (the full model;
#    the two schemes differ by their steps: trapezoidal 2e-5 s, central differences 1e-6 s).
run nlrom -mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -boundary ASET \
  -nlrom_basis pod -nlrom_num_pod 4 -nlrom_forces exact -nlrom_snapshots "$d/fom.h5" -out "$d/pod6.h5"
run nlrom -mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -boundary ASET \
  -nlrom_basis cb -nlrom_num_fixed_modes 4 -nlrom_forces step -nlrom_snapshots "$d/fom.h5" -nlrom_filter_pod 3 \
  -out "$d/cb6_filtered.h5"
run simulate -rom "$d/pod6.h5" -load_sets tip -load_tip_dir 0,1,0.5 -load_tip_amplitude 1118.0339887498948 \
  -sim_linear -sim_dt 1e-6 -sim_tfinal 0.031 -sim_monitor tip -sim_output_every 20 -out "$d/sim_pod6.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
p = h5py.File(f"{d}/pod6.h5", "r")
ids, V = p["/mesh/node_ids"][:], p["/nlrom/basis"][:]
tip = [int(np.where(ids == g)[0][0]) for g in (5, 10, 15, 20)]
assert V.shape[0] == 6 + 4, V.shape
for j in range(6, 10):
    assert np.abs(V[j][tip]).max() < 1e-12 * np.abs(V[j]).max(), (j, np.abs(V[j][tip]).max())
f, s = h5py.File(f"{d}/fom.h5", "r"), h5py.File(f"{d}/sim_pod6.h5", "r")
tf, ts = f["/fom/time"][:], s["/sim/time"][:]
yf = f["/fom/sets/tip/u"][:].reshape(len(tf), -1, 3)[:, :, 1].mean(axis=1)
ys = np.interp(tf, ts, s["/sim/sets/tip/u"][:].reshape(len(ts), -1, 3)[:, :, 1].mean(axis=1))
peak = np.abs(yf).max()
assert np.abs(ys - yf).max() < 0.03 * peak, np.abs(ys - yf).max() / peak
assert abs(ys.mean() - yf.mean()) < 2e-3 * abs(yf.mean()), (ys.mean(), yf.mean())
assert h5py.File(f"{d}/cb6_filtered.h5", "r")["/nlrom"].attrs["filter_pod"] == 3
print(f"constraints chain: POD on the point, tip history within {np.abs(ys - yf).max() / peak:.2%} of the fom's peak")
PY
# fom with nodal inputs on the constrained deck:
#  - -load_history: the same constant forces as a table on the four dependent tip grids (CSV)
#    give the -load_sets run (fom.h5): the history goes through T^T as the loads do;
#  - -fom_initial: started from the static solution under the same load (restricted to the model's
#    DOFs, fe::restrict_vector), the blade stays at rest: the tip on the static displacement.
{
  echo "time, node, fx, fy, fz"
  for t in 0 1; do for g in 5 10 15 20; do echo "$t, $g, 0, 1000, 500"; done; done
} >"$d/tip_history.csv"
fomargs=(-mesh "$deck" -clamp '*BOUNDARY' -mesh_node_sets tip -mesh_node_set_tip 5,10,15,20 -fom_linear -fom_dt 2e-5
  -fom_tfinal 0.031 -fom_monitor tip)
run fom "${fomargs[@]}" -load_history "$d/tip_history.csv" -out "$d/fom_history.h5"
run fom "${fomargs[@]}" -load_sets tip -load_tip_dir 0,1,0.5 -load_tip_amplitude 1118.0339887498948 \
  -fom_initial "$d/static.h5" -out "$d/fom_initial.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
tip = lambda n: h5py.File(f"{d}/{n}.h5", "r")["/fom/sets/tip/u"][:]
a, b = tip("fom"), tip("fom_history")
err = np.abs(a - b).max() / np.abs(a).max()
assert a.shape == b.shape and err < 1e-10, err
s = h5py.File(f"{d}/static.h5", "r")
sid = s["/mesh/node_ids"][:]
us = s["/static/u"][-1][[int(np.where(sid == g)[0][0]) for g in (5, 10, 15, 20)]]
c = tip("fom_initial").reshape(-1, 4, 3)
drift = np.abs(c - us[None]).max() / np.abs(us).max()
assert drift < 1e-8, drift
print(f"constraints chain: fom -load_history = -load_sets to {err:.1e}; from the static state the tip stays "
      f"within {drift:.1e} of it")
PY
# stress -fom on the deck: the linear stress of the state held at the static solution
# (fom_initial.h5, snapshots every 100 steps) against an independent hex8 evaluation of the static
# field: at each node, the mean over its elements of lambda tr(eps) I + 2 mu eps at that node.
run fom "${fomargs[@]}" -load_sets tip -load_tip_dir 0,1,0.5 -load_tip_amplitude 1118.0339887498948 \
  -fom_initial "$d/static.h5" -fom_tfinal 0.002 -fom_snapshot_every 50 -out "$d/fom_initial_snaps.h5"
run stress -mesh "$deck" -clamp '*BOUNDARY' -fom "$d/fom_initial_snaps.h5" -stress_time 0.001 -stress_measure linear \
  -out "$d/stress_fom.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
s, st = h5py.File(f"{d}/static.h5", "r"), h5py.File(f"{d}/stress_fom.h5", "r")
ids, X, u = s["/mesh/node_ids"][:], s["/mesh/coordinates"][:], s["/static/u"][-1]
conn = {1: [1, 2, 7, 6, 11, 12, 17, 16], 2: [2, 3, 8, 7, 12, 13, 18, 17], 3: [3, 4, 9, 8, 13, 14, 19, 18],
        4: [4, 5, 10, 9, 14, 15, 20, 19]}  # the deck's CHEXA
nat = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]])
E, nu = 2.1e11, 0.3
lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
row = {int(i): k for k, i in enumerate(ids)}
acc, cnt = np.zeros((len(ids), 6)), np.zeros(len(ids))
for nodes in conn.values():
    xe, ue = X[[row[n] for n in nodes]], u[[row[n] for n in nodes]]
    for b, xi in enumerate(nat):
        dN = np.array([a * (1 + xi[(c + 1) % 3] * a2[(c + 1) % 3]) * (1 + xi[(c + 2) % 3] * a2[(c + 2) % 3])
                       for a2 in nat for c, a in enumerate(a2)]).reshape(8, 3) / 8.0
        J = xe.T @ dN
        G = ue.T @ dN @ np.linalg.inv(J)  # du_i/dx_j
        eps = 0.5 * (G + G.T)
        sig = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
        k = row[nodes[b]]
        acc[k] += [sig[0, 0], sig[0, 1], sig[0, 2], sig[1, 1], sig[1, 2], sig[2, 2]]
        cnt[k] += 1
want = acc / cnt[:, None]
sid = st["/mesh/node_ids"][:]
got = st["/stress/stress"][0][[int(np.where(sid == i)[0][0]) for i in ids]]
err = np.abs(got - want).max() / np.abs(want).max()
assert err < 1e-8, err
print(f"constraints chain: stress -fom = the hex8 stress of the static field to {err:.1e} (max {np.abs(want).max() / 1e6:.1f} MPa)")
PY
sed 's/^RBE2,100,9001,123456,5,10,15,20$/RBE2,100,9001,123456,5,10,15,20,1/' "$deck" >"$d/clamped_dep.bdf"
expect_error "RBE2 100: node 1 component 1 (x) is dependent but also fixed" "$d/bad1.h5" modes -mesh "$d/clamped_dep.bdf" \
  -clamp '*BOUNDARY' -modes_nev 2
sed 's/^ENDDATA$/MPC,1,2,1,1.,3,1,-1.\nMPC,1,3,1,1.,2,1,-1.\nENDDATA/' "$deck" >"$d/cycle.bdf"
expect_error "circular dependency between constraints" "$d/bad2.h5" modes -mesh "$d/cycle.bdf" -clamp '*BOUNDARY' \
  -modes_nev 2
echo "constraints chain: OK"
