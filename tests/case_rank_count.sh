#!/usr/bin/env bash
# Case: a result does not depend on the rank count, also when ranks own no element or no
# constrained node. The tiny decks of tests/data (two_hex8.inp and two_hex8.bdf: 2 hex8, fewer
# elements than ranks on 3 and 4 ranks; four_hex8.inp: 4 hex8) run on 1, 2, 3 and 4 ranks:
#  - modes with -clamp '*BOUNDARY' (the deck's *BOUNDARY / SPC1) and with -clamp of a node set:
#    the same "N free DOFs, M clamped" line and the same frequencies (to round-off);
#  - reduce with -boundary TIP: the same fixed-interface and superelement frequencies;
#  - static with -load_sets TIP: the same displacement; fom with -load_history (a CSV table on the
#    tip nodes): the same energies.
# usage: case_rank_count.sh DIR MORSE DATA MPIEXEC [MPI FLAGS...]
set -euo pipefail
d=$1 morse=$2 data=$3 mpiexec=$4
shift 4
flags=("$@")
rm -rf "$d" && mkdir -p "$d"

# run NP OUT ARGS...: morse ARGS -out OUT on NP ranks; its output goes to OUT.log.
run() {
  local np=$1 out=$2
  shift 2
  "$mpiexec" "${flags[@]}" -n "$np" "$morse" "$@" -out "$out" >"$out.log" 2>&1 || {
    cat "$out.log"
    echo "case_rank_count: FAIL: morse $* on $np rank(s)"
    exit 1
  }
}

# same_line NAME REGEX: the line of the 1-rank run matching REGEX is in every run's log.
same_line() {
  local name=$1 regex=$2 ref
  ref=$(grep -E -- "$regex" "$d/${name}_np1.h5.log") || {
    echo "case_rank_count: FAIL: no /$regex/ in $d/${name}_np1.h5.log"
    exit 1
  }
  for np in 2 3 4; do
    grep -q -F -x -- "$ref" "$d/${name}_np${np}.h5.log" || {
      cat "$d/${name}_np${np}.h5.log"
      echo "case_rank_count: FAIL: $name on $np ranks does not print '$ref' (1 rank does)"
      exit 1
    }
  done
  echo "case_rank_count: ok: $name: '$ref' on 1-4 ranks"
}

inp2=("$data/two_hex8.inp") bdf2=("$data/two_hex8.bdf") inp4=("$data/four_hex8.inp")
for np in 1 2 3 4; do
  run $np "$d/modes_inp2_np$np.h5" modes -mesh "${inp2[@]}" -clamp '*BOUNDARY' -modes_nev 6
  run $np "$d/modes_bdf2_np$np.h5" modes -mesh "${bdf2[@]}" -clamp '*BOUNDARY' -modes_nev 6
  run $np "$d/modes_inp4_np$np.h5" modes -mesh "${inp4[@]}" -clamp '*BOUNDARY' -modes_nev 6
  run $np "$d/modes_set_np$np.h5" modes -mesh "${inp2[@]}" -clamp ROOT -modes_nev 6
  run $np "$d/reduce_np$np.h5" reduce -mesh "${inp4[@]}" -clamp '*BOUNDARY' -boundary TIP -cb_num_fixed_modes 4
  run $np "$d/static_np$np.h5" static -mesh "${inp2[@]}" -clamp '*BOUNDARY' -load_sets TIP -load_TIP_dir z \
    -load_TIP_amplitude 1e5
  run $np "$d/fom_np$np.h5" fom -mesh "${inp2[@]}" -clamp ROOT -load_history "$data/two_hex8_history.csv" \
    -fom_dt 1e-4 -fom_tfinal 1e-3
done
same_line modes_inp2 '^morse: 24 free DOFs, 12 clamped'
same_line modes_bdf2 '^morse: 24 free DOFs, 12 clamped'
same_line modes_inp4 '^morse: 48 free DOFs, 12 clamped'
same_line modes_set '^morse: 24 free DOFs, 12 clamped'
same_line reduce '^morse: Craig-Bampton superelement: 12 boundary DOFs'
same_line static '^morse: 24 free DOFs, 12 clamped'
same_line fom '^morse: 24 free DOFs, 12 clamped'

/usr/bin/python3 - "$d" <<'PY' || [ $? -eq 127 ]
import sys, h5py, numpy as np
d = sys.argv[1]
def close(name, dataset, tol):
    ref = np.asarray(h5py.File(f"{d}/{name}_np1.h5", "r")[dataset][:])
    for np_ in (2, 3, 4):
        a = np.asarray(h5py.File(f"{d}/{name}_np{np_}.h5", "r")[dataset][:])
        assert a.shape == ref.shape, (name, dataset, np_, a.shape, ref.shape)
        err = np.max(np.abs(a - ref)) / max(np.max(np.abs(ref)), 1e-300)
        assert err < tol, (name, dataset, np_, err)
    print(f"case_rank_count: ok: {name} {dataset} on 1-4 ranks")
for name in ("modes_inp2", "modes_bdf2", "modes_inp4", "modes_set"):
    close(name, "/fom/frequencies_hz", 1e-9)
ref = h5py.File(f"{d}/modes_inp2_np1.h5", "r")["/fom/frequencies_hz"][:]
bdf = h5py.File(f"{d}/modes_bdf2_np1.h5", "r")["/fom/frequencies_hz"][:]
assert np.max(np.abs(ref - bdf)) < 1e-9 * np.max(ref), ("inp vs bdf", ref, bdf)
close("reduce", "/cb/fixed_interface/frequencies_hz", 1e-9)
close("reduce", "/rom/frequencies_hz", 1e-9)
close("static", "/static/u", 1e-7)
close("fom", "/fom/energies/external_work", 1e-7)
close("fom", "/fom/energy", 1e-7)
PY
echo "case_rank_count: PASSED"
