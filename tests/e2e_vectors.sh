#!/usr/bin/env bash
# The exact vectors are reproducible and the generator follows the stated
# rules (tests/vectors/README.md):
#  - tests/tools/gen_vectors.py regenerates a sample of tests/vectors/generated
#    byte for byte from its seed (PLOTKIN_VECTORS_SAMPLE=1 checks every file),
#    and the file list exactly;
#  - the same generator, from each case's input alone, reproduces every
#    reference case in tests/vectors/exact exactly (byte for byte).
# The kernel itself is checked against both sets by tests/test_vectors.c.
set -uo pipefail
cd "$(dirname "$0")/.."
pass=0; fail=0
step() {  # name, command...
  local name=$1 out last; shift
  out=$("$@" 2>&1)
  last=$(printf '%s\n' "$out" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1)
  if [[ -n $last && ${last#*, } == "0 failed" ]]; then
    pass=$((pass+1)); echo "ok $name (${last%%,*})"
  else
    fail=$((fail+1)); printf '%s\n' "$out" | grep -E 'FAIL|Error|error' | head -n 10
    echo "not ok $name"
  fi
}
step "the generated corpus regenerates byte for byte from its seed" \
  python3 tests/tools/gen_vectors.py --check tests/vectors/generated \
  --sample "${PLOTKIN_VECTORS_SAMPLE:-4}"
step "the generator reproduces every exact reference case from its input" \
  python3 tests/tools/gen_vectors.py --verify tests/vectors/exact
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
