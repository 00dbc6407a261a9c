#!/usr/bin/env bash
# avr_arith.sh — the integer square root (pk_isqrt64) gives the exact floor on
# the ATmega328P itself: bench/avr/avr_arith_cycles.c checks every root on
# the chip (r^2 <= x < (r + 1)^2, libgcc's 64-bit products; a 16-bit int could
# break on the AVR what the host tests pass) and reports the wrong ones; the
# count must be 0 and both operand sets must have run. Skipped (0 passed, 0 failed) where
# avr-gcc or libsimavr is not installed.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
if ! command -v avr-gcc >/dev/null || ! pkg-config --exists simavr 2>/dev/null; then
  echo "avr_arith: avr-gcc or libsimavr missing (bash .ci/deps.sh targets): skipped"
  echo "0 passed, 0 failed"; exit 0
fi
elf=$BUILD/bench/avr-arith/avr_arith_cycles.elf
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" "$BUILD/bench/avr_cycles" "$elf" 2>&1); then
  printf '%s\n' "$out" | tail -n 20
  echo "FAIL avr_arith: building the check image failed"; echo "0 passed, 1 failed"; exit 1
fi
out=$("$BUILD/bench/avr_cycles" "$elf" arith 2>&1)
pass=0 fail=0
for h in pk_isqrt64; do
  row=$(printf '%s\n' "$out" | grep -F "wrong results: $h " | head -n 1)
  n=$(printf '%s\n' "$row" | awk '{print $NF}')
  if [ -z "$row" ]; then
    echo "not ok $h: no result row from the chip"; fail=$((fail + 1))
  elif [ "$n" != 0 ]; then
    echo "not ok $h: $n of its results on the ATmega328P differ from the exact value"; fail=$((fail + 1))
  else
    echo "ok $h: exact on the ATmega328P"; pass=$((pass + 1))
  fi
done
for h in "pk_isqrt64, 0..64-bit x" "pk_isqrt64, r^2 - 1"; do
  if ! printf '%s\n' "$out" | grep -F -- " $h" | grep -v 'wrong results' | grep -q '(30[0-9] calls'; then
    echo "not ok the chip did not run the $h measurement"; fail=$((fail + 1))
  fi
done
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
