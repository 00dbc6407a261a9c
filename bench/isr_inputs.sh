#!/usr/bin/env bash
# bench/isr_inputs.sh BIN — instructions the step callback (pk_machine_timer_cb
# and what it calls) executes per call and per motor step, for each input mode
# of bench/isr_inputs.c, counted by callgrind; all modes side by side in one run.
# "core" counts the firmware's own instructions (firmware/*.c and the inline
# wrappers of hal/hal.h), "hal" those of the recording HAL's pin and input
# functions (host-sim/), which a real board replaces by a few port accesses.
# A mode that cannot be measured fails the run (no zero is printed).
set -euo pipefail
BIN=${1:?usage: isr_inputs.sh BIN}
command -v valgrind >/dev/null || { echo "isr_inputs: valgrind is needed" >&2; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
printf '%-14s %10s %8s %12s %10s %10s %12s\n' mode callbacks steps core_instr core/call core/step hal_instr/call
for mode in noinputs none limits-edges limits-poll; do
  out=$(valgrind --tool=callgrind --toggle-collect=pk_machine_timer_cb \
          --callgrind-out-file="$tmp/cg.$mode" "$BIN" "$mode" 2>/dev/null) \
    || { echo "isr_inputs: $mode failed" >&2; exit 1; }
  calls=$(sed -n 's/.*callbacks \([0-9]*\).*/\1/p' <<<"$out")
  steps=$(sed -n 's/.*steps \([0-9]*\).*/\1/p' <<<"$out")
  ann=$(callgrind_annotate --auto=no --threshold=100 "$tmp/cg.$mode" 2>/dev/null)
  core=$(awk '/%\) +(firmware\/|hal\/hal\.h:)/ {gsub(",","",$1); s+=$1} END{print s+0}' <<<"$ann")
  hal=$(awk '/%\) +host-sim\// {gsub(",","",$1); s+=$1} END{print s+0}' <<<"$ann")
  [[ -n $calls && -n $steps && $core -gt 0 && $calls -gt 0 ]] \
    || { echo "isr_inputs: no measurement for $mode" >&2; exit 1; }
  awk -v m="$mode" -v c="$calls" -v s="$steps" -v i="$core" -v h="$hal" \
    'BEGIN{printf "%-14s %10d %8d %12d %10.2f %10.2f %12.2f\n", m, c, s, i, i/c, i/s, h/c}'
done
