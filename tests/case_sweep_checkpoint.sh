#!/usr/bin/env bash
# Corrupt sweep checkpoints are refused, not resumed: a tiny sweep of 11 speeds is run, then copies
# of its file are damaged with h5py (a per-speed dataset with 3 rows, every dataset with a
# duplicated speed, an index given twice, an index outside the grid, a spectrum of another shape,
# /sweep@n_done off) and the same sweep is run on each. Each run must fail naming the file and the
# dataset, and leave the file byte for byte as it was. The intact file resumes with every speed
# done. The first run's summary names the kernel and, on 2 ranks, each rank's idle share.
# Skipped (77) without /usr/bin/python3 and h5py.
# usage: case_sweep_checkpoint.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
/usr/bin/python3 -c "import h5py, numpy" 2>/dev/null || { echo "case: skipped: no python3 with h5py"; exit 77; }
. "$(dirname "$0")/case_common.sh" "$@"
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact -out "$d/cb0.h5"
tip=$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/cb0.h5','r')['/nlrom/node_sets/x1'][0])")
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -mesh_node_sets tipnode -mesh_node_set_tipnode "$tip" -out "$d/cb.h5"
sweep=(sweep -rom "$d/cb.h5" -contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3
       -sim_dt 4e-6 -sim_revolutions 2 -sweep_omega_min 1000 -sweep_omega_max 2000 -sweep_omega_step 100
       -sweep_monitor tipnode -sweep_spectrum_fmax 3000 -sweep_spectrum_bins 10)
out=$(run "${sweep[@]}" -out "$d/good.h5")
echo "$out" | tail -3
# The summary names the kernel (a CB model with exact tensors has a potential: the batched
# potential kernel by default, in the widest build of the processor), and, on several ranks, each
# rank's idle share.
grep -Eq "in the force kernels \(potential, (AVX-512 \(x86-64-v4\)|AVX2 \+ FMA \(x86-64-v3\)|baseline x86-64)\)" \
  <<<"$out" || { echo "case: FAIL: no potential kernel and build in: $out"; exit 1; }
if [ "$np" -gt 1 ]; then
  grep -Eq "idle per rank: 0: [0-9]+%, 1: [0-9]+%" <<<"$out" || { echo "case: FAIL: no idle share per rank"; exit 1; }
fi

# corrupt NAME PYTHON: $d/NAME.h5 is a copy of the good file, changed by the python code (f is the
# open file, s its /sweep group).
corrupt() {
  cp "$d/good.h5" "$d/$1.h5"
  /usr/bin/python3 - "$d/$1.h5" <<PY
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r+")
s = f["/sweep"]
def replace(name, data):
    del s[name]
    s[name] = data
$2
f.close()
PY
}
per_speed="index omega status steps t_final rms mean max_displacement time_of_max max_contact_force
  time_of_max_contact_force max_node_force max_active seconds spectrum"

corrupt rms_3_rows 'replace("rms", s["rms"][:3])'
corrupt index_12_of_11 "
for k in '''$per_speed'''.split():
    a = s[k][()]
    replace(k, np.concatenate([a, a[:1]]))
s.attrs['n_done'] = 12"
corrupt index_twice 'a = s["index"][()]; a[5] = a[4]; replace("index", a)'
corrupt index_outside 'a = s["index"][()]; a[10] = 42; replace("index", a)'
corrupt spectrum_shape 'replace("spectrum", s["spectrum"][:, :5])'
corrupt n_done 's.attrs["n_done"] = 5'

# refused NAME PATTERN: the sweep on $d/NAME.h5 fails, printing PATTERN (after the file's name),
# and leaves the file unchanged.
refused() {
  local f="$d/$1.h5" pattern=$2
  cp "$f" "$d/before.h5"
  set +e
  out=$(run "${sweep[@]}" -out "$f" 2>&1)
  rc=$?
  set -e
  echo "$out" | tail -2
  test $rc -ne 0 || { echo "case: FAIL: $1: the corrupt checkpoint was resumed"; exit 1; }
  grep -q -F -- "$f: $pattern" <<<"$out" || { echo "case: FAIL: $1: '$f: $pattern' not in: $out"; exit 1; }
  grep -q "already in" <<<"$out" && { echo "case: FAIL: $1: resumed"; exit 1; }
  cmp -s "$f" "$d/before.h5" || { echo "case: FAIL: $1: the file was changed"; exit 1; }
  if compgen -G "$f.tmp*" > /dev/null; then echo "case: FAIL: $1: temporary left"; exit 1; fi
}
refused rms_3_rows '/sweep/rms has shape [3], expected [11] for the 11 finished speeds of /sweep/index'
refused index_12_of_11 '/sweep/index holds 12 finished speeds of a grid of 11'
refused index_twice '/sweep/index holds speed 4 twice'
refused index_outside '/sweep/index[10] = 42 is outside the speed grid 0..10'
refused spectrum_shape '/sweep/spectrum has shape [11 x 5], expected [11 x 11]'
refused n_done '/sweep@n_done is 5 but /sweep/index holds 11 finished speeds'

# The intact file resumes with every speed done.
out=$(run "${sweep[@]}" -out "$d/good.h5")
grep -q "(11 already in $d/good.h5)" <<<"$out"

