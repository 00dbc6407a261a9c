#!/usr/bin/env bash
# campaign.sh SECONDS [TARGET[:SECONDS]...] — the long fuzzing campaign.
#
# Builds the libFuzzer targets (make fuzz-build), then runs each target in
# turn for SECONDS (or the SECONDS given after its name), never two at once:
# the machine is shared, and one process per target is also the fastest way
# here (measured: -fork=2 ran fuzz_refine at 1,192 exec/s against 3,739 for
# one plain process over the same 30 s, so no -fork and no -jobs). Each
# target's work corpus stays in build/fuzz/work/<target>/ between runs, so
# campaigns add up; artifacts (crashes, broken invariants) go to
# build/fuzz/artifacts/. Extra libFuzzer flags: FUZZ_FLAGS="...".
#
# Prints run_fuzz.sh's table (target, executions, exec/s, CPU seconds, cov,
# ft, corpus size, result; also in build/fuzz/summary.txt), then for each
# target the executions per CPU second and how long 10 million executions
# would take at the measured wall-clock rate. Exits non-zero if a target
# failed; see tests/fuzz/README.md for what to do with a finding.
#
# Examples:
#   tests/fuzz/campaign.sh 600                     # every target, 10 min each
#   tests/fuzz/campaign.sh 300 fuzz_motion:1800    # motion only, 30 min
set -uo pipefail
cd "$(dirname "$0")/../.."
secs=${1:-600}; shift || true
make -s fuzz-build >/dev/null || exit 1
specs=("$@")
if [[ ${#specs[@]} -eq 0 ]]; then
  for f in tests/fuzz/fuzz_*.c; do specs+=("$(basename "$f" .c)"); done
fi
start=$(date +%s)
fail=0
rows=()
for spec in "${specs[@]}"; do
  t=${spec%%:*}; s=$secs
  [[ $spec == *:* ]] && s=${spec#*:}
  [[ -x build/fuzz/$t ]] || { echo "no such target: $t" >&2; exit 2; }
  bash tests/fuzz/run_fuzz.sh build/fuzz "$s" "$t" > build/fuzz/campaign-$t.txt || fail=1
  rows+=("$(sed -n 3p build/fuzz/campaign-$t.txt)")   # the row (after the 2 header lines)
  # findings' details (if any) follow the table row
  sed -n '4,$p' build/fuzz/campaign-$t.txt
done
{
  head -n2 build/fuzz/campaign-"${specs[0]%%:*}".txt
  printf '%s\n' "${rows[@]}"
} | tee build/fuzz/summary.txt
echo
printf '%-14s  %12s  %14s\n' target "exec/CPU s" "10 M at exec/s"
for r in "${rows[@]}"; do
  IFS='|' read -r _ t execs rate cpu _ <<<"$r"
  t=${t// /}; execs=${execs// /}; rate=${rate// /}; cpu=${cpu// /}
  per_cpu=?; eta=?
  [[ $cpu =~ ^[0-9.]+$ && $execs =~ ^[0-9]+$ ]] && per_cpu=$(awk -v e="$execs" -v c="$cpu" 'BEGIN { print (c > 0 ? int(e / c) : "?") }')
  [[ $rate =~ ^[0-9]+$ && $rate -gt 0 ]] && eta="$((10000000 / rate / 60)) min"
  printf '%-14s  %12s  %14s\n' "$t" "$per_cpu" "$eta"
done
echo "campaign wall time: $(( ($(date +%s) - start) / 60 )) min"
exit $fail
