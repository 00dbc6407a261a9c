#!/usr/bin/env bash
# End to end: the Linux board binary's serve mode (`plotkin-gpiod serve
# --link`), built as its test variant on the mock GPIO chip
# (build/plotkin-gpiod-mock: the same gpiod backend, real-time loop and Grbl
# engine; the chip records every edge on the real clock), driven over a real
# pty by a Grbl sender (tests/gpiod_serve_client.py: character counting,
# ? ! ~ Ctrl-X, a vanishing client), then stopped with SIGTERM. The recorded
# edges are decoded on their own (tests/gpiod_trace_check.py) into steps and
# checked against the programmed end and the DRV8825's timing.
# --no-realtime: no SCHED_FIFO busy loop on a shared CI machine.
# Every wait is bounded. The sanitized build runs a short session too.
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=${PLOTKIN_BUILD:-build}
SAN=${PLOTKIN_SAN:-$BUILD/san}
PY=/usr/bin/python3
BOARD=hal/gpiod/rpi-plotter.conf   # step 17 27, dir 22 23, enable 24, pen 25
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $1"; }
bad() { fail=$((fail+1)); echo "not ok $1"; shift; printf '  %s\n' "$@"; }
if ! $PY -c 'import serial' 2>/dev/null; then
  bad "python3-serial is installed (.ci/deps.sh base)"; echo "$pass passed, $fail failed"; exit 1
