#!/usr/bin/env bash
# Fuzzes morse's file readers with libFuzzer (clang++ -fsanitize=fuzzer,address,undefined):
# builds the targets of bench/fuzz (fuzz_*.cpp, a CMake project of its own in build-fuzz/, not
# part of the normal build nor of run/test), seeds a corpus per target from meshes/, tests/data
# and bench/fuzz/seeds (copied at run time into build-fuzz/corpus/, never committed), runs each
# target for the given time and writes a JSON summary to bench/results/fuzz_<UTC time>.json:
# per target its executions, the crashes found and their files (build-fuzz/crashes/<target>/).
# A reader may refuse an input only with morse::Error (or its documented error return): a crash,
# a sanitizer report, an uncaught exception, a hang (-timeout=10) or more than 2 GB of memory
# (-rss_limit_mb=2048) is a finding.
# Usage: bench/fuzz/run.sh [-t SECONDS per target, default 600] [-j BUILD JOBS] [TARGET...]
#   TARGET: gmsh abaqus nastran mtx op4 load_csv h5_rom h5_nlrom h5_sweep (default: all)
# The HDF5 seeds (/rom, /nlrom, /sweep files) are written by build/morse on a tiny box if it is
# there (run/build); without it the HDF5 targets start from tests/data/*.h5 only.
# Installs clang and libclang-rt-14-dev with apt-get if they are missing.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
secs=600 jobs=$(nproc)
while getopts "t:j:" o; do
  case $o in
    t) secs=$OPTARG ;;
    j) jobs=$OPTARG ;;
    *) sed -n 2,16p "$0"; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
all=(gmsh abaqus nastran mtx op4 load_csv h5_rom h5_nlrom h5_sweep)
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all[@]}")

"$root/run/setup"
. "$root/run/env"
need=()
command -v clang++ >/dev/null || need+=(clang)
ls /usr/lib/llvm-*/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a >/dev/null 2>&1 || need+=(libclang-rt-14-dev)
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}"
fi

b="$root/build-fuzz"
CC=clang CXX=clang++ cmake -S "$root/bench/fuzz" -B "$b" -DCMAKE_BUILD_TYPE=None >/dev/null
cmake --build "$b" -j "$jobs" --target "${targets[@]/#/fuzz_}"

# Seeds.
corpus="$b/corpus"
rm -rf "$corpus" && mkdir -p "$corpus"
seed() {  # seed TARGET FILES...
  local t=$1; shift
  mkdir -p "$corpus/$t"
  for f in "$@"; do [ -f "$f" ] && cp "$f" "$corpus/$t/" || true; done
}
seed gmsh "$root"/tests/data/*.msh "$root"/meshes/*_coarse.msh
seed abaqus "$root"/tests/data/*.inp
seed nastran "$root"/tests/data/*.bdf
seed load_csv "$root"/tests/data/*.csv
for t in "${all[@]}"; do seed "$t" "$root"/bench/fuzz/seeds/"$t"/*; done
h5=()
morse="$root/build/morse"
if [ -x "$morse" ]; then
  g="$b/seedgen"
  rm -rf "$g" && mkdir -p "$g"
  # Node 5 is a corner of face x1 of this box (the sweep's monitor must be a set of one node).
  m=(-mesh "$g/box.msh" -clamp x0 -material_E 2.1e11 -material_nu 0.3 -material_rho 7800)
  (
    cd "$g"
    "$morse" mesh box -box_type hex8 -box_lx 4 -box_ly 1 -box_lz 1 -box_nx 4 -box_ny 1 -box_nz 1 -out box.msh
    "$morse" reduce "${m[@]}" -boundary x1 -cb_num_fixed_modes 2 -out rom.h5
    "$morse" export -export_from rom.h5 -export_format op4,mtx -out rom || true
    "$morse" nlrom "${m[@]}" -boundary x1 -nlrom_basis cb -nlrom_num_fixed_modes 2 -nlrom_forces exact \
      -mesh_node_sets tipnode -mesh_node_set_tipnode 5 -out nlrom.h5
    "$morse" sweep -rom nlrom.h5 -contact_set x1 -casing_clearance 2e-4 -casing_bump_height 6e-4 -casing_width 0.3 \
      -sim_dt 4e-6 -sim_revolutions 1 -sweep_omega_min 1000 -sweep_omega_max 1200 -sweep_omega_step 100 \
      -sweep_spectrum_fmax 3000 -sweep_spectrum_bins 4 -sweep_monitor tipnode -out sweep.h5
  ) >"$g/log" 2>&1 || echo "fuzz: some HDF5 seeds could not be generated (see $g/log)"
  seed h5_rom "$g/rom.h5"
  seed h5_nlrom "$g/nlrom.h5"
  seed h5_sweep "$g/sweep.h5"
  seed op4 "$g"/*.op4
  seed mtx "$g"/*.mtx
  seed gmsh "$g/box.msh"
fi
for t in h5_rom h5_nlrom h5_sweep; do seed "$t" "$root"/tests/data/*.h5; done

# Runs.
stamp=$(date -u +%Y-%m-%dT%H%M%SZ)
summary="$root/bench/results/fuzz_$stamp.json"
entries=()
for t in "${targets[@]}"; do
  exe="$b/fuzz_$t"
  crashes="$b/crashes/$t"
  mkdir -p "$crashes" "$corpus/$t"
  log="$b/fuzz_$t.log"
  echo "fuzz: $t for $secs s (log $log)"
  start=$(date +%s)
  # -fork=1: a crash does not end the run; the next input goes on (each crash is kept).
  ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$exe" "$corpus/$t" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
    -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix="$crashes/" >"$log" 2>&1 || true
  wall=$(($(date +%s) - start))
  execs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' | tail -1 || true)
  [ -n "$execs" ] || execs=$(grep -oE '#[0-9]+' "$log" | tail -1 | tr -d '#' || true)
  files=$(find "$crashes" -type f \( -name 'crash-*' -o -name 'timeout-*' -o -name 'oom-*' -o -name 'leak-*' \) | sort)
  n=$(printf '%s' "$files" | grep -c . || true)
  list=$(printf '%s\n' "$files" | grep . | sed "s|^$root/||; s|.*|\"&\"|" | paste -sd, - || true)
  echo "fuzz: $t: ${execs:-0} executions, $n crash files"
  entries+=("\"$t\": {\"seconds\": $wall, \"executions\": ${execs:-0}, \"crashes\": $n, \"files\": [${list}]}")
done
{
  echo "{\"benchmark\": \"fuzz\", \"utc\": \"$stamp\", \"seconds_per_target\": $secs, \"targets\": {"
  for i in "${!entries[@]}"; do
    sep=,; [ "$i" -eq $((${#entries[@]} - 1)) ] && sep=
    echo "  ${entries[$i]}$sep"
  done
  echo "}}"
} >"$summary"
echo "fuzz: summary in $summary"
