#!/usr/bin/env bash
# `plotkin refine` as a script user sees it: the CLI contract of issue 2.
set -uo pipefail
cd "$(dirname "$0")/.."
pass=0; fail=0
check() { if eval "$2"; then pass=$((pass+1)); echo "ok $1"; else fail=$((fail+1)); echo "not ok $1"; fi; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
# Run everything twice: the plain build and the ASan+UBSan build.
for P in "${PLOTKIN_BUILD:-build}/plotkin" "${PLOTKIN_SAN:-build/san}/plotkin"; do
echo "# $P"

printf '0 0\n10 0\n1O 10\n0 10\n' | $P refine >"$tmp/out" 2>"$tmp/err"; rc=$?
check "a malformed line exits 2, names the line and writes nothing" \
  '[[ $rc -eq 2 && ! -s $tmp/out ]] && grep -q "line 3" "$tmp/err"'

printf '0 0\n3000 0\n' | $P refine >"$tmp/out" 2>"$tmp/err"; rc=$?
check "an out-of-range coordinate exits 2 with a range error and writes nothing" \
  '[[ $rc -eq 2 && ! -s $tmp/out ]] && grep -q "line 2: coordinate out of range" "$tmp/err"'

printf '0 0\n1 2 3\n' | $P refine >"$tmp/out" 2>"$tmp/err"; rc=$?
check "mixing 2- and 3-axis lines is refused" '[[ $rc -eq 2 && ! -s $tmp/out ]]'

$P refine --scheme bspline:9 </dev/null >/dev/null 2>&1; rc=$?
check "an unknown scheme exits 2" '[[ $rc -eq 2 ]]'

out=$(printf '0 0\n0.0015 -0.0005\n' | $P refine --depth 0)
check "millimetres are parsed to whole micrometres, rounding half away from zero" \
  '[[ "$out" == $'"'"'0.000 0.000\n0.002 -0.001'"'"' ]]'

out=$(printf '0 0\n10 0\n10 10\n0 10\n' | $P refine --depth 1)
check "clamped Chaikin keeps the stroke ends and cuts the corners (mm in, mm out)" \
  '[[ "$out" == $'"'"'0.000 0.000\n5.000 0.000\n10.000 2.500\n10.000 7.500\n5.000 10.000\n0.000 10.000'"'"' ]]'

out=$(printf '0 0\n10 0\n10 10\n\n20 0\n30 0\n' | $P refine --depth 1)
check "a blank line separates strokes, in the input and in the output" \
  '[[ $(printf "%s\n" "$out" | grep -c "^$") -eq 1 && $(printf "%s\n" "$out" | tail -n 2 | tr "\n" " ") == "20.000 0.000 30.000 0.000 " ]]'

# --raw against an exact reference vector, through the CLI, with the stated bound.
v=tests/vectors/exact/bspline3_open_clamped_m7_d3.txt
check "the exact reference vector for the --raw check is in the repository" '[[ -f $v ]]'
if [[ -f $v ]]; then
  sed -n '/^input/,/^output/p' "$v" | sed '1d;$d' | $P refine --raw --scheme bspline:3 --depth 3 >"$tmp/raw"
  /usr/bin/python3 - "$v" "$tmp/raw" <<'PY' && r=0 || r=1
import sys
from fractions import Fraction as F
L=open(sys.argv[1]).read().split('\n'); got=[l.split() for l in open(sys.argv[2]) if l.strip()]
i=L.index(next(l for l in L if l.startswith('output'))); n=int(L[i].split()[1])
exp=[[F(t) for t in l.split()] for l in L[i+1:i+1+n]]
ok=len(got)==n and all(abs(int(g)-e)<=F(1,2)+F(3,512) for gl,el in zip(got,exp) for g,e in zip(gl,el))
sys.exit(0 if ok else 1)
PY
  check "--raw output matches the exact rational vector within 1/2 + depth/512 LSB" '[[ $r -eq 0 ]]'
fi

out=$(printf '0 0\n10 0\n10 10\n0 10\n' | $P refine --closed --limit --tangents --depth 2 | awk '{s=$3*$3+$4*$4; if (s<0.999999||s>1.000001) bad=1} END{print NR, bad+0}')
check "--tangents appends a unit vector to every limit point" '[[ "$out" == "16 0" ]]'

done
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