fi
tmp=$(mktemp -d)
srv=""
cleanup() { [[ -n $srv ]] && kill "$srv" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT

start() {  # binary, link, trace
  "$1" --board "$BOARD" --no-realtime --mock-trace "$3" serve --link "$2" >"$tmp/out" 2>"$tmp/err" &
  srv=$!
  # the symlink comes first, the banner once the loop is set up: wait for both
  for _ in $(seq 200); do
    [[ -e $2 ]] && grep -q "Grbl 1.1 on" "$tmp/out" 2>/dev/null && break
    kill -0 "$srv" 2>/dev/null || break
    sleep 0.05
  done
}
stop() {   # -> rc
  kill -TERM "$srv"
  for _ in $(seq 100); do kill -0 "$srv" 2>/dev/null || break; sleep 0.05; done
  if kill -0 "$srv" 2>/dev/null; then kill -KILL "$srv"; wait "$srv"; srv=""; return 99; fi
  wait "$srv"; local rc=$?; srv=""; return $rc
}

# A minimal sender: the pty in raw mode and until(pattern) reading answers.
PRELUDE='import os, select, sys, time, tty
fd = os.open(sys.argv[1], os.O_RDWR | os.O_NOCTTY); tty.setraw(fd)
buf = b""
def until(pat, t=10):
    global buf
    end = time.monotonic() + t
    while pat not in buf and time.monotonic() < end:
        if select.select([fd], [], [], 0.1)[0]: buf += os.read(fd, 4096)
    return pat in buf
'
pysend() {  # pty; the sender's script on stdin
  local body; body=$(cat)
  timeout 30 $PY -c "$PRELUDE$body" "$1"
}
final_levels() {  # trace -> "line=level ..." as the lines were left on exit
  $PY - "$1" <<'PYEOF'
import sys
lv = {}
for r in open(sys.argv[1]):
    if not r.startswith('#'):
        t, d, l, v, i = r.split(); lv[int(l)] = int(v)
print(" ".join("%d=%d" % (k, lv[k]) for k in sorted(lv)))
PYEOF
}

for b in "$BUILD/plotkin-gpiod-mock" "$SAN/plotkin-gpiod-mock"; do
  [[ -x $b ]] || { bad "$b is built (make test-build)"; continue; }
done

# 1. The whole protocol session on the plain build.
start "$BUILD/plotkin-gpiod-mock" "$tmp/tty" "$tmp/trace"
if [[ -e $tmp/tty ]] && grep -q "^plotkin-gpiod: Grbl 1.1 on /dev/pts/.* (link $tmp/tty)" "$tmp/out" &&
   grep -q "TEST BUILD: mock GPIO chip 'gpiochip0'" "$tmp/err"; then
  ok "plotkin-gpiod serve --link makes the pty and its symlink"
else
  bad "plotkin-gpiod serve --link makes the pty and its symlink" "$(cat "$tmp/out" "$tmp/err")"
fi
client=$(timeout 120 $PY tests/gpiod_serve_client.py "$tmp/tty" 2>&1)
echo "$client" | grep -vE '^[0-9]+ passed, [0-9]+ failed$|^END '
last=$(echo "$client" | tail -n 1)
if [[ $last =~ ^([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
  pass=$((pass+BASH_REMATCH[1])); fail=$((fail+BASH_REMATCH[2]))
else
  bad "the protocol client ran to the end" "$client"
fi
end=$(echo "$client" | sed -n 's/^END //p')
stop; rc=$?
lines=$(sed -n 's/^  lines \([0-9]*\): \([0-9]*\) ok, \([0-9]*\) error;.*/\1 \2 \3/p' "$tmp/out")
if [[ $rc -eq 0 ]] && grep -q "^plotkin-gpiod: stopped$" "$tmp/out" && [[ -n $lines ]]; then
  ok "SIGTERM stops the board's serve cleanly with a summary"
else
  bad "SIGTERM stops the board's serve cleanly with a summary" "exit $rc" "$(cat "$tmp/out" "$tmp/err")"
fi
[[ ! -e $tmp/tty ]] && ok "the --link symlink is removed on exit" || bad "the --link symlink is removed on exit"
read -r n nok nerr <<<"$lines"
# The client sent $I + 150 + 1 + 8 (hold) + 2 + 2 (locked G0, $X) + 2
# (vanishing) + 2 (G0 Z1, $X) = 168 lines, one refused on purpose (error:9
# while locked).
if [[ "$n $nok $nerr" == "168 167 1" ]]; then
  ok "the board answered every line the client sent exactly once (168: 167 ok, 1 error:9)"
else
  bad "the board answered every line the client sent exactly once (168: 167 ok, 1 error:9)" "$lines"
fi
if grep -q "^plotkin-gpiod: alarm: gpiod: axis Z would move, but the board wires no" "$tmp/err"; then
  ok "the operator is told why the board alarmed (axis Z has no lines)"
else
  bad "the operator is told why the board alarmed (axis Z has no lines)" "$(cat "$tmp/err")"
fi
if [[ -n $end ]]; then
  chk=$($PY tests/gpiod_trace_check.py "$tmp/trace" 17,27 22,23 80 $end 2>&1)
  echo "$chk" | grep -v '^STEPS '
  pass=$((pass+$(echo "$chk" | grep -c '^ok '))); fail=$((fail+$(echo "$chk" | grep -c '^not ok ')))
  steps=$(echo "$chk" | sed -n 's/^STEPS //p')
  if grep -qE "^  state Idle, position .* mm, steps $steps 0$" "$tmp/out"; then
    ok "the board's own final position in steps is the decoded one ($steps)"
  else
    bad "the board's own final position in steps is the decoded one ($steps)" "$(grep position "$tmp/out")"
  fi
  # Released on exit: every line back at its inactive level, drivers disabled
  # (enable_invert 1: high), pen up.
  fin=$(final_levels "$tmp/trace")
  [[ $fin =~ ^17=0\ 22=[01]\ 23=[01]\ 24=1\ 25=0\ 27=0$ ]] && ok "on exit the steps are low, the drivers disabled and the pen up ($fin)" \
    || bad "on exit the steps are low, the drivers disabled and the pen up" "$fin"
fi

# 2. The sanitized build: greeting, a move, '?', Ctrl-X, SIGTERM.
if [[ -x $SAN/plotkin-gpiod-mock ]]; then
  start "$SAN/plotkin-gpiod-mock" "$tmp/stty" "$tmp/strace"
  got=$(pysend "$tmp/stty" <<'PYEOF' 2>&1
os.write(fd, b"\x18"); until(b"Grbl 1.1h")
os.write(fd, b"G1 X2.5 Y1.25 F3000\n"); until(b"ok")
for _ in range(200):
    buf = b""; os.write(fd, b"?"); until(b">")
    if b"<Idle|MPos:2.500,1.250" in buf: break
    time.sleep(0.02)
print(buf.decode(errors="replace").strip())
os.write(fd, b"\x18"); print("reset", until(b"Grbl 1.1h"))
PYEOF
)
  stop; rc=$?
  if [[ $rc -eq 0 ]] && grep -q "<Idle|MPos:2.500,1.250" <<<"$got" && grep -q "reset True" <<<"$got" &&
     grep -q "steps 200 100 0" "$tmp/out" && ! grep -q "runtime error\|Sanitizer" "$tmp/err"; then
    ok "the ASan+UBSan build serves a move, a status and a reset cleanly"
  else
    bad "the ASan+UBSan build serves a move, a status and a reset cleanly" "exit $rc" "$got" "$(cat "$tmp/out" "$tmp/err")"
  fi
fi

# 3. SIGINT in the middle of a move: the motion stops at once, the lines are
# released at their inactive levels, and the summary says where it stopped.
start "$BUILD/plotkin-gpiod-mock" "$tmp/itty" "$tmp/itrace"
got=$(pysend "$tmp/itty" <<'PYEOF' 2>&1
os.write(fd, b"\x18"); until(b"Grbl 1.1h")
os.write(fd, b"M3\nG1 X100 Y50 F600\n"); until(b"ok\r\nok")
for _ in range(300):
    buf = b""; os.write(fd, b"?"); until(b">")
    if b"<Run|MPos:0.000,0.000" not in buf and b"<Run|" in buf: break
    time.sleep(0.01)
print(buf.decode(errors="replace").strip())
PYEOF
)
kill -INT "$srv"
for _ in $(seq 100); do kill -0 "$srv" 2>/dev/null || break; sleep 0.05; done
wait "$srv"; rc=$?; srv=""
fin=$(final_levels "$tmp/itrace")
pos=$(sed -n 's/^  state [A-Za-z:0-9]*, position X\([0-9.]*\) Y\([0-9.]*\) .*/\1 \2/p' "$tmp/out")
read -r px py <<<"$pos"
if [[ $rc -eq 0 && $got == "<Run|"* && -n $pos ]] && grep -q "^plotkin-gpiod: stopped$" "$tmp/out" &&
   $PY -c "import sys; x,y=map(float,sys.argv[1:]); sys.exit(0 if 0<x<100 and 0<y<50 else 1)" "$px" "$py" &&
   [[ $fin =~ ^17=0\ 22=[01]\ 23=[01]\ 24=1\ 25=0\ 27=0$ ]]; then
  ok "SIGINT mid-move stops the board short of the target and releases the lines ($pos; $fin)"
else
  bad "SIGINT mid-move stops the board short of the target and releases the lines" "exit $rc" "$got" "$fin" "$(cat "$tmp/out")"
fi

# 4. --device: a real tty (one end of a socat null-modem pair) in raw mode.
if command -v socat >/dev/null; then
  socat pty,raw,echo=0,link="$tmp/nmA" pty,raw,echo=0,link="$tmp/nmB" 2>/dev/null &
  nm=$!
  for _ in $(seq 100); do [[ -e $tmp/nmA && -e $tmp/nmB ]] && break; sleep 0.05; done
  "$BUILD/plotkin-gpiod-mock" --board "$BOARD" --no-realtime serve --device "$tmp/nmA" >"$tmp/dout" 2>&1 &
  srv=$!
  for _ in $(seq 100); do grep -q "at 115200 baud" "$tmp/dout" 2>/dev/null && break; sleep 0.05; done
  got=$(printf '$I\nG0 X3 Y2\n' | timeout 10 socat -t 1 - "FILE:$tmp/nmB,raw,echo=0" 2>&1)
  sleep 0.5
  kill -TERM "$srv"; wait "$srv"; rc=$?; srv=""
  kill "$nm" 2>/dev/null; wait "$nm" 2>/dev/null
  if [[ $rc -eq 0 ]] && echo "$got" | grep -q '^\[OPT:.*,128\]' && grep -q "position X3.000 Y2.000 .* steps 240 160 0" "$tmp/dout"; then
    ok "serve --device speaks Grbl on a real tty at 115200 8N1 raw and moves the board"
  else
    bad "serve --device speaks Grbl on a real tty at 115200 8N1 raw and moves the board" "$got" "$(cat "$tmp/dout")"
  fi
fi

# 5. Where real time is refused (an unprivileged user: here root drops to
# nobody with setpriv, which clears the capabilities): by default one line
# says so and what it means, and the board runs; --realtime refuses to run.
if [[ $(id -u) -eq 0 ]] && command -v setpriv >/dev/null; then
  printf 'G1 X1.25 F3000\n' >"$tmp/one.gcode"; chmod 755 "$tmp"; chmod 644 "$tmp/one.gcode"
  nob=(setpriv --reuid 65534 --regid 65534 --clear-groups "$BUILD/plotkin-gpiod-mock" --board "$BOARD")
  "${nob[@]}" "$tmp/one.gcode" >"$tmp/r1" 2>&1; r1=$?
  "${nob[@]}" --realtime "$tmp/one.gcode" >"$tmp/r2" 2>&1; r2=$?
  if [[ $r1 -eq 0 && $r2 -eq 1 ]] && grep -q "position 100 0 steps" "$tmp/r1" &&
     [[ $(grep -c "note: no real-time .*Operation not permitted.*: step timing will jitter" "$tmp/r1") -eq 1 ]] &&
     grep -q -- "--realtime: refused (SCHED_FIFO: Operation not permitted" "$tmp/r2" && ! grep -q "position" "$tmp/r2"; then
    ok "without the privilege: one clear line and the job runs; with --realtime it refuses"
  else
    bad "without the privilege: one clear line and the job runs; with --realtime it refuses" \
        "$r1 $r2" "$(cat "$tmp/r1" "$tmp/r2")"
  fi
else
  echo "# not root or no setpriv: the refused-real-time case is not exercised here"
fi

# 6. Usage errors are refused, not guessed.
"$BUILD/plotkin-gpiod-mock" --board "$BOARD" serve >/dev/null 2>"$tmp/u1"; r1=$?
"$BUILD/plotkin-gpiod-mock" --board "$BOARD" serve --link "$tmp/a" --device /dev/null >/dev/null 2>"$tmp/u2"; r2=$?
"$BUILD/plotkin-gpiod-mock" --board "$BOARD" --no-realtime serve --device "$tmp/none" >/dev/null 2>"$tmp/u3"; r3=$?
if [[ $r1 -eq 2 && $r2 -eq 2 && $r3 -eq 1 ]] && grep -q "not both" "$tmp/u2" &&
   grep -q "$tmp/none: No such file or directory" "$tmp/u3"; then
  ok "serve without a line, with two lines, or on a missing device is refused with a reason"
else
  bad "serve without a line, with two lines, or on a missing device is refused with a reason" \
      "$r1 $r2 $r3" "$(cat "$tmp/u1" "$tmp/u2" "$tmp/u3")"
fi
# 7. The pen as a servo on a kernel PWM channel (servo_pwm): a fake sysfs
# channel whose duty_cycle is a FIFO, so every pulse width the board writes is
# seen in order. M3 S1000 = the far end (2.0 ms), M5 = up (1.0 ms), M3 S250 =
# a quarter of the range; 50 Hz frames; disabled when the run ends.
pwm="$tmp/pwm0"; mkdir -p "$pwm"; echo 0 >"$pwm/period"; echo 0 >"$pwm/enable"; mkfifo "$pwm/duty_cycle"
# the reader reopens the FIFO after each writer closes it, until it reads END
timeout 90 $PY -c '
import sys
out = open(sys.argv[2], "w")
while True:
    with open(sys.argv[1]) as f:
        for ln in f:
            if ln.strip() == "END":
                sys.exit(0)
            out.write(ln); out.flush()
' "$pwm/duty_cycle" "$tmp/widths" &
rdr=$!
grep -v '^pen ' "$BOARD" >"$tmp/servo.conf"; echo "servo_pwm $pwm" >>"$tmp/servo.conf"
printf 'G21 G90\nM3 S1000\nG1 X5 Y5 F3000\nM5\nG0 X0 Y0\nM3 S250\nG1 X3 F3000\nM5\nM2\n' >"$tmp/servo.gcode"
timeout 60 "$BUILD/plotkin-gpiod-mock" --board "$tmp/servo.conf" --no-realtime "$tmp/servo.gcode" >"$tmp/out" 2>&1; rc=$?
timeout 10 sh -c 'echo END >"$1"' sh "$pwm/duty_cycle"; wait "$rdr" 2>/dev/null
widths=$(tr '\n' ' ' <"$tmp/widths")
if [[ $rc -eq 0 && $widths == "0 1000000 2000000 1000000 1250004 1000000 " && $(cat "$pwm/period") == 20000000 &&
      $(cat "$pwm/enable") == 0 ]]; then
  ok "a servo pen on a kernel PWM channel: 20 ms frames, widths up/S1000/up/S250/up in order, disabled at the end"
else
  bad "a servo pen on a kernel PWM channel" "exit $rc" "widths: $widths" "$(cat "$pwm/period" "$pwm/enable" "$tmp/out")"
fi
printf 'servo_pwm %s/nope/pwm3\n' "$tmp" | cat <(grep -v '^pen ' "$BOARD") - >"$tmp/servo_bad.conf"
timeout 20 "$BUILD/plotkin-gpiod-mock" --board "$tmp/servo_bad.conf" --no-realtime "$tmp/servo.gcode" >"$tmp/out" 2>&1; rc=$?
if [[ $rc -ne 0 ]] && grep -q "servo PWM $tmp/nope/pwm3" "$tmp/out"; then
  ok "a servo channel that is not there: a clear error naming it, no run"
else
  bad "a servo channel that is not there: a clear error naming it, no run" "exit $rc" "$(cat "$tmp/out")"
fi

echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
