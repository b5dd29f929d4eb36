#!/usr/bin/env bash
# Case chain of contact and speed sweeps on the generated box (clamped at x0, its free face x1
# rubbing on the rotating two-lobe casing): nlrom (boundary x1) -> simulate with casing contact
# (/sim/contact: no penetration, compressive forces) -> sweep. On several ranks the sweep is
# killed (kill -9) after a few speeds and run again: the resumed file holds bitwise the results
# of an uninterrupted sweep on one rank. Bad input: a contact set outside the basis, a negative
# clearance, a step above critical, an unwritable output, a sweep file with other settings.
# morse stress at the time of the largest radial displacement of one tip node: the time and u = Phi q
# there agree with the simulation's record, np ranks give bitwise the one-rank file, and its bad
# input (a time outside the run, an unknown measure, no -sim, a monitor of 4 nodes) is refused.
# usage: case_contact_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes 15 -out "$d/cb.h5"
casing=(-contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3 -contact_mu 0.15)
run simulate -rom "$d/cb.h5" "${casing[@]}" -sim_omega 1200 -sim_revolutions 2 -sim_dt 4e-6 -out "$d/sim.h5"
/usr/bin/python3 - "$d/sim.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
c = f["/sim/contact"]
n, g, act = c["normal"][:], c["gap"][:], c["active"][:]
assert n.shape == g.shape == (len(f["/sim/time"]), 4) and c["tangential"].shape == n.shape + (3,)
assert act.max() > 0 and n.max() > 0, "no contact"
assert n.min() >= 0 and g.min() > -1e-12 * 2e-4, (n.min(), g.min())
# Coulomb: |friction| = mu lambda on every contact node
t = np.linalg.norm(c["tangential"][:], axis=2)
assert np.allclose(t, 0.15 * n, rtol=1e-9, atol=1e-9 * n.max())
assert abs(f["/sim/time"][-1] - 2 * 2 * np.pi / 1200) < 4e-6
PY
# The contact force history (/sim/contact/normals, mean_force): with output every step the mean
# force is lambda n + friction of that step; with output every 5 steps it is the mean of those 5
# (the impulse is kept); it drives the full model through morse fom -load_history.
run simulate -rom "$d/cb.h5" "${casing[@]}" -sim_omega 1200 -sim_revolutions 2 -sim_dt 4e-6 -sim_output_every 5 \
  -out "$d/sim5.h5"
/usr/bin/python3 - "$d/sim.h5" "$d/sim5.h5" "$d/cb.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
f, f5, rom = (h5py.File(p, "r") for p in sys.argv[1:4])
c, c5 = f["/sim/contact"], f5["/sim/contact"]
t, nrm, lam, fr, mf = f["/sim/time"][:], c["normals"][:], c["normal"][:], c["tangential"][:], c["mean_force"][:]
ids = c["node_ids"][:]
x = np.array([rom["/mesh/coordinates"][int(np.flatnonzero(rom["/mesh/node_ids"][:] == i)[0])] for i in ids])
er = np.c_[x[:, :2] / np.hypot(x[:, 0], x[:, 1])[:, None], np.zeros(len(ids))]
assert np.allclose(nrm, -er, atol=1e-14), "normals are not -e_r"
want = lam[:, :, None] * nrm[None] + fr
assert np.abs(mf[0]).max() == 0 and np.allclose(mf[1:], want[1:], rtol=1e-12, atol=1e-12 * np.abs(want).max())
tm = c["mean_force_time"][:]
assert tm[0] == 0 and np.allclose(tm[1:], 0.5 * (t[1:] + t[:-1]), rtol=1e-14)
mf5, t5 = c5["mean_force"][:], f5["/sim/time"][:]
n5 = len(t5) - 1
assert np.allclose(t5, t[::5][:len(t5)])
mean5 = want[1:5 * n5 + 1].reshape(n5, 5, *want.shape[1:]).mean(axis=1)
assert np.abs(mean5).max() > 0, "no contact"
assert np.allclose(mf5[1:], mean5, rtol=1e-10, atol=1e-10 * np.abs(mean5).max()), np.abs(mf5[1:] - mean5).max()
PY
run fom "${model[@]}" -load_history "$d/sim5.h5" -fom_linear -fom_dt 2e-5 -fom_tfinal 5e-3 -fom_monitor x1 \
  -out "$d/fom_history.h5"
