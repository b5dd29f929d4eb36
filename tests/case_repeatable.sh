#!/usr/bin/env bash
# Case: -factor_repeatable makes the same command on 2 ranks give the same bits (issue 26 item 8).
# Without it, MUMPS's parallel solves change their last bits from run to run (bench/
# mumps_repeat.sh; on the 60k-DOF blade 4 runs of `modes` gave 4 bit patterns). Each command
# below runs 3 times on 2 ranks with -factor_repeatable and every floating-point dataset of its
# output (all but /meta) must have one bit pattern:
#  - modes on the 60k-DOF blade (meshes/blade.msh): the block eigen solver's factor, its
#    MatMatSolve and the Sylvester check;
#  - static -static_linear on the coarse blade: the factor behind a KSP (PCCHOLESKY);
#  - reduce (Craig-Bampton, constraint modes solved on the eigen solver's factor) and the README's
#    nlrom (CB + modal derivatives, STEP) on the coarse blade.
# usage: case_repeatable.sh DIR MORSE MPIEXEC [MPI FLAGS...]
set -euo pipefail
d=$1 morse=$2 mpiexec=$3
shift 3
flags=("$@")
meshes=$(cd "$(dirname "$0")/.." && pwd)/meshes
rm -rf "$d" && mkdir -p "$d"

run() {
  local out=$1
  shift
  "$mpiexec" "${flags[@]}" -n 2 "$morse" "$@" -factor_repeatable -out "$out" >"$out.log" 2>&1 || {
    cat "$out.log"
    echo "case_repeatable: FAIL: morse $* -factor_repeatable on 2 ranks"
    exit 1
  }
}

for i in 1 2 3; do
  run "$d/modes_$i.h5" modes -mesh "$meshes/blade.msh" -clamp root -modes_nev 12
  run "$d/static_$i.h5" static -mesh "$meshes/blade_coarse.msh" -clamp root -static_linear -load_sets tip \
    -load_tip_dir y -load_tip_amplitude 1
  run "$d/reduce_$i.h5" reduce -mesh "$meshes/blade_coarse.msh" -clamp root -boundary tip -cb_num_fixed_modes 10
  run "$d/nlrom_$i.h5" nlrom -mesh "$meshes/blade_coarse.msh" -clamp root -boundary LE -nlrom_basis cbmd \
    -nlrom_num_fixed_modes 4 -nlrom_num_derivatives 13 -load_sets LE -load_LE_dir y -load_LE_amplitude 300 \
    -load_LE_omega 2000 -nlrom_training_tfinal 0.0314
done

/usr/bin/python3 - "$d" <<'PY'
import sys, hashlib, h5py, numpy as np
d = sys.argv[1]
def digests(path):
    out = {}
    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f" and not name.startswith("meta"):
            out[name] = hashlib.sha1(np.ascontiguousarray(obj[()]).tobytes()).hexdigest()
    with h5py.File(path, "r") as h:
        h.visititems(visit)
    return out
for cmd in ("modes", "static", "reduce", "nlrom"):
    runs = [digests(f"{d}/{cmd}_{i}.h5") for i in (1, 2, 3)]
    assert runs[0], f"{cmd}: no floating-point dataset"
    for name in runs[0]:
        patterns = {r.get(name) for r in runs}
        assert len(patterns) == 1, f"case_repeatable: FAIL: {cmd} /{name}: {len(patterns)} bit patterns in 3 runs"
    print(f"case_repeatable: ok: {cmd}: {len(runs[0])} datasets, one bit pattern in 3 runs on 2 ranks")
PY
