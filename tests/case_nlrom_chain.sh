#!/usr/bin/env bash
# Case chain of the nonlinear reduced models: fom with snapshots -> nlrom (cb + exact tensors,
# cbmd + STEP, pod + STEP) -> simulate on each, then a simulate step above the critical one is
# refused with the limit and leaves no file.
# usage: case_nlrom_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
. "$(dirname "$0")/case_common.sh" "$@"
load=(-load_sets x1 -load_x1_dir y -load_x1_amplitude 1e6 -load_x1_omega 300)
run fom "${model[@]}" "${load[@]}" -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_snapshot_every 2 -fom_monitor x1 \
  -out "$d/fom.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes 2 -out "$d/cb.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cbmd -nlrom_num_fixed_modes 2 -nlrom_num_derivatives 3 \
  "${load[@]}" -nlrom_training_tfinal 2e-3 -out "$d/cbmd.h5"
# The random control of seed 003 Fig. 9: the same weights W_ij, another (seeded) choice of pairs.
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cbmd -nlrom_num_fixed_modes 2 -nlrom_num_derivatives 3 \
  "${load[@]}" -nlrom_training_tfinal 2e-3 -nlrom_derivative_selection random -nlrom_derivative_seed 3 \
  -out "$d/cbmd_random.h5"
/usr/bin/python3 - "$d/cbmd.h5" "$d/cbmd_random.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
w, rnd = (h5py.File(f, "r")["/nlrom/derivatives"] for f in sys.argv[1:3])
assert w.attrs["selection"] in (b"weight", "weight") and rnd.attrs["selection"] in (b"random", "random")
assert np.allclose(w["weights"][:], rnd["weights"][:], rtol=1e-10)
sw, sr = w["selected"][:], rnd["selected"][:]
assert sw.sum() == sr.sum() == 3 and not np.array_equal(sw, sr), (sw, sr)
# By weight: the 3 selected pairs carry the 3 largest weights.
assert set(np.argsort(-w["weights"][:])[:3]) == set(np.nonzero(sw)[0])
PY
run nlrom "${model[@]}" -boundary x1 -nlrom_basis pod -nlrom_num_pod 3 -nlrom_snapshots "$d/fom.h5" \
  -nlrom_filter_pod 0 -out "$d/pod.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_snapshots "$d/fom.h5" \
  -nlrom_filter_pod 4 -out "$d/cbfilter.h5"
# Rank independence, on the coarse blade (the box's square section has double eigenvalues, so its
# fixed-interface modes are any basis of each pair): the cbmd model with exact tensors on one rank
# and on NP ranks agrees to the eigen solver's tolerance (mode signs are normalized; sums run in
# another order).
if [ "$np" -gt 1 ]; then
  blade=$(cd "$(dirname "$0")/.." && pwd)/meshes/blade_coarse.msh
  bl=(nlrom -mesh "$blade" -clamp root -boundary LE -nlrom_basis cbmd -nlrom_num_fixed_modes 4 -nlrom_num_derivatives 6
      -nlrom_forces exact -load_sets LE -load_LE_dir y -load_LE_amplitude 300 -load_LE_omega 2000
      -nlrom_training_tfinal 0.00314)
  "$mpiexec" "${flags[@]}" -n 1 "$morse" "${bl[@]}" -out "$d/blade_np1.h5"
  run "${bl[@]}" -out "$d/blade_np.h5"
  /usr/bin/python3 - "$d/blade_np.h5" "$d/blade_np1.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
a, b = (h5py.File(f, "r") for f in sys.argv[1:3])
assert (a["/nlrom/derivatives/selected"][:] == b["/nlrom/derivatives/selected"][:]).all()
for k in ["M", "K", "A", "B", "basis"]:
    x, y = a["/nlrom/" + k][:], b["/nlrom/" + k][:]
    d = abs(x - y).max() / abs(y).max()
    print("nlrom %s: 1 rank vs several %.1e" % (k, d))
    assert d < 1e-8, (k, d)
PY
fi
for b in cb cbmd pod cbfilter; do
  test -s "$d/$b.h5"
  run simulate -rom "$d/$b.h5" "${load[@]}" -sim_dt 1e-8 -sim_tfinal 2e-5 -sim_monitor x1 -out "$d/sim_$b.h5"
  test -s "$d/sim_$b.h5"
