#!/bin/bash
# bench/mumps_repeat.sh: does the same MUMPS factorization and solve give the same bits run after
# run (issue 26 item 8)? Compiles bench/mumps_repeat.cpp into a temporary directory (include and
# link flags from pkg-config: slepc, petsc, hdf5-openmpi, mpi-cxx; plus metis, lapack, blas, like
# build/morse's link line) against build/libmorse_lib.a, then for each mesh runs it N times per
# configuration and counts, per quantity, the distinct bit patterns over the N runs (1 = bitwise
# repeatable): K x, M x, and per sigma (K - sigma M) one MatSolve, the same solve repeated in the
# same run, a 16-column MatMatSolve. Configurations: the defaults on 1 and on 2 ranks, then on 2
# ranks each MUMPS option of VARIANTS below. Also records the largest difference from the first
# run (max |a - a_1| / max |a_1| over the quantity) and, from one extra run with ICNTL(4) = 2 per
# configuration, MUMPS's "Number of level 2 nodes" (fronts shared by several processes, whose
# slaves are chosen at run time) and the ordering effectively used. Not in VARIANTS: parallel
# analysis (ICNTL(28) = 2) aborts, Debian's MUMPS has neither PT-SCOTCH nor ParMETIS; PETSc 3.18
# does not pass ICNTL(48) or ICNTL(58); MUMPS's scheduling parameters (KEEP) are not reachable.
#
#     bench/mumps_repeat.sh [-n N] [-l LIB] [-v NAMES] [mesh.msh ...]   # default: N = 5, meshes/blade.msh
#
# -v: only the configurations named (comma-separated, e.g. defaults,repeatable). The last
# configuration, repeatable, is morse's -factor_repeatable (MUMPS on rank 0 alone,
# morse/core/factor.hpp): it must give one pattern for every quantity.
# -l: the morse library to link (default build/libmorse_lib.a of this checkout, else of
# /work/main). Prints a table and writes bench/results/mumps_repeat_<UTC>.json. At most 2 ranks.
set -euo pipefail
cd "$(dirname "$0")/.."
N=5 LIB= ONLY=
while getopts "n:l:v:" o; do case $o in n) N=$OPTARG ;; l) LIB=$OPTARG ;; v) ONLY=,$OPTARG, ;; *) exit 2 ;; esac; done
shift $((OPTIND - 1))
MESHES=("${@:-meshes/blade.msh}")
[ -n "$LIB" ] || for LIB in build/libmorse_lib.a /work/main/build/libmorse_lib.a; do [ -f "$LIB" ] && break; done
VARIANTS=("defaults|" "icntl13_1|-mat_mumps_icntl_13 1" "icntl24_0|-mat_mumps_icntl_24 0"
  "cntl1_0|-mat_mumps_cntl_1 0" "icntl14_100|-mat_mumps_icntl_14 100" "amd|-mat_mumps_icntl_7 0"
  "amf|-mat_mumps_icntl_7 2" "scotch|-mat_mumps_icntl_7 3" "pord|-mat_mumps_icntl_7 4"
  "metis|-mat_mumps_icntl_7 5" "qamd|-mat_mumps_icntl_7 6" "rhs_block_1|-mat_mumps_icntl_27 1"
  "repeatable|-factor_repeatable")
. run/env 2>/dev/null || . /work/main/run/env
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
TMP=$(mktemp -d /tmp/mumps_repeat.XXXXXX)
trap 'rm -rf "$TMP"' EXIT
PKG="slepc petsc hdf5-openmpi mpi-cxx"
RPATH=$(pkg-config --libs-only-L $PKG | sed 's/-L//g; s/ \+/:/g; s/:$//')
CXX_CMD="c++ -O2 -std=c++17 -Iinclude $(pkg-config --cflags $PKG | sed 's/-I/-isystem /g') bench/mumps_repeat.cpp \
-o $TMP/mumps_repeat $LIB -Wl,-rpath,$RPATH $(pkg-config --libs $PKG) -lmetis -llapack -lblas"
$CXX_CMD
for mesh in "${MESHES[@]}"; do
  for v in "${VARIANTS[@]}"; do
    name=${v%%|*} opts=${v#*|}
    [ -n "$ONLY" ] && [[ $ONLY != *",$name,"* ]] && continue
    for np in 1 2; do
      [ "$np" = 1 ] && [ "$name" != defaults ] && continue
      cfg="$TMP/$(basename "$mesh" .msh)_${name}_np$np"
      mpirun -n "$np" "$TMP/mumps_repeat" -mesh "$mesh" -clamp root -sigmas 0 $opts -mat_mumps_icntl_4 2 >"$cfg.diag"
      for i in $(seq "$N"); do
        mkdir -p "$cfg.$i"
        mpirun -n "$np" "$TMP/mumps_repeat" -mesh "$mesh" -clamp root -dump "$cfg.$i" $opts | grep '^{' >"$cfg.$i/run.json"
      done
      /usr/bin/python3 bench/mumps_repeat_summary.py config "$cfg" "$N" "$mesh" "$name" "$np" "$opts" >>"$TMP/configs.jsonl"
      rm -rf "$cfg".[0-9]*
    done
  done
done
/usr/bin/python3 bench/mumps_repeat_summary.py report "$TMP/configs.jsonl" "$N" "$CXX_CMD"
