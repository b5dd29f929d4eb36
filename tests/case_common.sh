# Sourced by the case_*.sh chains: their common arguments and helpers.
#   . "$(dirname "$0")/case_common.sh" "$@"    with  DIR MORSE NP BOX MPIEXEC [MPI FLAGS...] -- [MATERIAL OPTIONS...]
# Sets d, morse, np, box, mpiexec, flags, material and model (the box clamped at x0), empties DIR,
# and defines run (morse on NP ranks) and expect_error.
d=$1 morse=$2 np=$3 box=$4 mpiexec=$5
shift 5
flags=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do flags+=("$1"); shift; done
shift
material=("$@")
run() { "$mpiexec" "${flags[@]}" -n "$np" "$morse" "$@"; }
rm -rf "$d" && mkdir -p "$d"
model=(-mesh "$box" -clamp x0 "${material[@]}")

# expect_error PATTERN FILE COMMAND ARGS...: morse COMMAND ARGS -out FILE must fail, print PATTERN
# and leave no FILE.
expect_error() {
  local pattern=$1 file=$2
  shift 2
  set +e
  out=$(run "$@" -out "$file" 2>&1)
  rc=$?
  set -e
  test $rc -ne 0
  grep -q -- "$pattern" <<<"$out" || { echo "missing '$pattern' in: $out"; exit 1; }
  test ! -e "$file"
}
