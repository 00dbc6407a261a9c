#!/usr/bin/env bash
# run_fuzz.sh DIR SECONDS TARGET... — run each libFuzzer target in turn (one at
# a time: the build machines are shared) for SECONDS, seeded from
# tests/fuzz/corpus/<target>/, with tests/fuzz/<target>.dict if present.
# Prints one summary line per target (executions, new corpus size, result)
# and exits non-zero if any target found a crash or broken invariant; the
# input is then in DIR/artifacts/ (add it to the corpus as a regression input
# once the bug is fixed, see tests/fuzz/README.md).
set -uo pipefail
dir=$1; secs=$2; shift 2
mkdir -p "$dir/artifacts"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
fail=0
for t in "$@"; do
  seeds=tests/fuzz/corpus/$t; work=$dir/work/$t
  mkdir -p "$work" "$seeds"
  dict=(); [[ -f tests/fuzz/$t.dict ]] && dict=(-dict="tests/fuzz/$t.dict")
  log=$dir/$t.log
  "$dir/$t" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/$t-" "${dict[@]}" "$work" "$seeds" >"$log" 2>&1
  rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n1)
  cov=$(grep -oE '#[0-9]+.*cov: [0-9]+' "$log" | tail -n1 | grep -oE 'cov: [0-9]+')
  if [[ $rc -eq 0 ]]; then res=ok; else res="FAILED (exit $rc)"; fail=1; fi
  printf '%-16s %12s execs %8s/s  %-10s corpus %5s  %s\n' "$t" "${execs:-?}" "${rate:-?}" \
    "${cov:-cov: ?}" "$(ls "$work" | wc -l)" "$res"
  if [[ $rc -ne 0 ]]; then
    grep -E 'invariant broken|ERROR: |runtime error|SUMMARY|Test unit written' "$log" | head -n 12
  fi
done
exit $fail
