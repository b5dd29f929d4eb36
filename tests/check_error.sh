#!/usr/bin/env bash
# Error-case check for the ctest "case" tests.
#
# usage: check_error.sh [--copy SRC DST]... [--link LINK TARGET]... [--unchanged FILE]...
#                       <expected-regex> <output-file> -- <command...>
#
# Removes <output-file> (and its temporaries <output-file>.tmp*), runs the command under `timeout`,
# and passes only if
#   - the command exits with a non-zero status that is not a timeout (a hang fails the case),
#     a signal, or "command could not be run";
#   - its stdout+stderr matches <expected-regex> (grep -E);
#   - neither <output-file> nor a temporary <output-file>.tmp* exists afterwards.
# Inputs the command must leave alone (an -out that names an input, a sweep checkpoint):
#   --copy SRC DST     copies SRC to DST (creating its directory) first; DST must still be SRC, byte
#                      for byte, afterwards;
#   --link LINK TARGET makes LINK a symbolic link to TARGET first;
#   --unchanged FILE   FILE must be byte for byte the same afterwards.
# An <output-file> that is one of these (or a link to one) is not removed and must stay as it was.
# CHECK_ERROR_TIMEOUT (seconds, default 90; ctest kills a case after 120 s) sets the time limit.
set -u

keep_dir=$(mktemp -d "${TMPDIR:-/tmp}/check_error_keep.XXXXXX")
trap 'rm -rf "$keep_dir"' EXIT
kept=()  # files that must not change
links=()
while [ $# -gt 0 ]; do
  case $1 in
    --copy) mkdir -p "$(dirname "$3")" && rm -f "$3" && cp "$2" "$3" || exit 2; kept+=("$3"); shift 3 ;;
    --link) mkdir -p "$(dirname "$2")" && ln -sfn "$3" "$2" || exit 2; links+=("$2"); shift 3 ;;
    --unchanged) kept+=("$2"); shift 2 ;;
    *) break ;;
  esac
done
if [ $# -lt 4 ] || [ "$3" != "--" ]; then
  echo "usage: check_error.sh [--copy SRC DST]... [--link LINK TARGET]... [--unchanged FILE]... <expected-regex> <output-file> -- <command...>" >&2
  exit 2
fi
regex=$1
out=$2
shift 3
limit=${CHECK_ERROR_TIMEOUT:-90}

out_is_input=0
for f in "${kept[@]}" "${links[@]}"; do [ "$f" = "$out" ] && out_is_input=1; done
for i in "${!kept[@]}"; do cp "${kept[$i]}" "$keep_dir/$i" || exit 2; done
mkdir -p "$(dirname "$out")"
[ "$out_is_input" -eq 1 ] || rm -f "$out"
rm -f "$out".tmp*
log=$keep_dir/log

echo "check_error: command: $*"
timeout --kill-after=10 "$limit" "$@" >"$log" 2>&1
rc=$?
echo "---- output (stdout+stderr) ----"
cat "$log"
echo "--------------------------------"

fail=0
if [ "$rc" -eq 0 ]; then
  echo "check_error: FAIL: exit status 0, expected a failure"
  fail=1
elif [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
  echo "check_error: FAIL: exit status $rc: timed out after ${limit} s (hang)"
  fail=1
elif [ "$rc" -eq 125 ] || [ "$rc" -eq 126 ] || [ "$rc" -eq 127 ]; then
  echo "check_error: FAIL: exit status $rc: the command could not be run"
  fail=1
elif [ "$rc" -gt 128 ]; then
  echo "check_error: FAIL: exit status $rc: killed by signal $((rc - 128)) (crash, not a clean error)"
  fail=1
else
  echo "check_error: ok: exit status $rc (non-zero, no timeout)"
fi

if grep -E -q -e "$regex" "$log"; then
  echo "check_error: ok: output matches /$regex/"
else
  echo "check_error: FAIL: output does not match /$regex/"
  fail=1
fi

if [ "$out_is_input" -eq 0 ]; then
  if [ -e "$out" ]; then
    echo "check_error: FAIL: $out exists after the failed run"
    fail=1
  else
    echo "check_error: ok: no $out"
  fi
fi
for f in "$out".tmp*; do
  if [ -e "$f" ]; then
    echo "check_error: FAIL: the temporary $f exists after the failed run"
    fail=1
  fi
done
for i in "${!kept[@]}"; do
  if cmp -s "${kept[$i]}" "$keep_dir/$i"; then
    echo "check_error: ok: ${kept[$i]} unchanged"
  else
    echo "check_error: FAIL: ${kept[$i]} was changed (or removed) by the failed run"
    fail=1
  fi
done
for f in "${links[@]}"; do
  if [ -L "$f" ]; then
    echo "check_error: ok: $f is still a link"
  else
    echo "check_error: FAIL: the link $f was replaced"
    fail=1
  fi
done

if [ "$fail" -ne 0 ]; then
  echo "check_error: FAILED"
  exit 1
fi
echo "check_error: PASSED"
exit 0
