#!/usr/bin/env bash
# Adaptive refinement of `morse sweep` (-sweep_refine_step): a coarse grid of 6 speeds refined down
# to 1/8 of its step runs refinement rounds and adds speeds between the coarse ones; run again, it
# resumes with every speed done and runs nothing. A file cut back to its coarse speeds plus part of
# a round (as a killed run leaves it) resumes to the same speeds and the same results, bitwise. Bad
# refinement options are refused naming them, before anything runs, and a model rebuilt at the same
# path with other damping is not resumed into the old model's file. Skipped (77) without
# /usr/bin/python3 and h5py.
# usage: case_sweep_refine.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
/usr/bin/python3 -c "import h5py, numpy" 2>/dev/null || { echo "case: skipped: no python3 with h5py"; exit 77; }
. "$(dirname "$0")/case_common.sh" "$@"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes all -out "$d/cb0.h5"
tip=$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/cb0.h5','r')['/nlrom/node_sets/x1'][0])")
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes all -mesh_node_sets tipnode -mesh_node_set_tipnode "$tip" \
  -out "$d/cb.h5"
sweep=(sweep -rom "$d/cb.h5" -contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3
       -sim_dt 4e-6 -sim_revolutions 2 -sim_linear -sweep_omega_min 800 -sweep_omega_max 2800 -sweep_omega_step 400
       -sweep_monitor tipnode -sweep_spectrum_fmax 3000 -sweep_spectrum_bins 30 -sweep_refine_step 50)
out=$(run "${sweep[@]}" -out "$d/full.h5")
grep -q "refinement round 1:" <<<"$out" || { echo "case: FAIL: no refinement round: $out"; exit 1; }
n=$(/usr/bin/python3 -c "import h5py; print(len(h5py.File('$d/full.h5','r')['/sweep/index']))")
test "$n" -gt 6 || { echo "case: FAIL: $n speeds, no refined speed"; exit 1; }
echo "refined sweep: $n speeds of a grid of 41"

# Refined on engine-order lines instead (-sweep_refine_orders): rounds run, and every speed has
# its lines 1..24 at their exact frequencies, NaN above -sweep_spectrum_fmax (3 kHz).
out=$(run "${sweep[@]}" -sweep_refine_orders 2,4 -out "$d/lines.h5")
grep -q "refined where the engine-order lines 2,4 jump by 0.5" <<<"$out" || { echo "case: FAIL: no lines: $out"; exit 1; }
/usr/bin/python3 - "$d/lines.h5" <<'PY'
import sys, math, h5py, numpy as np
s = h5py.File(sys.argv[1], "r")["/sweep"]
w, eo = np.abs(s["omega"][()]), s["order_amplitude"][()]
assert eo.shape == (len(w), 24), eo.shape
assert len(w) > 6, "no refined speed"
for k in range(len(w)):
    for n in range(1, 25):
        above = n * w[k] / (2 * math.pi) > 3000
        assert np.isnan(eo[k, n - 1]) == above, (w[k], n, eo[k, n - 1])
assert "refine_orders=2,4" in s["settings"][()].decode(), "settings lack the lines"
print("lines: %d speeds, engine orders measured up to 3 kHz" % len(w))
PY

# Run again: everything is done, nothing runs.
out=$(run "${sweep[@]}" -out "$d/full.h5")
grep -q "($n already in $d/full.h5)" <<<"$out" || { echo "case: FAIL: not resumed whole: $out"; exit 1; }
grep -q "refinement round" <<<"$out" && { echo "case: FAIL: a resumed finished sweep ran a round: $out"; exit 1; }

# A killed run: keep the coarse speeds and the first refined one, then resume.
cp "$d/full.h5" "$d/cut.h5"
/usr/bin/python3 - "$d/cut.h5" <<'PY'
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r+")
s = f["/sweep"]
idx = s["index"][()]
keep = np.where(idx % 8 == 0)[0].tolist() + [int(np.where(idx % 8 != 0)[0][0])]
for k in list(s.keys()):
    d = s[k]
    if isinstance(d, h5py.Dataset) and d.shape and d.shape[0] == len(idx) and k not in ("frequency", "eigenfrequencies"):
        a = d[()][keep]
        del s[k]
        s[k] = a
s.attrs["n_done"] = len(keep)
PY
run "${sweep[@]}" -out "$d/cut.h5" > /dev/null
/usr/bin/python3 - "$d/full.h5" "$d/cut.h5" <<'PY'
import sys, h5py, numpy as np
a, b = (h5py.File(p, "r")["/sweep"] for p in sys.argv[1:])
ka, kb = np.argsort(a["index"][()]), np.argsort(b["index"][()])
assert (a["index"][()][ka] == b["index"][()][kb]).all(), "the resumed sweep ran other speeds"
for k in ("omega", "rms", "spectrum", "energy_balance", "order_amplitude"):
    assert np.array_equal(a[k][()][ka], b[k][()][kb], equal_nan=True), "resumed %s differs" % k
print("resumed: the same %d speeds, bitwise" % len(ka))
PY

# Bad refinement options: refused, naming them, nothing written.
refused() {
  set +e
  out=$(run "${sweep[@]}" "$@" -out "$d/bad.h5" 2>&1)
  rc=$?
  set -e
  test $rc -ne 0 || { echo "case: FAIL: accepted: $*"; exit 1; }
  test ! -e "$d/bad.h5" || { echo "case: FAIL: $d/bad.h5 written"; exit 1; }
  grep -q -F -- "$pattern" <<<"$out" || { echo "case: FAIL: '$pattern' not in: $out"; exit 1; }
}
pattern="-sweep_refine_step 800 rad/s is not below the grid's step -sweep_omega_step 400"
refused -sweep_refine_step 800
pattern="-sweep_omega_step 400 / -sweep_refine_step 30 = 13.3333 is not a power of two"
refused -sweep_refine_step 30
pattern="-sweep_refine_rms and -sweep_refine_frequency must be > 0"
refused -sweep_refine_rms 0
pattern="-sweep_refine_orders: engine order 30 is not among those measured, 1..-sweep_orders 24"
refused -sweep_refine_orders 30
# The model rebuilt at the same path with other damping: its file is not resumed, nothing changed.
cp "$d/full.h5" "$d/before.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none \
  -nlrom_damping_modal 0.02 -nlrom_damping_modes all -mesh_node_sets tipnode -mesh_node_set_tipnode "$tip" \
  -out "$d/cb.h5"
set +e
out=$(run "${sweep[@]}" -out "$d/full.h5" 2>&1)
rc=$?
set -e
test $rc -ne 0 || { echo "case: FAIL: a sweep of another model was resumed"; exit 1; }
grep -q "holds a sweep with other settings (model: " <<<"$out" || { echo "case: FAIL: model not named: $out"; exit 1; }
cmp -s "$d/full.h5" "$d/before.h5" || { echo "case: FAIL: the file was changed"; exit 1; }
echo "case: ok: refined sweep (RMS and lines), resumed whole and after a cut, bad options and another model refused"