/usr/bin/python3 - "$d/fom_history.h5" "$d/sim5.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
src = f["/fom"].attrs["load_history"]
src = src.decode() if isinstance(src, bytes) else src
assert src == sys.argv[2] + ":/sim/contact", src
assert np.abs(f["/fom/sets/x1/u"][:]).max() > 0, "no response to the contact forces"
PY
sweep=(sweep -rom "$d/cb.h5" "${casing[@]}" -sim_dt 4e-6 -sim_revolutions 150 -sweep_omega_min 800
       -sweep_omega_max 2000 -sweep_omega_step 100 -sweep_monitor x1 -sweep_spectrum_fmax 3000
       -sweep_spectrum_bins 60 -sweep_batch 3)
# The monitor must be one node: the box has no one-node set, so -sweep_monitor x1 must be refused.
expect_error '-sweep_monitor x1 has 4 nodes' "$d/bad_monitor.h5" "${sweep[@]}"
# A one-node monitor set cannot be added after nlrom: rebuild with one.
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes 15 -mesh_node_sets tipnode \
  -mesh_node_set_tipnode "$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/cb.h5','r')['/nlrom/node_sets/x1'][0])")" \
  -out "$d/cb.h5"
sweep=(sweep -rom "$d/cb.h5" "${casing[@]}" -sim_dt 4e-6 -sim_revolutions 150 -sweep_omega_min 800
       -sweep_omega_max 2000 -sweep_omega_step 100 -sweep_monitor tipnode -sweep_spectrum_fmax 3000
       -sweep_spectrum_bins 60 -sweep_batch 3)
# Stress at the time of the largest |u_r| at tipnode (morse stress): the time and the displacement
# agree with the simulation's own record, and np ranks write bitwise the one-rank file.
run simulate -rom "$d/cb.h5" "${casing[@]}" -sim_omega 1200 -sim_revolutions 2 -sim_dt 4e-6 -out "$d/sim2.h5"
run stress "${model[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" -stress_monitor tipnode -out "$d/stress.h5"
"$mpiexec" "${flags[@]}" -n 1 "$morse" stress "${model[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" -stress_monitor tipnode \
  -out "$d/stress1.h5"
/usr/bin/python3 - "$d/sim2.h5" "$d/stress.h5" "$d/stress1.h5" "$d/cb.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
sim, st, st1, rom = (h5py.File(f, "r") for f in sys.argv[1:5])
tip = rom["/nlrom/node_sets/tipnode"][0]
k = list(sim["/sim/contact/node_ids"][:]).index(tip)
ur = sim["/sim/contact/radial_displacement"][:, k]
i = int(np.argmax(np.abs(ur)))
s = st["/stress"]
assert s.attrs["step"] == i and s.attrs["time"] == sim["/sim/time"][i], (s.attrs["step"], i)
assert s.attrs["measure"] in (b"nonlinear", "nonlinear")
n = list(st["/mesh/node_ids"][:]).index(tip)
X = st["/mesh/coordinates"][n]
u = st["/stress/displacement"][0, n]
assert abs((u[0] * X[0] + u[1] * X[1]) / np.hypot(X[0], X[1]) - ur[i]) <= 1e-12 * abs(ur[i]), "u = Phi q at the monitor"
vm = st["/stress/von_mises"][0]
assert vm.max() > 0 and abs(vm.max() - s.attrs["max_nodal_von_mises"]) == 0
for key in ("displacement", "von_mises", "stress", "von_mises_element", "von_mises_element_max"):
    assert np.array_equal(st["/stress/" + key][()], st1["/stress/" + key][()]), key
print("stress: t_max %.6g s, max von Mises %.4g MPa, bitwise equal on 1 rank" % (s.attrs["time"], vm.max() / 1e6))
PY
grep -q 'Attribute Name="von_mises_1" AttributeType="Scalar" Center="Node"' "$d/stress.xdmf"
expect_error 'lies outside the simulation' "$d/bad_t.h5" stress "${model[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" \
  -stress_time 1
expect_error '-stress_measure plastic: unknown' "$d/bad_m.h5" stress "${model[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" \
  -stress_measure plastic
expect_error 'no simulation given' "$d/bad_sim2.h5" stress "${model[@]}" -rom "$d/cb.h5"
# A mesh that is not the model's is refused, naming both files: another node count (a longer box),
# and the same node ids at other places (the box twice as long, same divisions).
"$mpiexec" "${flags[@]}" -n 1 "$morse" mesh box -box_type hex8 -box_lx 4 -box_ly 1 -box_lz 1 -box_nx 5 -box_ny 1 \
  -box_nz 1 -out "$d/other_box.msh" > /dev/null
