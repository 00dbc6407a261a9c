#!/usr/bin/env bash
# e2e_fuzz_corpus.sh — replay every committed fuzz input (seeds and the
# regression inputs of bugs the fuzzers found) through each target's
# invariant checks, built without libFuzzer, plainly and under ASan+UBSan.
# One "passed" per target and build whose whole corpus replays cleanly.
set -uo pipefail
B=${PLOTKIN_BUILD:-build}; S=${PLOTKIN_SAN:-build/san}
pass=0; fail=0
for src in tests/fuzz/fuzz_*.c; do
  t=$(basename "$src" .c); c=tests/fuzz/corpus/$t
  for bin in "$B/fuzz-replay/$t" "$S/fuzz-replay/$t"; do
    if [[ ! -x $bin ]]; then echo "FAIL $t: $bin not built"; fail=$((fail+1)); continue; fi
    if [[ ! -d $c ]] || [[ -z $(ls "$c") ]]; then echo "FAIL $t: empty corpus $c"; fail=$((fail+1)); continue; fi
    if out=$("$bin" "$c" 2>&1); then
      pass=$((pass+1)); echo "ok   $bin: $(printf '%s\n' "$out" | tail -n1 | cut -d, -f1) inputs"
    else
      printf '%s\n' "$out" | tail -n 15; echo "FAIL $bin on $c"; fail=$((fail+1))
    fi
  done
done
echo "$pass passed, $fail failed"