done
# The indicator of a POD ROM against the run its snapshots came from (short run, same sampling).
run simulate -rom "$d/pod.h5" "${load[@]}" -sim_dt 1e-7 -sim_tfinal 2e-3 -sim_monitor x1 -sim_output_every 100 \
  -out "$d/sim_long.h5"
run compare "$d/fom.h5" "$d/sim_long.h5" "${load[@]}" -compare_tip x1 -compare_tmax 1e-3 | tee "$d/compare.txt"
grep -q "performance indicator I" "$d/compare.txt"
# /sim@rom names the model by its absolute path: a simulate given a relative -rom, compared from
# another working directory, still finds it (it failed when the relative path was stored).
(cd "$d" && run simulate -rom pod.h5 "${load[@]}" -sim_dt 1e-7 -sim_tfinal 2e-3 -sim_monitor x1 \
  -sim_output_every 100 -out sim_rel.h5)
(cd / && run compare "$d/fom.h5" "$d/sim_rel.h5" "${load[@]}" -compare_tip x1 -compare_tmax 1e-3) \
  > "$d/compare_rel.txt"
grep -q "performance indicator I" "$d/compare_rel.txt"
/usr/bin/python3 - "$d/sim_long.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py
f = h5py.File(sys.argv[1], "r")
e, I = f["/compare/e"][:], f["/compare/I"][0]
assert all(0 <= x <= 1 for x in e) and 0.5 < I <= 1, (e, I)
PY
# The fom and simulate files store their load (/fom/load, /sim/load): compare without -load_* takes
# t_max from it and gives the same /compare as with the -load_* options, which still override the
# stored load with a notice. A file without a stored load (written before) needs -load_*. (A
# faster load than the chain's, so that its first maximum, t_max = pi/2/1000, is inside the run.)
fast=(-load_sets x1 -load_x1_dir y -load_x1_amplitude 1e6 -load_x1_omega 1000)
run fom "${model[@]}" "${fast[@]}" -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_snapshot_every 2 -fom_monitor x1 \
  -out "$d/fom_fast.h5"
run simulate -rom "$d/pod.h5" "${fast[@]}" -sim_dt 1e-7 -sim_tfinal 2e-3 -sim_monitor x1 -sim_output_every 100 \
  -out "$d/sim_fast.h5"
cp "$d/sim_fast.h5" "$d/sim_stored.h5"
cp "$d/sim_fast.h5" "$d/sim_given.h5"
run compare "$d/fom_fast.h5" "$d/sim_stored.h5" -compare_tip x1 | tee "$d/compare_stored.txt"
if grep -q 'override' "$d/compare_stored.txt"; then echo "override notice without -load_*"; exit 1; fi
run compare "$d/fom_fast.h5" "$d/sim_given.h5" "${fast[@]}" -compare_tip x1 | tee "$d/compare_given.txt"
grep -q "the -load_\* options override the load stored in $d/fom_fast.h5" "$d/compare_given.txt"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
a, b = (h5py.File(d + "/sim_%s.h5" % k, "r")["/compare"] for k in ("stored", "given"))
for k in ("e", "I", "t_max", "t_snapshot"):
    assert np.array_equal(a[k][:], b[k][:]), (k, a[k][:], b[k][:])
assert abs(a["t_max"][0] - np.pi / 2 / 1000) < 1e-15, a["t_max"][0]
for f, g in (("fom.h5", "/fom/load"), ("sim_long.h5", "/sim/load")):
    l = h5py.File(d + "/" + f, "r")[g]
    assert l.attrs["n_loads"] == 1 and l["sets"][()].decode() == "x1\n", f
    assert np.array_equal(l["direction"][:], [[0, 1, 0]]) and l["amplitude"][0] == 1e6 and l["omega"][0] == 300
    assert l["phase"][0] == 0
# Files of an older morse: no stored load.
for f, g in (("fom_fast.h5", "/fom/load"), ("sim_fast.h5", "/sim/load")):
    with h5py.File(d + "/" + f, "r") as src, h5py.File(d + "/old_" + f, "w") as dst:
        for k in src:
            src.copy(k, dst)
        del dst[g]
