#!/usr/bin/env bash
# A killed run stops writing, and two runs never write one output: a slow sweep is started in its
# own process group; the same sweep on the same -out is refused while it runs, naming the output
# and the pid of the first run's rank 0 (the lock <out>.lock, core/files.hpp). Then the first
# launcher's process group is killed with kill -9 (Open MPI's ranks are in process groups of their
# own, so they are not hit): within 1 s no rank of it may remain (each exits when its launcher
# dies, core/session.cpp), the checkpoint file must not change in the next 1.5 s, and the lock must
# be free. On one rank, a run without mpirun outlives the shell that started it. Skipped (77) without setsid, pgrep, stat, or /usr/bin/python3 with h5py.
# usage: case_sweep_lock.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
for tool in setsid pgrep stat; do
  command -v "$tool" > /dev/null || { echo "case: skipped: no $tool"; exit 77; }
done
/usr/bin/python3 -c "import h5py" 2>/dev/null || { echo "case: skipped: no python3 with h5py"; exit 77; }
. "$(dirname "$0")/case_common.sh" "$@"
fail() { echo "case: FAIL: $*"; exit 1; }
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact -out "$d/cb0.h5"
tip=$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/cb0.h5','r')['/nlrom/node_sets/x1'][0])")
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces exact \
  -mesh_node_sets tipnode -mesh_node_set_tipnode "$tip" -out "$d/cb.h5"
# Many slow speeds, one checkpoint each: it runs far longer than this test.
out="$d/locked.h5"
sweep=(sweep -rom "$d/cb.h5" -contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3
       -sim_dt 4e-6 -sim_revolutions 40 -sweep_omega_min 1000 -sweep_omega_max 30000 -sweep_omega_step 100
       -sweep_monitor tipnode -sweep_spectrum_fmax 3000 -sweep_spectrum_bins 10 -sweep_batch 1 -out "$out")

# The first run, its launcher leading a process group of its own (setsid execs in place: a
# background job of a script is no group leader).
setsid "$mpiexec" "${flags[@]}" -n "$np" "$morse" "${sweep[@]}" > "$d/first.log" 2>&1 &
first=$!
cleanup() { kill -9 -- "-$first" 2>/dev/null || true; pkill -9 -f -- "-out $out" 2>/dev/null || true; }
trap cleanup EXIT
for _ in $(seq 300); do [ -e "$out" ] && break; sleep 0.1; done
[ -e "$out" ] || { cat "$d/first.log"; fail "the first sweep wrote no checkpoint in 30 s"; }
ranks=$(pgrep -f -- "-out $out" | tr '\n' ' ')
echo "first run: launcher $first, processes $ranks"

# The second run on the same output is refused at its start, naming the output and a pid of the
# first run; the first one goes on.
set +e
msg=$(run "${sweep[@]}" 2>&1)
rc=$?
set -e
echo "$msg" | tail -2
[ $rc -ne 0 ] || fail "the second run on $out was not refused"
pattern="morse: error: $out is being written by another morse run \(pid [0-9]+\); wait for it or choose another -out"
grep -q -E -- "$pattern" <<<"$msg" || fail "'$pattern' not in: $msg"
holder=$(echo "$msg" | sed -n 's/.*another morse run (pid \([0-9]*\)).*/\1/p' | head -1)
case " $ranks " in *" $holder "*) ;; *) fail "pid $holder is not a process of the first run ($ranks)" ;; esac
kill -0 "$first" 2>/dev/null || { cat "$d/first.log"; fail "the first run ended before it was killed"; }

# kill -9 of the launcher's process group: its ranks stop within 1 s (about 0.3 s: the watchdog
# polls every 200 ms; without it Open MPI's ranks noticed after about 1.1 s, writing meanwhile)
# and write nothing more.
t0=$(date +%s%N)
kill -9 -- "-$first"
wait "$first" 2>/dev/null || true
gone=0
while [ $(($(date +%s%N) - t0)) -lt 2000000000 ]; do
  if ! pgrep -f -- "-out $out" > /dev/null; then gone=1; break; fi
  sleep 0.05
done
ms=$((($(date +%s%N) - t0) / 1000000))
echo "ranks gone $ms ms after the kill"
[ $gone -eq 1 ] || { pgrep -a -f -- "-out $out"; fail "ranks of the killed run still run 2 s after the kill"; }
[ "$ms" -le 1000 ] || fail "the ranks of the killed run stopped only $ms ms after the kill (at most 1000 ms)"
before=$(stat -c '%i %s %Y.%y' "$out")
sleep 1.5
after=$(stat -c '%i %s %Y.%y' "$out")
[ "$before" = "$after" ] || fail "$out was written after the run was killed: $before -> $after"
if command -v flock > /dev/null; then
  flock -n "$out.lock" true || fail "the lock $out.lock is still held after the run was killed"
fi

# A run without mpirun (a singleton) is not tied to its parent: it outlives the shell that started
# it (nohup), and holds its lock meanwhile.
if [ "$np" -eq 1 ]; then
  solo="$d/solo.h5"
  setsid bash -c '"$@" > /dev/null 2>&1 & echo $! > "'"$d/solo.pid"'"; sleep 2; kill -9 $$' _ \
    "$morse" "${sweep[@]:0:${#sweep[@]}-1}" "$solo" 2> /dev/null || true
  solo_pid=$(cat "$d/solo.pid")
  sleep 1
  kill -0 "$solo_pid" 2> /dev/null || fail "a morse run without mpirun died with the shell that started it"
  kill -9 "$solo_pid"
fi
trap - EXIT
echo "case: ok: the second run was refused (pid $holder); the killed run's ranks stopped, $out unchanged"
