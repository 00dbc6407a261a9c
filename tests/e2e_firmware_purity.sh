#!/usr/bin/env bash
# The portable core must hold no heap, no stdio, no floating point, no mutable
# globals, and include nothing from the OS, the HAL backends or the simulator.
# Checked on what the compiler produced, not on the source text:
#  1. every firmware/*.c compiles with -mgeneral-regs-only (x86-64): any float
#     or double arithmetic is then a compile error;
#  2. the objects reference no malloc/free/printf/libm/soft-float symbols;
#  3. the objects define no writable data (.data/.bss: nm types D d B b);
#  4. firmware sources include only freestanding headers and their own (and,
#     for constant tables in flash on AVR, the toolchain's <avr/pgmspace.h>,
#     behind #if __AVR__ in firmware/pk_rom.h: architecture support, no board).
set -uo pipefail
cd "$(dirname "$0")/.."
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $1"; }
bad() { fail=$((fail+1)); echo "not ok $1"; shift; printf '  %s\n' "$@"; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

errs=()
for f in firmware/*.c; do
  o="$tmp/$(basename "${f%.c}").o"
  if ! out=$(cc -std=c11 -Wall -Wextra -Werror -O2 -ffreestanding -mgeneral-regs-only \
        -Ifirmware -Ihal -c "$f" -o "$o" 2>&1); then errs+=("$f: $(echo "$out" | grep -m1 error)"); fi
done
[[ ${#errs[@]} -eq 0 ]] && ok "firmware compiles with general registers only (no floating point)" \
  || bad "firmware compiles with general registers only (no floating point)" "${errs[@]}"

forbidden='^(malloc|calloc|realloc|free|aligned_alloc|printf|fprintf|sprintf|snprintf|vprintf|puts|putchar|fopen|exit|abort|sqrt|sqrtf|pow|sin|cos|atan2|floor|ceil|__(add|sub|mul|div)[sd]f3|__float.*|__fix.*|__extend.*|__trunc.*)$'
syms=$(for o in "$tmp"/*.o; do nm -u "$o" | awk '{print $2}'; done | sort -u | grep -E "$forbidden" || true)
[[ -z $syms ]] && ok "firmware objects call no heap, stdio, libm or soft-float routine" \
  || bad "firmware objects call no heap, stdio, libm or soft-float routine" "$syms"

data=$(for o in "$tmp"/*.o; do nm "$o" | awk -v f="$(basename "$o")" '$2 ~ /^[DdBb]$/ {print f": "$3}'; done)
[[ -z $data ]] && ok "firmware objects define no mutable global or static state" \
  || bad "firmware objects define no mutable global or static state" "$data"

inc=$(grep -hoE '^#include *[<"][^>"]+[>"]' firmware/*.c firmware/*.h | sort -u \
      | grep -vE '<(stdint|stddef|stdbool|limits|string|avr/pgmspace)\.h>|"(pk_[a-z0-9_]+|hal)\.h"' || true)
[[ -z $inc ]] && ok "firmware includes only freestanding headers, its own and hal.h" \
  || bad "firmware includes only freestanding headers, its own and hal.h" "$inc"

echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
