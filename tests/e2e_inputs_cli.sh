#!/usr/bin/env bash
# `plotkin sim`'s input options as a user runs them: a limit switch tripping
# mid-move by a scripted edge (--input) or by a switch placed along an axis
# (--switch) with --hard-limits; the pin trace (--trace CSV) is decoded here,
# in Python, independently of the simulator, and must agree with the position
# the firmware reports; no step pulse after the edge; bad options exit 2.
set -uo pipefail
cd "$(dirname "$0")/.."
pass=0; fail=0
check() { if eval "$2"; then pass=$((pass+1)); echo "ok $1"; else fail=$((fail+1)); echo "not ok $1"; fi; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
PY=/usr/bin/python3
B=${PLOTKIN_BUILD:-build}
printf 'G21 G90\nM3\nG1 X50 Y10 F3000\nG1 X80 Y40\nM5\nM2\n' > "$tmp/p.gcode"

# decode.py TRACE.csv JSON [T_s]: decoded steps == the firmware's; no rising
# step edge at or after T_s; prints the decoded X Y
cat > "$tmp/decode.py" <<'PYEOF'
import csv, json, sys
rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith('#'))][1:]
j = json.load(open(sys.argv[2]))
t_lim = float(sys.argv[3]) if len(sys.argv) > 3 else None
lvl, pos, last = {}, {'X': 0, 'Y': 0, 'Z': 0}, 0.0
for tick, t, sig, level, initial in rows:
    level = int(level)
    prev = lvl.get(sig)
    lvl[sig] = level
    ax, _, kind = sig.partition('.')
    if kind == 'step' and initial == '0' and prev == 0 and level == 1:   # active-high step lines
        d = 1 if lvl.get(ax + '.dir', 0) == 1 else -1
        pos[ax] += d
        last = float(t)
assert [pos['X'], pos['Y'], pos['Z']] == j['firmware_steps'], (pos, j['firmware_steps'])
if t_lim is not None:
    assert last < t_lim, (last, t_lim)
print(pos['X'], pos['Y'])
PYEOF

for P in "$B/plotkin" "${PLOTKIN_SAN:-build/san}/plotkin"; do
echo "# $P"
$P sim "$tmp/p.gcode" --exact --hard-limits --input 0.5:limit-y=1 --json --trace "$tmp/a.csv" >"$tmp/a.json" 2>"$tmp/err"; rc=$?
check "a limit edge mid-move: exit 1, alarm 'hard limit'" \
  '[[ $rc -eq 1 ]] && $PY -c "import json,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if j[\"alarm\"] == \"hard limit\" and j[\"alarms\"] == 1 else 1)" "$tmp/a.json"'
check "the decoded pins agree with the firmware's position and stop before the edge" \
  'xy=$($PY "$tmp/decode.py" "$tmp/a.csv" "$tmp/a.json" 0.5) && [[ ${xy%% *} -gt 1000 && ${xy%% *} -lt 4000 ]]'
$P sim "$tmp/p.gcode" --exact --hard-limits --switch limit-x:x:40 --json --trace "$tmp/b.csv" >"$tmp/b.json" 2>/dev/null; rc=$?
check "a switch at X=40 mm stops the machine on the step that reaches it (3200 steps, Y 8 mm)" \
  '[[ $rc -eq 1 ]] && [[ $($PY "$tmp/decode.py" "$tmp/b.csv" "$tmp/b.json") == "3200 640" ]]'
$P sim "$tmp/p.gcode" --exact --switch limit-x:x:40 --json >"$tmp/c.json" 2>/dev/null; rc=$?
check "without --hard-limits the switch changes nothing" \
  '[[ $rc -eq 0 ]] && $PY -c "import json,sys; j=json.load(open(sys.argv[1])); sys.exit(0 if j[\"final_steps\"][:2] == [6400, 3200] and j[\"alarms\"] == 0 else 1)" "$tmp/c.json"'
for bad in "--input 0.5:limit-q=1" "--input x:probe=1" "--input 0.5:probe=2" "--switch probe:w:3" "--switch probe:x" "--switch probe:x:1:up"; do
  $P sim "$tmp/p.gcode" $bad >/dev/null 2>"$tmp/err"; rc=$?
  check "bad input option '$bad': exit 2 with a reason" '[[ $rc -eq 2 ]] && grep -q "plotkin sim: --" "$tmp/err"'
done
check "--help lists the input options" '$P sim --help | grep -q -- "--switch NAME:AXIS:MM"'
done
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
