#!/usr/bin/env bash
# The cluster recipe (run/cluster) without a cluster: fake `sbatch` and `srun` on PATH run each
# job at once on NP ranks. A chain of 3 jobs on one sweep: the first runs the sweep from an
# options file (with a morse option given after --), the next two resume it and find every speed
# done; the options file, the output and the extra option reach morse. A bad chain length is
# refused. Skipped (77) without /usr/bin/python3 and h5py.
# usage: case_cluster_chain.sh DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
set -euo pipefail
/usr/bin/python3 -c "import h5py" 2>/dev/null || { echo "case: skipped: no python3 with h5py"; exit 77; }
. "$(dirname "$0")/case_common.sh" "$@"
recipe=$(cd "$(dirname "$0")/../run/cluster" && pwd)
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none -out "$d/cb0.h5"
tip=$(/usr/bin/python3 -c "import h5py; print(h5py.File('$d/cb0.h5','r')['/nlrom/node_sets/x1'][0])")
run nlrom "${model[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 3 -nlrom_forces none \
  -mesh_node_sets tipnode -mesh_node_set_tipnode "$tip" -out "$d/cb.h5"
cat > "$d/map.opts" <<OPTS
-rom $d/cb.h5
-contact_set x1
-casing_clearance 2e-4
-casing_bump_height 6e-4
-casing_width 0.3
-sim_dt 4e-6
-sim_revolutions 2
-sim_linear
-sweep_omega_min 1000
-sweep_omega_max 1400
-sweep_omega_step 100
-sweep_spectrum_fmax 3000
-sweep_spectrum_bins 10
OPTS
# Fake SLURM: sbatch runs the job script now (its log in $d) and prints a job id; srun is mpiexec.
mkdir -p "$d/bin"
cat > "$d/bin/sbatch" <<FAKE
#!/usr/bin/env bash
n=\$(( \$(ls "$d"/job-*.log 2>/dev/null | wc -l) + 1 ))
echo "\$*" > "$d/job-\$n.args"
args=()
for a in "\$@"; do case "\$a" in --parsable|--dependency=*|--ntasks=*|--time=*) ;; *) args+=("\$a") ;; esac; done
SLURM_JOB_ID=\$n SLURM_NTASKS=$np bash "\${args[@]}" > "$d/job-\$n.log" 2>&1 || true
echo \$n
FAKE
cat > "$d/bin/srun" <<FAKE
#!/usr/bin/env bash
shift  # --kill-on-bad-exit=1
exec "$mpiexec" ${flags[*]} -n \$SLURM_NTASKS "\$@"
FAKE
chmod +x "$d/bin/sbatch" "$d/bin/srun"
PATH="$d/bin:$PATH" "$recipe/submit_sweep.sh" 3 "$morse" "$d/map.opts" "$d/maps/map.h5" --ntasks=$np --time=1:00:00 \
  -- -sweep_monitor tipnode > "$d/submit.log"
cat "$d/submit.log"
grep -q "job 3 of 3: 3" "$d/submit.log" || { echo "case: FAIL: not 3 jobs"; exit 1; }
grep -q -- "--dependency=afterany:1" "$d/job-2.args" || { echo "case: FAIL: job 2 not after job 1"; exit 1; }
grep -q -- "--dependency=afterany:2" "$d/job-3.args" || { echo "case: FAIL: job 3 not after job 2"; exit 1; }
grep -q "ended with status 0" "$d/job-1.log" || { echo "case: FAIL: job 1: $(cat "$d/job-1.log")"; exit 1; }
grep -q "(0 already in $d/maps/map.h5)" "$d/job-1.log" || { echo "case: FAIL: job 1 did not start the sweep"; exit 1; }
for j in 2 3; do
  grep -q "(5 already in $d/maps/map.h5)" "$d/job-$j.log" || { echo "case: FAIL: job $j did not resume"; exit 1; }
done
n=$(/usr/bin/python3 -c "import h5py; print(len(h5py.File('$d/maps/map.h5','r')['/sweep/index']))")
test "$n" -eq 5 || { echo "case: FAIL: $n speeds in the map"; exit 1; }
# A bad chain length is refused before anything is submitted.
set +e
out=$(PATH="$d/bin:$PATH" "$recipe/submit_sweep.sh" 0x "$morse" "$d/map.opts" "$d/maps/b.h5" 2>&1)
rc=$?
set -e
test $rc -ne 0 && grep -q "N must be a positive number of jobs" <<<"$out" || { echo "case: FAIL: $out"; exit 1; }
echo "case: ok: a chain of 3 jobs ran and resumed the sweep"
