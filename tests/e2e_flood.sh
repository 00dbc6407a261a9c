#!/usr/bin/env bash
# e2e_flood.sh — a character-counting sender floods `plotkin serve` over a
# pseudo-terminal (tests/flood_sender.py): every line acknowledged exactly
# once, final position exact, memory flat; then the same with a sender that
# disconnects mid-flood and reconnects, and with a sender that ignores
# character counting. `make test` sends PLOTKIN_FLOOD_LINES
# (default 10,000) lines; `make soak` sends 100,000. The simulated clock runs
# PLOTKIN_FLOOD_SPEED (50) times real time, so the machine, not the sender,
# sets the pace: the receive buffer stays full and the sender waits on
# acknowledgements. Every wait is bounded.
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${PLOTKIN_BUILD:-build}
LINES=${PLOTKIN_FLOOD_LINES:-10000}
PY=/usr/bin/python3
pass=0; fail=0
if ! [[ -x $BUILD/plotkin ]]; then echo "FAIL $BUILD/plotkin not built"; echo "0 passed, 1 failed"; exit 1; fi
tmp=$(mktemp -d); srv=""
cleanup() { [[ -n $srv ]] && kill "$srv" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT

flood() { # lines [--disconnect-at K]
  local n=$1; shift
  rm -f "$tmp/tty"
  "$BUILD/plotkin" serve --link "$tmp/tty" --speed "${PLOTKIN_FLOOD_SPEED:-50}" >"$tmp/out" 2>"$tmp/err" &
  srv=$!
  for _ in $(seq 200); do [[ -e $tmp/tty ]] && break; sleep 0.05; done
  if [[ ! -e $tmp/tty ]]; then
    cat "$tmp/out" "$tmp/err"; echo "FAIL serve did not start"; fail=$((fail+1)); return
  fi
  local out last rc
  out=$(timeout 900 $PY tests/flood_sender.py "$tmp/tty" "$n" "$srv" "$@" 2>&1)
  printf '%s\n' "$out" | grep -vE '^[0-9]+ passed, [0-9]+ failed$'
  last=$(printf '%s\n' "$out" | tail -n 1)
  if [[ $last =~ ^([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
    pass=$((pass+BASH_REMATCH[1])); fail=$((fail+BASH_REMATCH[2]))
  else
    echo "FAIL the flood sender did not finish"; fail=$((fail+1))
  fi
  kill -TERM "$srv"; wait "$srv"; rc=$?; srv=""
  # the server's own count: every line answered, nothing lost to overflow
  if [[ $rc -eq 0 ]] && grep -qE "0 bytes lost to overflow" "$tmp/out" && \
     grep -qE "lines $((n + 2)): $((n + 2)) ok, 0 error" "$tmp/out"; then
    pass=$((pass+1)); echo "ok serve's summary counts $((n + 2)) lines, all ok, no byte lost"
  else
    fail=$((fail+1)); echo "FAIL serve's summary (exit $rc):"; cat "$tmp/out"
  fi
}

flood "$LINES"
flood 3000 --disconnect-at 1500
flood 3000 --no-counting
echo "$pass passed, $fail failed"