# Continuation (-sweep_continuation up, 2 chains): every speed but each chain's first starts from
# its neighbour below (/sweep/continuation), every final state is kept; a file cut back to the
# first speeds of each chain (a killed run) resumes to bitwise the uninterrupted results; the
# plain sweep's file is not resumed as a continuation (the settings differ, named).
cont=("${sweep[@]}" -sweep_continuation up -sweep_chains 2)
out=$(run "${cont[@]}" -out "$d/cont.h5")
grep -q "continuation up" <<<"$out" || { echo "case: FAIL: no continuation notice in: $out"; exit 1; }
/usr/bin/python3 - "$d/cont.h5" "$d/cut.h5" <<'PY'
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
s = f["/sweep"]
idx = s["index"][()]
frm = s["continuation"][:, 0]
want = [-1 if i in (0, 5) else i - 1 for i in idx]  # chains 0..4 and 5..10
assert list(frm) == want, (list(frm), want)
fs = s["final_state"][()]
assert np.all(np.isfinite(fs)) and fs.shape[0] == 11 and fs.shape[1] % 2 == 1, fs.shape
# The same file with speeds 3, 4, 8, 9, 10 removed: a run killed after speed 2 and speed 7.
g = h5py.File(sys.argv[2], "w")
f.copy("/sweep", g)
for k in list(f.keys()):
    if k != "sweep":
        f.copy(k, g)
for k, v in f.attrs.items():
    g.attrs[k] = v
keep = np.isin(idx, [0, 1, 2, 5, 6, 7])
t = g["/sweep"]
for k in list(t.keys()):
    d = t[k]
    if isinstance(d, h5py.Dataset) and d.shape and d.shape[0] == 11 and k not in ("frequency", "eigenfrequencies"):
        a = d[()][keep]
        del t[k]
        t[k] = a
t.attrs["n_done"] = int(keep.sum())
g.close()
print("case: continuation origins and final states ok")
PY
out=$(run "${cont[@]}" -out "$d/cut.h5")
grep -q "(6 already in $d/cut.h5)" <<<"$out" || { echo "case: FAIL: the cut file did not resume: $out"; exit 1; }
/usr/bin/python3 - "$d/cont.h5" "$d/cut.h5" <<'PY'
import sys, h5py, numpy as np
a, b = (h5py.File(p, "r")["/sweep"] for p in sys.argv[1:3])
for k in ("index", "rms", "spectrum", "continuation", "final_state"):
    assert np.array_equal(a[k][()], b[k][()]), k
print("case: resumed continuation is bitwise the uninterrupted one")
PY
# Both ways in one sweep (-sweep_continuation both): 22 runs, indices 0..10 are the up sweep's
# (bitwise those of cont.h5), 11..21 the down sweep's, each from its neighbour above.
out=$(run "${sweep[@]}" -sweep_continuation both -sweep_chains 2 -out "$d/both.h5")
grep -q "continuation both ways" <<<"$out" || { echo "case: FAIL: no both-ways notice in: $out"; exit 1; }
/usr/bin/python3 - "$d/cont.h5" "$d/both.h5" <<'PY'
import sys, h5py, numpy as np
up, both = (h5py.File(p, "r")["/sweep"] for p in sys.argv[1:3])
idx = both["index"][()]
assert sorted(idx) == list(range(22)), idx
o = np.argsort(idx)
for k in ("rms", "spectrum", "final_state"):
    assert np.array_equal(both[k][()][o][:11], up[k][()][np.argsort(up["index"][()])]), k
frm = both["continuation"][()][o][:, 0]
want = [-1 if i in (0, 5) else i - 1 for i in range(11)] + [-1 if i in (15, 21) else i + 1 for i in range(11, 22)]
assert list(frm) == want, (list(frm), want)
print("case: both ways: the up half is the up sweep bitwise, the down half continues downwards")
PY
set +e
out=$(run "${cont[@]}" -out "$d/good.h5" 2>&1)
rc=$?
set -e
test $rc -ne 0 || { echo "case: FAIL: a plain sweep's file was resumed as a continuation"; exit 1; }
grep -q "continuation: (none) in the file, up now" <<<"$out" || { echo "case: FAIL: not named: $out"; exit 1; }

# One BLAS thread per rank: given a threaded OpenBLAS (2 threads, the rank not bound to a core, so
# OpenBLAS may use them), the sweep sets it to 1 and says so. Only where morse uses OpenBLAS and
# the machine has 2 CPUs; on one rank (the notice is the same on every rank count).
if [ "$np" -eq 1 ] && ldd "$morse" | grep -q openblas && [ "$(nproc)" -ge 2 ]; then
  out=$(OPENBLAS_NUM_THREADS=2 "$mpiexec" "${flags[@]}" --bind-to none -x OPENBLAS_NUM_THREADS -n 1 "$morse" \
        "${sweep[@]}" -sweep_restart -out "$d/blas.h5")
  grep -q "OpenBLAS set to 1 thread per rank (it had 2)" <<<"$out" || { echo "case: FAIL: no BLAS notice: $out"; exit 1; }
  echo "case: BLAS threads set to 1"
fi
echo "case: ok: corrupt sweep checkpoints refused, files unchanged; continuation resumed"
