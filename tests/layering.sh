#!/bin/bash
# The module layering of morse, checked by ctest (`layering`): a module includes only itself and
# the modules below it in kOrder (lowest first). Scans include/morse/<module>/ and src/<module>/
# for `#include "morse/<module>/..."` or `<morse/<module>/...>` (public headers) and
# `#include "<module>/..."` (private headers, src/<module>/detail/); tests/, apps/ and bench/ may
# include anything. Also checks that
# kOrder names exactly the module directories of src/ and include/morse/, so that a new module
# must be placed in the order. Prints every violation as file:line and exits 1.
#
#   tests/layering.sh [source dir]   check the tree (default: the directory above this script)
#   tests/layering.sh --self-test    check that a violation in a scratch tree is caught
#
# Needs bash, grep and sed only.
set -u

kOrder=(core mesh fe eigen cb io select dyn nlrom sim eval rampup app)


check_tree() {
  local root=$1 fail=0 i m d
  declare -A rank
  for i in "${!kOrder[@]}"; do rank[${kOrder[$i]}]=$i; done

  # The order names every module directory, and only those.
  declare -A seen
  for d in "$root"/src/*/ "$root"/include/morse/*/; do
    [[ -d $d ]] || continue
    m=$(basename "$d")
    seen[$m]=1
    if [[ -z ${rank[$m]+x} ]]; then
      echo "layering: module directory ${d#"$root"/} is not in the order of tests/layering.sh (kOrder); place it"
      fail=1
    fi
  done
  for m in "${kOrder[@]}"; do
    if [[ -z ${seen[$m]+x} ]]; then
      echo "layering: module '$m' of the order (tests/layering.sh kOrder) has no src/$m or include/morse/$m directory"
      fail=1
    fi
  done

  # Every include of a module by a module.
  local file line text rel from target
  while IFS= read -r hit; do
    file=${hit%%:*}
    hit=${hit#*:}
    line=${hit%%:*}
    text=${hit#*:}
    rel=${file#"$root"/}
    case $rel in
      src/*/*) from=${rel#src/} ;;
      include/morse/*/*) from=${rel#include/morse/} ;;
      *) continue ;;
    esac
    from=${from%%/*}
    target=$(sed -E 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*("(morse\/)?|<morse\/)([^/">]+)\/.*/\3/' <<<"$text")
    [[ -n ${rank[$target]+x} && -n ${rank[$from]+x} ]] || continue
    ((rank[$target] <= rank[$from])) && continue
    echo "$rel:$line: module '$from' includes module '$target', which is above it in the order ${kOrder[*]}: $text"
    fail=1
  done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*("[^/"]+/|<morse/)' --include='*.hpp' --include='*.h' \
             --include='*.cpp' "$root/src" "$root/include/morse" 2>/dev/null)
  return $fail
}

self_test() {
  local tmp m out
  tmp=$(mktemp -d) || exit 1
  trap 'rm -rf "$tmp"' RETURN
  for m in "${kOrder[@]}"; do mkdir -p "$tmp/src/$m" "$tmp/include/morse/$m"; done
  mkdir -p "$tmp/include/morse/cb" "$tmp/tests"
  printf '#include "morse/eigen/eigen.hpp"\n' >"$tmp/include/morse/cb/craig_bampton.hpp"
  printf '#include "morse/core/error.hpp"\n#include "eigen/detail/testing.hpp"\n' >"$tmp/src/cb/ok.cpp"
  printf '#include "morse/app/anything.hpp"\n' >"$tmp/tests/test_any.cpp"
  if ! out=$(check_tree "$tmp"); then
    echo "layering self-test: a tree without violation was refused:"
    echo "$out"
    return 1
  fi
  printf '// a comment\n#include "morse/fe/element.hpp"\n' >"$tmp/src/mesh/bad.cpp"
  printf '#include "sim/contact.hpp"\n' >"$tmp/src/dyn/bad_private.cpp"
  printf '#include <morse/rampup/rampup.hpp>\n' >"$tmp/include/morse/io/bad_angle.hpp"
  mkdir -p "$tmp/src/newmodule"
  if out=$(check_tree "$tmp"); then
    echo "layering self-test: violations were not caught"
    return 1
  fi
  local want
  for want in "src/mesh/bad.cpp:2: module 'mesh' includes module 'fe'" \
              "src/dyn/bad_private.cpp:1: module 'dyn' includes module 'sim'" \
              "include/morse/io/bad_angle.hpp:1: module 'io' includes module 'rampup'" \
              "module directory src/newmodule/ is not in the order"; do
    if [[ $out != *"$want"* ]]; then
      echo "layering self-test: '$want' not reported in:"
      echo "$out"
      return 1
    fi
  done
  echo "layering self-test: violations caught"
}

if [[ ${1:-} == --self-test ]]; then
  self_test
  exit $?
fi
root=${1:-$(cd "$(dirname "$0")/.." && pwd)}
if check_tree "$root"; then
  echo "layering: every module includes only modules below it (${kOrder[*]})"
  exit 0
fi
exit 1
