#!/usr/bin/env bash
# Error-case check for the ctest "case" tests.
#
# usage: check_error.sh <expected-regex> <output-file> -- <command...>
#
# Removes <output-file> (and <output-file>.tmp), runs the command under `timeout`, and passes only if
#   - the command exits with a non-zero status that is not a timeout (a hang fails the case),
#     a signal, or "command could not be run";
#   - its stdout+stderr matches <expected-regex> (grep -E);
#   - neither <output-file> nor <output-file>.tmp exists afterwards.
# CHECK_ERROR_TIMEOUT (seconds, default 90; ctest kills a case after 120 s) sets the time limit.
set -u

if [ $# -lt 4 ] || [ "$3" != "--" ]; then
  echo "usage: check_error.sh <expected-regex> <output-file> -- <command...>" >&2
  exit 2
fi
regex=$1
out=$2
shift 3
limit=${CHECK_ERROR_TIMEOUT:-90}

mkdir -p "$(dirname "$out")"
rm -f "$out" "$out.tmp"
log=$(mktemp "${TMPDIR:-/tmp}/check_error.XXXXXX")
trap 'rm -f "$log"' EXIT

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

for f in "$out" "$out.tmp"; do
  if [ -e "$f" ]; then
    echo "check_error: FAIL: $f exists after the failed run"
    fail=1
  else
    echo "check_error: ok: no $f"
  fi
done

if [ "$fail" -ne 0 ]; then
  echo "check_error: FAILED"
  exit 1
fi
echo "check_error: PASSED"
exit 0
