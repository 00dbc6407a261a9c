#!/usr/bin/env bash
# avr_wholechip.sh — the board images on emulated AVRs against `plotkin sim`
# (tests/avr/wholechip.py says what is checked). Builds the images (`make
# firmware-images`: the HEX of every AVR board that fits its part), the host
# tool and, per board, `plotkin sim` with that board's size knobs. Skipped
# (0 passed, 0 failed) where avr-gcc or libsimavr is not installed.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
if ! command -v avr-gcc >/dev/null || ! pkg-config --exists simavr 2>/dev/null; then
  echo "avr_wholechip: avr-gcc or libsimavr missing (bash .ci/deps.sh targets): skipped"
  echo "0 passed, 0 failed"; exit 0
fi
boards=$(ls -d hal/avr/*/board.mk 2>/dev/null | xargs -n1 dirname | xargs -n1 basename)
targets="firmware-images $BUILD/plotkin"
for b in $boards; do targets="$targets $BUILD/firmware/$b/host/plotkin $BUILD/firmware/$b/hal_selftest.hex"; done
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" $targets 2>&1); then
  printf '%s\n' "$out" | tail -n 20
  echo "FAIL avr_wholechip: building the images failed"; echo "0 passed, 1 failed"; exit 1
fi
if ! "$BUILD/plotkin" avrsim --help >/dev/null 2>&1 || "$BUILD/plotkin" avrsim x.hex --run x 2>&1 | grep -q "no simavr"; then
  echo "not ok plotkin avrsim was built with libsimavr"; echo "0 passed, 1 failed"; exit 1
fi
exec /usr/bin/python3 tests/avr/wholechip.py "$BUILD" $boards
