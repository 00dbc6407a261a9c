#!/usr/bin/env bash
# targets_fwcheck.sh — the gate of `make targets` can fail.
#
# Compiles tests/targets/fwcheck_cases.c for Cortex-M0+, Cortex-M4 (hardware
# FPU) and the ATmega328P once clean and once per broken rule (heap, stdio,
# float, mutable static, software divide one call deep in the step path, a
# step function that does not exist) and checks that fwcheck.py passes the
# clean objects and rejects each broken one naming the rule. Skipped
# (0 passed, 0 failed) without the cross compilers.
set -uo pipefail
cd "$(dirname "$0")/../.."
if ! command -v arm-none-eabi-gcc >/dev/null || ! command -v avr-gcc >/dev/null; then
  echo "targets_fwcheck: cross compilers missing (bash .ci/deps.sh targets): skipped"
  echo "0 passed, 0 failed"; exit 0
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
OPT="-std=c11 -Os -ffreestanding -ffunction-sections -fdata-sections -fno-common -Wall -Wextra -Werror"
declare -A CC=([m0plus]=arm-none-eabi-gcc [m4]=arm-none-eabi-gcc [avr]=avr-gcc)
declare -A FL=([m0plus]="-mcpu=cortex-m0plus -mthumb -mfloat-abi=soft"
               [m4]="-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16"
               [avr]="-mmcu=atmega328p")
declare -A PFX=([m0plus]=arm-none-eabi- [m4]=arm-none-eabi- [avr]=avr-)
declare -A FPU=([m0plus]=no [m4]=yes [avr]=no)
pass=0; fail=0
check() {  # target case want_rc want_text [extra fwcheck args...]
  local t=$1 c=$2 rc_want=$3 text=$4; shift 4
  local def=""; [[ $c != CLEAN ]] && def="-DCASE_$c"
  local o=$tmp/$t-$c/fwcheck_cases.o; mkdir -p "$(dirname "$o")"
  if ! ${CC[$t]} $OPT ${FL[$t]} $def -c tests/targets/fwcheck_cases.c -o "$o" 2>"$tmp/err"; then
    cat "$tmp/err"; echo "not ok $t $c: does not compile"; fail=$((fail+1)); return
  fi
  local out rc
  out=$(/usr/bin/python3 tests/targets/fwcheck.py "$@" --target "$t:${PFX[$t]}:${FPU[$t]}" "$o" 2>&1); rc=$?
  if [[ $rc -eq $rc_want ]] && grep -q -- "$text" <<<"$out"; then
    pass=$((pass+1)); echo "ok $t $c -> exit $rc ($text)"
  else
    fail=$((fail+1)); printf '%s\n' "$out" | tail -n 5; echo "not ok $t $c: exit $rc, wanted $rc_want and '$text'"
  fi
}
for t in m0plus m4 avr; do
  check "$t" CLEAN 0 "no software divide on the step path" --step-func fwc_step
  check "$t" HEAP 1 "heap allocator: malloc"
  check "$t" STDIO 1 "stdio"
  check "$t" STATIC 1 "mutable static storage"
  check "$t" STEP_DIVIDE 1 "step path calls __.*: fwc_step -> fwc_helper" --step-func fwc_step
  check "$t" CLEAN 1 "step-path function fwc_stepper not found" --step-func fwc_stepper
done
# Board images: a static named with --allow-static passes (the image's one
# controller / backend instance), any other static still fails.
for t in m0plus avr; do
  mkdir -p "$tmp/sym-$t"
  ${CC[$t]} $OPT ${FL[$t]} -DCASE_STATIC -c tests/targets/fwcheck_cases.c -o "$tmp/sym-$t/fwcheck_cases.o"
  sym=$(${PFX[$t]}nm "$tmp/sym-$t/fwcheck_cases.o" | awk '$2 ~ /^[bBdD]$/ {print $3; exit}')
  check "$t" STATIC 0 "static storage allowed for $sym" --allow-static "fwcheck_cases.o:$sym"
  check "$t" STATIC 1 "mutable static storage .*: $sym" --allow-static fwcheck_cases.o:app
done
check m0plus FLOAT 1 "floating point (soft-float helper or libm): __aeabi_f"
check m4 FLOAT 1 "floating-point instruction: .*vmul"
check avr FLOAT 1 "floating point (soft-float helper or libm): __"
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
