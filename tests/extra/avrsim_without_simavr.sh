#!/usr/bin/env bash
# avrsim_without_simavr.sh — the host tool builds where libsimavr is absent,
# and `plotkin avrsim` then says how to get it (exit 2) instead of failing
# obscurely. host-sim/avr_chip.c and cmd_avrsim.c are compiled here without
# PK_HAVE_SIMAVR, as on such a machine, and linked into a tool of their own.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $1"; }
bad() { fail=$((fail+1)); echo "not ok $1"; shift; printf '  %s\n' "$@"; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
if ! ${MAKE:-make} --no-print-directory -s BUILD="$BUILD" "$BUILD/libplotkin_host.a" "$BUILD/libplotkin_fw.a" >"$tmp/log" 2>&1; then
  bad "the host libraries build" "$(tail -n 5 "$tmp/log")"; echo "$pass passed, $fail failed"; exit 1
fi
FLAGS="-std=c11 -Wall -Wextra -Werror -Ifirmware -Ihal -Ihost-sim -D_POSIX_C_SOURCE=200809L"
cat >"$tmp/main.c" <<'C'
#include "commands.h"
int main(int argc, char **argv) { return cmd_avrsim(argc - 1, argv + 1); }
C
if cc $FLAGS -c host-sim/avr_chip.c -o "$tmp/avr_chip.o" 2>"$tmp/err" &&
   cc $FLAGS -c host-sim/cmd_avrsim.c -o "$tmp/cmd_avrsim.o" 2>>"$tmp/err" &&
   cc $FLAGS -c "$tmp/main.c" -o "$tmp/main.o" 2>>"$tmp/err" &&
   cc -o "$tmp/plotkin-nosim" "$tmp/main.o" "$tmp/cmd_avrsim.o" "$tmp/avr_chip.o" \
      "$BUILD/libplotkin_host.a" "$BUILD/libplotkin_fw.a" -lm 2>>"$tmp/err"; then
  ok "the avrsim command compiles and links without libsimavr"
else
  bad "the avrsim command compiles and links without libsimavr" "$(head -n 5 "$tmp/err")"
  echo "$pass passed, $fail failed"; exit 1
fi
if nm "$tmp/plotkin-nosim" | grep -q " U avr_\| T avr_run"; then
  bad "the tool without simavr references no libsimavr symbol" "$(nm "$tmp/plotkin-nosim" | grep ' avr_' | head -3)"
else
  ok "the tool without simavr references no libsimavr symbol"
fi
out=$("$tmp/plotkin-nosim" avrsim some.hex --run some.gcode 2>&1); rc=$?
if [[ $rc -eq 2 ]] && grep -q "no simavr: install it" <<<"$out" && grep -q "deps.sh targets" <<<"$out"; then
  ok "plotkin avrsim without simavr says how to get it (exit 2)"
else
  bad "plotkin avrsim without simavr says how to get it (exit 2)" "exit $rc" "$out"
fi
out=$("$tmp/plotkin-nosim" avrsim --help 2>&1); rc=$?
[[ $rc -eq 0 ]] && grep -q -- "--link PATH" <<<"$out" && ok "its --help still describes the command" \
  || bad "its --help still describes the command" "exit $rc"
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
