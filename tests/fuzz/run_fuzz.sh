#!/usr/bin/env bash
# run_fuzz.sh DIR SECONDS TARGET... — run each libFuzzer target in turn (one at
# a time: the build machines are shared) for SECONDS, seeded from
# tests/fuzz/corpus/<target>/, with tests/fuzz/<target>.dict if present and
# the flags in tests/fuzz/<target>.options (-max_len: each target's input cap)
# plus $FUZZ_FLAGS (e.g. FUZZ_FLAGS=-entropic=0). New inputs go to
# DIR/work/<target>/ (kept between runs), the log to DIR/<target>.log.
#
# Prints a table, one row per target: executions, exec/s (libFuzzer's, per
# wall second), CPU seconds used (user+sys: on a shared machine the rate per
# CPU second is the figure that compares), edge coverage (cov) and features
# (ft) at the end, work corpus size, result. The same rows go to
# DIR/summary.txt. Exits non-zero if any target found a crash or broken
# invariant; the input is then in DIR/artifacts/ (add it to the corpus as a
# regression input once the bug is fixed, see tests/fuzz/README.md).
set -uo pipefail
dir=$1; secs=$2; shift 2
mkdir -p "$dir/artifacts"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
read -r -a extra <<<"${FUZZ_FLAGS:-}"
fail=0
row() { printf '| %-14s | %12s | %7s | %7s | %6s | %7s | %6s | %s\n' "$@"; }
{ row target executions exec/s "CPU s" cov ft corpus result
  row -------------- ------------ ------- ------- ------ ------- ------ "------"; } | tee "$dir/summary.txt"
for t in "$@"; do
  seeds=tests/fuzz/corpus/$t; work=$dir/work/$t
  mkdir -p "$work" "$seeds"
  opts=(); [[ -f tests/fuzz/$t.options ]] && read -r -a opts < "tests/fuzz/$t.options"
  dict=(); [[ -f tests/fuzz/$t.dict ]] && dict=(-dict="tests/fuzz/$t.dict")
  log=$dir/$t.log
  TIMEFORMAT='%U %S'
  { time "$dir/$t" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$dir/artifacts/$t-" "${opts[@]}" "${dict[@]}" "${extra[@]}" \
      "$work" "$seeds" >"$log" 2>&1; } 2>"$dir/$t.time"
  rc=$?
  cpu=$(awk '{printf "%.1f", $1 + $2}' "$dir/$t.time" 2>/dev/null)
  # the last status line ("#N ... cov: C ft: F corp: K/..."; -fork prints "#N: cov: ...")
  last=$(grep -E '^#[0-9]+:?[[:space:]]' "$log" | tail -n1)
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n1)
  [[ -z $execs ]] && execs=$(sed -E 's/^#([0-9]+).*/\1/' <<<"$last")
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n1)
  [[ -z $rate && -n $execs ]] && rate=$((execs / (secs > 0 ? secs : 1)))
  cov=$(grep -oE 'cov: [0-9]+' <<<"$last" | grep -oE '[0-9]+')
  ft=$(grep -oE 'ft: [0-9]+' <<<"$last" | grep -oE '[0-9]+')
  if [[ $rc -eq 0 ]]; then res=ok; else res="FAILED (exit $rc)"; fail=1; fi
  row "$t" "${execs:-?}" "${rate:-?}" "${cpu:-?}" "${cov:-?}" "${ft:-?}" "$(ls "$work" | wc -l)" "$res" \
    | tee -a "$dir/summary.txt"
  if [[ $rc -ne 0 ]]; then
    grep -E 'invariant broken|ERROR: |runtime error|SUMMARY|Test unit written' "$log" | head -n 12
  fi
done
exit $fail
