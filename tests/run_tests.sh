#!/usr/bin/env bash
# Run every test program (plain and sanitized builds) and every end-to-end
# script; each ends with "N passed, N failed". Sum them, print the total as
# the closing line, and exit non-zero if anything failed or did not report.
set -uo pipefail
BUILD=${1:-build}; SAN=${2:-build/san}
export PLOTKIN_BUILD=$BUILD PLOTKIN_SAN=$SAN
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
tp=0; tf=0; bad=()
run() {  # name, command...
  local name=$1; shift
  local out rc last p f
  out=$("$@" 2>&1); rc=$?
  last=$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1)
  if [[ -z $last ]]; then
    printf '%s\n' "$out" | tail -n 20
    echo "FAIL $name: no result line (exit $rc)"; tf=$((tf+1)); bad+=("$name"); return
  fi
  p=${last%% passed*}; f=${last#*, }; f=${f%% failed*}
  tp=$((tp+p)); tf=$((tf+f))
  if [[ $rc -ne 0 || $f -ne 0 ]]; then
    printf '%s\n' "$out" | grep -E 'FAIL|not ok|ERROR|runtime error|Sanitizer' | head -n 30
    bad+=("$name"); [[ $f -eq 0 ]] && { tf=$((tf+1)); echo "FAIL $name: exit $rc"; }
  fi
  printf '%-40s %s\n' "$name" "$last"
}
for t in "$BUILD"/tests/test_*; do [[ -x $t ]] && run "$(basename "$t")" "$t"; done
for t in "$SAN"/tests/test_*; do [[ -x $t ]] && run "san/$(basename "$t")" "$t"; done
for s in tests/e2e_*.sh; do [[ -f $s ]] && run "$(basename "$s")" bash "$s"; done
for s in tests/extra/*.sh; do [[ -f $s ]] && run "$(basename "$s")" bash "$s"; done
echo "----"
[[ ${#bad[@]} -gt 0 ]] && echo "failing: ${bad[*]}"
echo "$tp passed, $tf failed"
[[ $tf -eq 0 ]]
