#!/usr/bin/env bash
# Formatting check (ctest `format`): every C++ file of the repository (src, include, apps, tests,
# bench) is as .clang-format formats it. clang-format is installed by run/setup; where it is
# missing the test is skipped (exit 77, ctest SKIP_RETURN_CODE), never passed silently.
# Usage: tests/format.sh [REPO]; to reformat: clang-format -i $(tests/format.sh --list)
set -u
root=${1:-$(cd "$(dirname "$0")/.." && pwd)}
list() {
  find "$root/src" "$root/include" "$root/apps" "$root/tests" "$root/bench" \
    \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' \) -type f | sort
}
if [[ ${1:-} == --list ]]; then root=$(cd "$(dirname "$0")/.." && pwd); list; exit 0; fi
cf=$(command -v clang-format || true)
if [[ -z $cf ]]; then
  echo "format: clang-format is not installed (run/setup installs it): skipped"
  exit 77
fi
# The tree is formatted with clang-format 14 (Debian 12); other majors format some constructs
# differently, so they skip (exit 77) instead of failing on code nobody changed.
major=$("$cf" --version | sed -n 's/.*version \([0-9]*\)\..*/\1/p')
if [[ $major != 14 ]]; then
  echo "format: clang-format $major found, the tree is formatted with clang-format 14: skipped"
  exit 77
fi
mapfile -t files < <(list)
bad=()
for f in "${files[@]}"; do
  "$cf" --style=file:"$root/.clang-format" --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("${f#"$root"/}")
done
if ((${#bad[@]})); then
  echo "format: ${#bad[@]} file(s) differ from .clang-format ($("$cf" --version)):"
  printf '  %s\n' "${bad[@]}"
  echo "reformat with: clang-format -i \$(tests/format.sh --list)"
  exit 1
fi
echo "format: ${#files[@]} files formatted as .clang-format says ($("$cf" --version))"
