#!/usr/bin/env bash
# End to end: `plotkin serve` on a real pseudo-terminal, driven by a Grbl
# sender written with Debian's python3-serial (tests/serve_client.py), then
# stopped with SIGTERM, which must print the summary. Every wait is bounded.
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${PLOTKIN_BUILD:-build}
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $1"; }
bad() { fail=$((fail+1)); echo "not ok $1"; shift; printf '  %s\n' "$@"; }

PY=/usr/bin/python3
if ! $PY -c 'import serial' 2>/dev/null; then
  bad "python3-serial is installed (.ci/deps.sh base)"; echo "$pass passed, $fail failed"; exit 1
fi
tmp=$(mktemp -d)
srv=""
cleanup() { [[ -n $srv ]] && kill "$srv" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT

"$BUILD/plotkin" serve --link "$tmp/tty" --speed 100 >"$tmp/out" 2>"$tmp/err" &
srv=$!
for _ in $(seq 200); do [[ -e $tmp/tty ]] && break; sleep 0.05; done
if [[ -e $tmp/tty ]] && grep -q "^plotkin serve: Grbl 1.1 on /dev/pts/" "$tmp/out"; then
  ok "serve prints its pty and makes the --link symlink"
else
  bad "serve prints its pty and makes the --link symlink" "$(cat "$tmp/out" "$tmp/err")"
fi

client=$(timeout 300 $PY tests/serve_client.py "$tmp/tty" 2>&1)
echo "$client" | grep -vE '^[0-9]+ passed, [0-9]+ failed$'
last=$(echo "$client" | tail -n 1)
if [[ $last =~ ^([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
  pass=$((pass+BASH_REMATCH[1])); fail=$((fail+BASH_REMATCH[2]))
else
  bad "the protocol client ran to the end" "$client"
fi

# socat is a plain byte pipe: it must get the same answers.
if command -v socat >/dev/null; then
  got=$(printf 'G0 X2 Y3\n$G\n' | timeout 10 socat -t 1 - "FILE:$tmp/tty,raw,echo=0" 2>&1)
  if echo "$got" | grep -q '^ok' && echo "$got" | grep -q '^\[GC:G0 '; then
    ok "socat talks to serve"
  else
    bad "socat talks to serve" "$got"
  fi
fi

kill -TERM "$srv"
for _ in $(seq 100); do kill -0 "$srv" 2>/dev/null || break; sleep 0.05; done
if kill -0 "$srv" 2>/dev/null; then
  bad "SIGTERM stops serve within 5 s"
else
  wait "$srv"; rc=$?; srv=""
  if [[ $rc -eq 0 ]] && grep -q "plotkin serve: stopped" "$tmp/out" && grep -q "lines [0-9]*: [0-9]* ok" "$tmp/out"; then
    ok "SIGTERM stops serve cleanly with a summary"
  else
    bad "SIGTERM stops serve cleanly with a summary" "exit $rc" "$(cat "$tmp/out")"
  fi
  [[ ! -e $tmp/tty ]] && ok "the --link symlink is removed on exit" || bad "the --link symlink is removed on exit"
fi
# The exit summary is `plotkin sim`'s, from the same simulated machine: a
# program streamed to serve must end where `plotkin sim` ends it (exact
# steps: 80 steps/mm, the default $100/$101), with no timing violation.
cat >"$tmp/prog.gcode" <<'G'
G21 G90
G64 P0.02
M3
G1 X10 Y0 F3000
G1 X12.5 Y5
G1 X12.5 Y7.25
M5
G
cat >"$tmp/stream.py" <<'PYEOF'
import serial, sys, time
s = serial.Serial(sys.argv[1], 115200, timeout=0.1)
def line(deadline=10.0):
    t = time.time(); b = b''
    while time.time() - t < deadline:
        c = s.read(1)
        if c == b'\n':
            return b.decode(errors='replace').strip()
        b += c
    return None
for l in open(sys.argv[2]).read().splitlines():
    s.write((l + '\n').encode())
    while True:
        a = line()
        if a is None or a == 'ok' or a.startswith('error'):
            print(l, '->', a); break
t = time.time()
while time.time() - t < 30:
    s.write(b'?')
    a = line()
    if a and a.startswith('<Idle'):
        print(a); break
    time.sleep(0.05)
PYEOF
"$BUILD/plotkin" serve --link "$tmp/tty2" --speed 20 >"$tmp/sout" 2>&1 &
srv=$!
for _ in $(seq 200); do [[ -e $tmp/tty2 ]] && break; sleep 0.05; done
streamed=$(timeout 60 $PY "$tmp/stream.py" "$tmp/tty2" "$tmp/prog.gcode" 2>&1)
kill -TERM "$srv"; wait "$srv"; rc=$?; srv=""
"$BUILD/plotkin" sim "$tmp/prog.gcode" >"$tmp/simout" 2>&1
want="final position    X 1000 steps = 12.5000 mm  Y 580 steps = 7.2500 mm  Z 0 steps = 0.0000 mm"
if [[ $rc -eq 0 ]] && grep -q '^<Idle|MPos:12.500,7.250,0.000' <<<"$streamed" &&
   grep -qF "  timing violations 0 (drv8825 limits)" "$tmp/sout" &&
   grep -qF "  $want" "$tmp/sout" && grep -qF "  $want" "$tmp/simout" &&
   grep -qE "^  lines +7$" "$tmp/sout" && grep -qE "^  errors +0$" "$tmp/sout" &&
   grep -qE "^  alarms +0$" "$tmp/sout" && grep -qE "^  max speed +X [0-9.]+ mm/s" "$tmp/sout" &&
   grep -qE "^  max acceleration +X [0-9]+ mm/s\^2" "$tmp/sout"; then
  ok "the SIGTERM summary is plotkin sim's: no timing violation, the exact final position in steps"
else
  bad "the SIGTERM summary is plotkin sim's: no timing violation, the exact final position in steps" \
      "exit $rc" "$streamed" "$(cat "$tmp/sout")" "$(cat "$tmp/simout")"
fi

# --device: the termios backend on a real tty device (one end of a socat
# null-modem pair), a sender on the other end.
if command -v socat >/dev/null; then
  socat pty,raw,echo=0,link="$tmp/nmA" pty,raw,echo=0,link="$tmp/nmB" 2>/dev/null &
  nm=$!
  for _ in $(seq 100); do [[ -e $tmp/nmA && -e $tmp/nmB ]] && break; sleep 0.05; done
  "$BUILD/plotkin" serve --device "$tmp/nmA" --baud 115200 >"$tmp/dout" 2>&1 &
  srv=$!
  for _ in $(seq 100); do grep -q "at 115200 baud" "$tmp/dout" 2>/dev/null && break; sleep 0.05; done
  got=$(printf 'G0 X3 Y2\nG4 P0\n$I\n' | timeout 10 socat -t 1 - "FILE:$tmp/nmB,raw,echo=0" 2>&1)
  kill -TERM "$srv"; wait "$srv"; rc=$?; srv=""
  kill "$nm" 2>/dev/null; wait "$nm" 2>/dev/null
  if [[ $rc -eq 0 ]] && echo "$got" | grep -q '^\[OPT:VM,[0-9]*,128\]' && grep -q "position X3.000 Y2.000" "$tmp/dout"; then
    ok "serve --device speaks Grbl on a real tty in raw mode"
  else
    bad "serve --device speaks Grbl on a real tty in raw mode" "$got" "$(cat "$tmp/dout")"
  fi
fi
# --eeprom FILE: settings, offsets and startup lines survive a restart of
# serve (the board's EEPROM on a host), and a damaged file is reset loudly.
cat >"$tmp/ee.py" <<'PYEOF'
import serial, sys, time
s = serial.Serial(sys.argv[1], 115200, timeout=0.1)
out = []
def ask(l, t=5.0):
    s.write((l + '\n').encode()); end = time.time() + t; b = b''
    while time.time() < end:
        b += s.read(256)
        if b'ok\r\n' in b or b'error:' in b:
            break
    out.append(b.decode(errors='replace'))
s.write(b'\x18')  # a reset: the greeting and the startup lines again
time.sleep(0.5)
out.append(s.read(4096).decode(errors='replace'))
for l in sys.argv[2:]:
    ask(l)
print(''.join(out))
PYEOF
ee_run() { # FILE TTY LINES...: one serve session on the store FILE
  local f=$1 t=$2; shift 2
  "$BUILD/plotkin" serve --link "$t" --speed 20 --eeprom "$f" >/dev/null 2>&1 &
  srv=$!
  for _ in $(seq 200); do [[ -e $t ]] && break; sleep 0.05; done
  timeout 30 $PY "$tmp/ee.py" "$t" "$@" 2>&1
  kill -TERM "$srv"; wait "$srv"; srv=""
}
first=$(ee_run "$tmp/ee.bin" "$tmp/tty3" '$100=123.5' 'G10 L2 P2 X7' '$N0=G91')
second=$(ee_run "$tmp/ee.bin" "$tmp/tty4" '$$' '$#' '$G')
if [[ $(grep -c '^ok' <<<"$first") -eq 3 ]] &&
   grep -q '^\$100=123.500' <<<"$second" && grep -q '^\[G55:7.000,0.000,0.000\]' <<<"$second" &&
   grep -q '^>G91:ok' <<<"$second" && grep -q '^\[GC:G0 G54 G17 G21 G91 ' <<<"$second"; then
  ok "serve --eeprom: settings, G55 and a startup line survive a restart"
else
  bad "serve --eeprom: settings, G55 and a startup line survive a restart" "$first" "$second"
fi
printf '\x5a' | dd of="$tmp/ee.bin" bs=1 seek=9 conv=notrunc 2>/dev/null  # $1's low byte
third=$(ee_run "$tmp/ee.bin" "$tmp/tty5" '$$')
if grep -q '^\$100=80.000' <<<"$third" && ! grep -q '^>G91' <<<"$third"; then
  ok "serve --eeprom: a damaged settings record is reset to the defaults"
else
  bad "serve --eeprom: a damaged settings record is reset to the defaults" "$third"
fi
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
