#!/usr/bin/env bash
# e2e_soak_sim.sh — a long simulated plotting session with no drift.
#
# Builds one program from the bundled flower example repeated until it
# covers PLOTKIN_SOAK_MINUTES of simulated plotting (make test: 2; make soak:
# 120), each repetition followed by a rapid to an odd spot that is not a whole
# number of steps, and the whole ending at X12.345 Y6.789. `plotkin sim` runs
# it through the firmware and decodes the pins. Checked: no G-code error, no
# alarm, no driver-timing violation; the position decoded from the pins equals
# the firmware's step count, and both equal the last target rounded to whole
# steps (an independent integer rounding here), after hours of motion: a
# single lost or invented step anywhere would persist to the end.
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${PLOTKIN_BUILD:-build}
MIN=${PLOTKIN_SOAK_MINUTES:-2}
P=$BUILD/plotkin
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $*"; }
bad() { fail=$((fail+1)); echo "FAIL $*"; }
[[ -x $P ]] || { echo "FAIL $P not built"; echo "0 passed, 1 failed"; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
ex=host-sim/examples/flower.gcode
one=$("$P" sim "$ex" --json | sed -n 's/.*"sim_time_s": *\([0-9.]*\).*/\1/p')
reps=$(awk -v m="$MIN" -v t="$one" 'BEGIN { r = int(m * 60 / t) + 1; print (r < 1 ? 1 : r) }')
{
  for ((i = 0; i < reps; i++)); do
    grep -vE '^M2|^M30' "$ex"
    printf 'G0 X%d.%03d Y%d.%03d\n' $((i % 97)) $(((i * 37) % 1000)) $((i % 53)) $(((i * 91) % 1000))
  done
  echo "G0 X12.345 Y6.789"
  echo "M2"
} > "$tmp/soak.gcode"
# steps/mm set here (Y not a whole number, so rounding matters), not read back
spx=80; spy=78.74
printf '$100=%s\n$101=%s\n' "$spx" "$spy" > "$tmp/machine.conf"
"$P" sim "$tmp/soak.gcode" --config "$tmp/machine.conf" --json > "$tmp/out.json" 2>&1; rc=$?
j() { sed -n "s/.*\"$1\": *\(.*\)/\1/p" "$tmp/out.json" | head -n1 | tr -d ' ,[]"'; }
j2() { sed -n "s/.*\"$1\": *\[\([^]]*\)\].*/\1/p" "$tmp/out.json" | head -n1 | tr -d ' '; }
simt=$(j sim_time_s)
[[ $rc -eq 0 ]] && ok "sim exits 0 after $reps repetitions, $simt s simulated" || bad "sim exit $rc: $(head -c 600 "$tmp/out.json")"
[[ $(j errors) == 0 && $(j alarms) == 0 ]] && ok "no G-code error, no alarm" || bad "errors $(j errors) alarms $(j alarms)"
[[ $(j timing_violations) == 0 ]] && ok "no driver-timing violation" || bad "timing violations $(j timing_violations)"
awk -v s="$simt" -v m="$MIN" 'BEGIN { exit !(s >= m * 60) }' && ok "covers at least $MIN simulated minutes" || bad "only $simt s simulated"
dec=$(j2 final_steps); fw=$(j2 firmware_steps)
[[ -n $dec && $dec == "$fw" ]] && ok "decoded pins ($dec) equal the firmware's step count" || bad "decoded $dec, firmware $fw"
want=$(awk -v x=12.345 -v y=6.789 -v sx="$spx" -v sy="$spy" \
  'function r(v) { return v < 0 ? -int(-v + 0.5) : int(v + 0.5) } BEGIN { printf "%d,%d,0", r(x * sx), r(y * sy) }')
[[ $dec == "$want" ]] && ok "after $simt s the machine is exactly at the last target ($want steps)" || bad "final $dec, want $want"
echo "# soak: $reps repetitions, $simt s simulated, steps $(j2 steps)"
echo "$pass passed, $fail failed"
