#!/usr/bin/env bash
# e2e_determinism.sh — the same input gives the same machine output, bit for
# bit, run after run and build after build, and any change in motion output
# shows up in review.
#
# For every bundled example (host-sim/examples/*.gcode, *.txt) this runs
# `plotkin sim FILE --trace` twice and checks that the two pin-edge traces
# are identical (and equal to the sanitized build's), then compares their SHA-256 with the golden hash checked in
# tests/golden/sim_traces.sha256. It does the same for `plotkin refine`
# on the polyline examples with a few schemes (tests/golden/refine.sha256).
#
# A deliberate change of motion output (planner, step generator, kernel,
# defaults, examples) changes these hashes. Update them on purpose with
#     PLOTKIN_UPDATE_GOLDEN=1 bash tests/e2e_determinism.sh
# and commit tests/golden/ together with the change, saying why in the
# commit message; the diff of the .sha256 files is the review signal.
set -uo pipefail
B=${PLOTKIN_BUILD:-build}; S=${PLOTKIN_SAN:-build/san}
P=$B/plotkin
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok   $*"; }
bad() { fail=$((fail+1)); echo "FAIL $*"; }
update=${PLOTKIN_UPDATE_GOLDEN:-0}

check_golden() { # file key hash
  local gf=$1 key=$2 h=$3 want
  if [[ $update == 1 ]]; then
    grep -v " $key\$" "$gf" 2>/dev/null > "$tmp/g" || true
    echo "$h $key" >> "$tmp/g"; sort -k2 "$tmp/g" > "$gf"; ok "golden updated: $key"; return
  fi
  want=$(awk -v k="$key" '$2 == k { print $1 }' "$gf" 2>/dev/null)
  if [[ -z $want ]]; then bad "$key: no golden hash in $gf (run with PLOTKIN_UPDATE_GOLDEN=1)"
  elif [[ $want == "$h" ]]; then ok "$key matches its golden hash"
  else bad "$key: hash $h, golden $want (motion output changed: update deliberately, see header)"
  fi
}

[[ -x $P ]] || { echo "FAIL $P not built"; echo "0 passed, 1 failed"; exit 1; }

for ex in host-sim/examples/*.gcode host-sim/examples/*.txt; do
  [[ -f $ex ]] || continue
  name=$(basename "$ex")
  "$P" sim "$ex" --trace "$tmp/a.csv" > "$tmp/a.out" 2>&1; ra=$?
  "$P" sim "$ex" --trace "$tmp/b.csv" > "$tmp/b.out" 2>&1; rb=$?
  if [[ $ra -ne 0 || $rb -ne 0 ]]; then bad "sim $name exits $ra/$rb"; continue; fi
  if cmp -s "$tmp/a.csv" "$tmp/b.csv" && cmp -s "$tmp/a.out" "$tmp/b.out"; then
    ok "sim $name: two runs give the same trace ($(($(wc -l < "$tmp/a.csv") - 2)) edges) and summary"
  else
    bad "sim $name: two runs differ"
  fi
  # another build (-O1, ASan+UBSan) of the same sources: the same trace
  if [[ -x $S/plotkin ]]; then
    "$S/plotkin" sim "$ex" --trace "$tmp/c.csv" > /dev/null 2>&1
    if cmp -s "$tmp/a.csv" "$tmp/c.csv"; then ok "sim $name: the sanitized build gives the same trace"
    else bad "sim $name: the sanitized build's trace differs"; fi
  fi
  check_golden tests/golden/sim_traces.sha256 "sim:$name" "$(sha256sum < "$tmp/a.csv" | cut -d' ' -f1)"
done

for ex in host-sim/examples/*.txt; do
  [[ -f $ex ]] || continue
  name=$(basename "$ex")
  for opts in "--scheme chaikin --depth 4" "--scheme bspline:3 --depth 3 --closed --limit --tangents" \
              "--scheme dlg --depth 5"; do
    "$P" refine $opts < "$ex" > "$tmp/r1" 2>&1; r1=$?
    "$P" refine $opts < "$ex" > "$tmp/r2" 2>&1; r2=$?
    key="refine:$name:${opts// /_}"
    if [[ $r1 -ne 0 || $r2 -ne 0 ]] || ! cmp -s "$tmp/r1" "$tmp/r2"; then
      bad "$key: two runs differ or fail ($r1/$r2)"; continue
    fi
    ok "$key: two runs identical"
    check_golden tests/golden/refine.sha256 "$key" "$(sha256sum < "$tmp/r1" | cut -d' ' -f1)"
  done
done
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
