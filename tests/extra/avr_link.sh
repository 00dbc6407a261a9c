#!/usr/bin/env bash
# avr_link.sh — `plotkin avrsim --link`: an emulated board's serial port on a
# pseudo-terminal, driven by a Grbl sender written with Debian's
# python3-serial (tests/avr/link_client.py), then stopped with SIGTERM,
# which must print the summary with the pin-decoded position. Runs on the
# first AVR image that fits its part; skipped (0 passed, 0 failed) where
# avr-gcc or libsimavr is missing. Every wait is bounded.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $1"; }
bad() { fail=$((fail+1)); echo "not ok $1"; shift; printf '  %s\n' "$@"; }
if ! command -v avr-gcc >/dev/null || ! pkg-config --exists simavr 2>/dev/null; then
  echo "avr_link: avr-gcc or libsimavr missing (bash .ci/deps.sh targets): skipped"
  echo "0 passed, 0 failed"; exit 0
fi
PY=/usr/bin/python3
if ! $PY -c 'import serial' 2>/dev/null; then
  bad "python3-serial is installed (.ci/deps.sh base)"; echo "$pass passed, $fail failed"; exit 1
fi
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" firmware-images "$BUILD/plotkin" 2>&1); then
  printf '%s\n' "$out" | tail -n 20; bad "the images and the host tool build"; echo "$pass passed, $fail failed"; exit 1
fi
board=""
for b in mega-ramps uno-cnc-shield; do [[ -f $BUILD/firmware/$b/$b.hex ]] && board=$b; done
if [[ -z $board ]]; then
  bad "an AVR image fits its part (make firmware)"; echo "$pass passed, $fail failed"; exit 1
fi
tmp=$(mktemp -d)
srv=""
cleanup() { [[ -n $srv ]] && kill "$srv" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT

"$BUILD/plotkin" avrsim "$BUILD/firmware/$board/$board.hex" --board "$board" --link "$tmp/tty" --speed 0 \
  >"$tmp/out" 2>"$tmp/err" &
srv=$!
for _ in $(seq 200); do [[ -e $tmp/tty ]] && break; sleep 0.05; done
if [[ -e $tmp/tty ]] && grep -q "^plotkin avrsim: $board (.*) on /dev/pts/" "$tmp/out"; then
  ok "avrsim prints its pty and makes the --link symlink"
else
  bad "avrsim prints its pty and makes the --link symlink" "$(cat "$tmp/out" "$tmp/err")"
fi

client=$(timeout 300 $PY tests/avr/link_client.py "$tmp/tty" 2>&1)
echo "$client" | grep -vE '^[0-9]+ passed, [0-9]+ failed$'
last=$(echo "$client" | tail -n 1)
if [[ $last =~ ^([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
  pass=$((pass+BASH_REMATCH[1])); fail=$((fail+BASH_REMATCH[2]))
else
  bad "the sender ran to the end" "$client"
fi

kill -TERM "$srv"
for _ in $(seq 100); do kill -0 "$srv" 2>/dev/null || break; sleep 0.05; done
wait "$srv"; rc=$?; srv=""
if grep -q "final position (steps) 0 0 0; firmware reports 0.000 0.000 0.000 mm" "$tmp/out" &&
   grep -q "timing violations 0;" "$tmp/out" && [[ $rc -eq 0 ]]; then
  ok "SIGTERM ends avrsim with the summary: back at 0 by the pins and by the firmware, no violation"
else
  bad "SIGTERM ends avrsim with the summary: back at 0 by the pins and by the firmware, no violation" \
      "exit $rc" "$(cat "$tmp/out" "$tmp/err" | tail -n 8)"
fi
[[ ! -e $tmp/tty ]] && ok "the --link symlink is removed on exit" || bad "the --link symlink is removed on exit"
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