PY
if [ -e "$d/old_fom_fast.h5" ]; then
  run compare "$d/old_fom_fast.h5" "$d/old_sim_fast.h5" "${fast[@]}" -compare_tip x1 | tee "$d/compare_old.txt"
  if grep -q 'override' "$d/compare_old.txt"; then echo "override notice without a stored load"; exit 1; fi
  set +e
  out=$(run compare "$d/old_fom_fast.h5" "$d/old_sim_fast.h5" -compare_tip x1 2>&1)
  rc=$?
  set -e
  test $rc -ne 0
  grep -q -- 'give -compare_tmax T or the harmonic load (-load_\*).*neither file stores' <<<"$out" \
    || { echo "missing the no-load message in: $out"; exit 1; }
fi
# Three load cases spread over the ranks (one file each), with full-field snapshots at the fom's
# snapshot times: case a repeats the single run above, so its q is the same to the last bit.
run simulate -rom "$d/pod.h5" -sim_cases a,b,c -sim_dt 1e-7 -sim_tfinal 2e-3 -sim_monitor x1 -sim_output_every 100 \
  -a_load_sets x1 -a_load_x1_dir y -a_load_x1_amplitude 1e6 -a_load_x1_omega 300 \
  -b_load_sets x1 -b_load_x1_dir y -b_load_x1_amplitude 1e6 -b_load_x1_omega 600 \
  -c_load_sets x1 -c_load_x1_dir z -c_load_x1_amplitude 1e6 -c_load_x1_omega 300 \
  -sim_snapshots "$d/fom.h5" -out "$d/cases.h5"
/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
one, fom = h5py.File(d + "/sim_long.h5", "r"), h5py.File(d + "/fom.h5", "r")
a, b, c = (h5py.File(d + "/cases_%s.h5" % k, "r") for k in "abc")
assert np.array_equal(a["/sim/q"][:], one["/sim/q"][:]), "case a differs from the single run"
assert not np.allclose(b["/sim/q"][:], a["/sim/q"][:]) and not np.allclose(c["/sim/q"][:], a["/sim/q"][:])
st, ft = a["/sim/snapshots/time"][:], fom["/fom/snapshots/time"][:]
assert np.allclose(st, ft, atol=1e-7), (st, ft)
assert a["/sim/snapshots/u"].shape == fom["/fom/snapshots/u"].shape
assert np.array_equal(a["/sim/snapshots/dof_node_ids"][:], fom["/fom/snapshots/dof_node_ids"][:])
# The snapshot at the last time equals the reconstruction of the final state.
basis, ids = h5py.File(d + "/pod.h5", "r")["/nlrom/basis"][:], h5py.File(d + "/pod.h5", "r")["/mesh/node_ids"][:]
row = {n: k for k, n in enumerate(ids)}
comp = a["/sim/snapshots/dof_components"][:]
rows = [row[n] for n in a["/sim/snapshots/dof_node_ids"][:]]
u = np.einsum("j,jn->n", a["/sim/final/q"][:], basis[:, rows, :].reshape(len(basis), len(rows), 3)[:, np.arange(len(rows)), comp])
assert abs(a["/sim/final"].attrs["time"] - st[-1]) < 1e-9
assert np.allclose(u, a["/sim/snapshots/u"][-1], rtol=1e-12, atol=1e-12 * abs(u).max())
PY
# Bad input: a step above the critical one, an initial state of the wrong size, a missing
# snapshot file. Each names the option or the limit and leaves no file.
expect_error 'above the critical step' "$d/bad.h5" simulate -rom "$d/cb.h5" -sim_dt 1 -sim_tfinal 10
expect_error '-sim_q0 has 2 values' "$d/bad_q0.h5" simulate -rom "$d/cb.h5" -sim_dt 1e-8 -sim_tfinal 1e-6 -sim_q0 1,2
expect_error '-sim_snapshots.*no_such_fom.h5' "$d/bad_snap.h5" simulate -rom "$d/cb.h5" -sim_dt 1e-8 -sim_tfinal 1e-6 \
  -sim_snapshots "$d/no_such_fom.h5"
echo "case: ok: nlrom chain"
