#!/bin/bash
# Submits a chain of N sweep jobs (run/cluster/sweep.sbatch) on one output file: each starts when
# the previous one has ended, whatever its status (--dependency=afterany), and resumes the sweep
# from its checkpoint. Pick N from the predicted cost that `morse sweep` prints at its start (core-
# hours / (ranks x hours per job)), plus one or two for the refinement rounds and for failures.
#
#   run/cluster/submit_sweep.sh N MORSE OPTIONS_FILE OUT.h5 [sbatch options ...] [-- morse options ...]
#
# Example (the seed's nonlinear map, 32 ranks, 12-hour jobs):
#   run/cluster/submit_sweep.sh 4 $PWD/build/morse run/cluster/example.opts maps/nonlinear.h5 \
#       --ntasks=32 --time=12:00:00 -- -sweep_rotation positive
set -euo pipefail
if [ $# -lt 4 ]; then
  sed -n '2,12p' "$0" >&2
  exit 2
fi
n=$1 morse=$2 opts=$3 out=$4
shift 4
sbatch_opts=() morse_opts=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do sbatch_opts+=("$1"); shift; done
[ $# -gt 0 ] && shift
morse_opts=("$@")
case "$n" in ''|*[!0-9]*) echo "submit_sweep.sh: N must be a positive number of jobs (got '$n')" >&2; exit 2 ;; esac
[ "$n" -ge 1 ] || { echo "submit_sweep.sh: N must be >= 1" >&2; exit 2; }
[ -x "$morse" ] || { echo "submit_sweep.sh: $morse is not an executable" >&2; exit 2; }
[ -r "$opts" ] || { echo "submit_sweep.sh: cannot read the options file $opts" >&2; exit 2; }
mkdir -p "$(dirname "$out")"
here=$(cd "$(dirname "$0")" && pwd)
dep=()
for ((i = 1; i <= n; ++i)); do
  id=$(sbatch --parsable "${dep[@]}" "${sbatch_opts[@]}" "$here/sweep.sbatch" "$morse" "$opts" "$out" \
       "${morse_opts[@]}")
  echo "job $i of $n: $id"
  dep=(--dependency=afterany:"$id")
done
