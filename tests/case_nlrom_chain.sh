#!/usr/bin/env bash
# Case chain of the nonlinear reduced models: fom with snapshots -> nlrom (cb + exact tensors,
# cbmd + STEP, pod + STEP) -> simulate on each, then a simulate step above the critical one is
# refused with the limit and leaves no file.
# usage: case_nlrom_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
d=$1 morse=$2 np=$3 box=$4 mpiexec=$5
shift 5
flags=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do flags+=("$1"); shift; done
shift
material=("$@")
run() { "$mpiexec" "${flags[@]}" -n "$np" "$morse" "$@"; }
rm -rf "$d" && mkdir -p "$d"
model=(-mesh "$box" -clamp x0 "${material[@]}")
load=(-load_sets x1 -load_x1_dir y -load_x1_amplitude 1e6 -load_x1_omega 300)
run fom "${model[@]}" "${load[@]}" -fom_dt 1e-4 -fom_tfinal 2e-3 -fom_snapshot_every 2 -fom_monitor x1 \
  -out "$d/fom.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -nlrom_damping_modal 0.01 -nlrom_damping_modes 2 -out "$d/cb.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cbmd -nlrom_num_fixed_modes 2 -nlrom_num_derivatives 3 \
  "${load[@]}" -nlrom_training_tfinal 2e-3 -out "$d/cbmd.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis pod -nlrom_num_pod 3 -nlrom_snapshots "$d/fom.h5" \
  -nlrom_filter_pod 0 -out "$d/pod.h5"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_snapshots "$d/fom.h5" \
  -nlrom_filter_pod 4 -out "$d/cbfilter.h5"
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
/usr/bin/python3 - "$d/sim_long.h5" <<'PY' || [ $? -eq 127 ]
import sys, h5py
f = h5py.File(sys.argv[1], "r")
e, I = f["/compare/e"][:], f["/compare/I"][0]
assert all(0 <= x <= 1 for x in e) and 0.5 < I <= 1, (e, I)
PY
set +e
out=$(run simulate -rom "$d/cb.h5" -sim_dt 1 -sim_tfinal 10 -out "$d/bad.h5" 2>&1)
rc=$?
set -e
test $rc -ne 0
echo "$out" | grep -q 'above the critical step'
test ! -e "$d/bad.h5"
echo "case: ok: nlrom chain"