"$mpiexec" "${flags[@]}" -n 1 "$morse" mesh box -box_type hex8 -box_lx 8 -box_ly 1 -box_lz 1 -box_nx 4 -box_ny 1 \
  -box_nz 1 -out "$d/long_box.msh" > /dev/null
expect_error "the mesh $d/other_box.msh has 24 nodes but the reduced model $d/cb.h5 was built on a mesh of 20" \
  "$d/bad_mesh.h5" stress -mesh "$d/other_box.msh" -clamp x0 "${material[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" \
  -stress_monitor tipnode
expect_error "of the mesh $d/long_box.msh is at .* in the reduced model $d/cb.h5" "$d/bad_mesh2.h5" \
  stress -mesh "$d/long_box.msh" -clamp x0 "${material[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" -stress_monitor tipnode
expect_error 'has 4 nodes; one is expected' "$d/bad_mon.h5" stress "${model[@]}" -rom "$d/cb.h5" -sim "$d/sim2.h5" \
  -stress_monitor x1
"$mpiexec" "${flags[@]}" -n 1 "$morse" "${sweep[@]}" -out "$d/full.h5"
if [ "$np" -gt 1 ]; then
  # Killed after at least 3 finished speeds, then resumed.
  "$mpiexec" "${flags[@]}" -n "$np" "$morse" "${sweep[@]}" -out "$d/resumed.h5" > "$d/killed.log" 2>&1 &
  pid=$!
  /usr/bin/python3 - "$d/resumed.h5" <<'PY'
import sys, time, os, h5py
for _ in range(1200):
    try:
        if os.path.exists(sys.argv[1]) and h5py.File(sys.argv[1], "r")["/sweep"].attrs["n_done"] >= 3:
            break
    except Exception:
        pass
    time.sleep(0.05)
PY
  kill -9 -- "$pid" 2>/dev/null || true
  pkill -9 -f -- "-out $d/resumed.h5" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  done_before=$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/resumed.h5','r')['/sweep'].attrs['n_done'])")
  echo "sweep killed with $done_before of 13 speeds in the file"
  out=$(run "${sweep[@]}" -out "$d/resumed.h5" 2>&1)
  grep -q "($done_before already in" <<<"$out" || { echo "no resume in: $out"; exit 1; }
  cmp_file="$d/resumed.h5"
else
  cmp_file="$d/full.h5"
fi
/usr/bin/python3 - "$d/full.h5" "$cmp_file" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
a, b = (h5py.File(f, "r")["/sweep"] for f in sys.argv[1:3])
assert a.attrs["n_done"] == b.attrs["n_done"] == 13
for k in a:
    if k in ("seconds",):
        continue
    x, y = a[k][()], b[k][()]
    assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), k  # NaN: a line above fmax
assert (a["status"][:] == 0).all() and (a["max_active"][:] > 0).sum() >= 5
assert a["spectrum"].shape == (13, 61) and np.all(np.diff(a["omega"][:]) > 0)
print("sweep: 13 speeds, bitwise equal to the uninterrupted one-rank sweep")
PY
# Bad input: each names the option or file and leaves no file.
expect_error 'not a physical boundary node' "$d/bad_set.h5" sweep -rom "$d/cb.h5" -contact_set x0 -sim_dt 4e-6 \
  -sweep_omega_min 800 -sweep_omega_max 900 -sweep_omega_step 100 -sweep_monitor tipnode
expect_error '-casing_clearance must be positive' "$d/bad_c0.h5" "${sweep[@]}" -casing_clearance -1e-3
expect_error 'above the critical step' "$d/bad_dt.h5" "${sweep[@]}" -sim_dt 1
expect_error 'cannot write' "$d/no_such_dir/sw.h5" "${sweep[@]}"
expect_error '-sim_omega does not apply' "$d/bad_omega.h5" "${sweep[@]}" -sim_omega 1000
expect_error '-contact_plane_\* do not apply' "$d/bad_plane.h5" "${sweep[@]}" -contact_plane_normal 1,0,0
set +e
out=$(run "${sweep[@]}" -sim_revolutions 10 -out "$d/full.h5" 2>&1)
rc=$?
set -e
test $rc -ne 0 && grep -q "other settings" <<<"$out"
expect_error 'not a physical boundary node' "$d/bad_sim.h5" simulate -rom "$d/cb.h5" -contact_set x0 -sim_dt 4e-6 \
  -sim_tfinal 1e-3
expect_error '-sim_revolutions needs a rotation speed' "$d/bad_rev.h5" simulate -rom "$d/cb.h5" -contact_set x1 \
  -sim_dt 4e-6 -sim_revolutions 2
echo "case: ok: contact chain"
