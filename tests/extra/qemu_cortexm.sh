#!/usr/bin/env bash
# qemu_cortexm.sh — the kernel's unit tests on an emulated Cortex-M3.
#
# Runs every on-target test image (tests/targets/module.mk: QEMU_PROGS, the
# same tests/test_*.c sources as the host, linked with a semihosting th_write
# and no libc) under `qemu-system-arm -M mps2-an385`. A program passes when
# its closing "N passed, N failed" line says 0 failed AND QEMU's exit code
# (SYS_EXIT_EXTENDED, = th_main's return) is 0. A deliberately failing image
# must come back with exit code 1 and "1 failed", and a deliberately crashing
# one with the fault handler's exit code 120: a failure or a crash on target
# cannot look like a pass. Prints "N passed, N failed" last (the sum of
# the programs' cases plus the exit-code check); skipped (0 passed, 0 failed)
# when the Arm toolchain or QEMU is not installed.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
if ! command -v arm-none-eabi-gcc >/dev/null || ! command -v qemu-system-arm >/dev/null; then
  echo "qemu_cortexm: arm-none-eabi-gcc or qemu-system-arm missing (bash .ci/deps.sh targets): skipped"
  echo "0 passed, 0 failed"; exit 0
fi
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" qemu-images 2>&1); then
  printf '%s\n' "$out" | tail -n 20
  echo "FAIL qemu_cortexm: building the images failed"; echo "0 passed, 1 failed"; exit 1
fi
DIR=$BUILD/targets/m3/tests
runq() {  # image -> sets qout, qrc
  qout=$(timeout 30 qemu-system-arm -M mps2-an385 -nographic -monitor none -serial none \
           -semihosting-config enable=on,target=native -kernel "$1" </dev/null 2>&1); qrc=$?
}
tp=0; tf=0
for img in "$DIR"/*.elf; do
  name=$(basename "$img" .elf)
  [[ $name == deliberate_fail || $name == deliberate_fault ]] && continue
  runq "$img"
  last=$(printf '%s\n' "$qout" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1)
  if [[ -z $last ]]; then
    printf '%s\n' "$qout" | tail -n 10
    why="exit $qrc"; [[ $qrc -eq 124 ]] && why="timeout after 30 s"; [[ $qrc -eq 120 ]] && why="fault"
    echo "FAIL $name on cortex-m3: no result line ($why)"; tf=$((tf+1)); continue
  fi
  p=${last%% passed*}; f=${last#*, }; f=${f%% failed*}
  tp=$((tp+p)); tf=$((tf+f))
  if [[ $qrc -ne $f ]]; then
    echo "FAIL $name on cortex-m3: exit code $qrc but $f failed"; tf=$((tf+1))
  fi
  [[ $f -ne 0 ]] && printf '%s\n' "$qout" | grep -E 'FAIL|not ok' | head -n 20
  printf 'cortex-m3 %-30s %s\n' "$name" "$last"
done
runq "$DIR/deliberate_fail.elf"
last=$(printf '%s\n' "$qout" | grep -E '^[0-9]+ passed, [0-9]+ failed' | tail -n 1)
if [[ $qrc -eq 1 && $last == *", 1 failed" ]]; then
  tp=$((tp+1)); echo "cortex-m3 a failing test fails the run: exit code 1, '$last'"
else
  tf=$((tf+1)); echo "FAIL cortex-m3 deliberate failure not reported: exit $qrc, '$last'"
fi
runq "$DIR/deliberate_fault.elf"
if [[ $qrc -eq 120 ]] && grep -q '^FAULT' <<<"$qout" && ! grep -qE '^[0-9]+ passed, 0 failed' <<<"$qout"; then
  tp=$((tp+1)); echo "cortex-m3 a crashing test fails the run: fault handler, exit code 120"
else
  tf=$((tf+1)); echo "FAIL cortex-m3 deliberate crash not reported: exit $qrc"
fi
echo "$tp passed, $tf failed"
[[ $tf -eq 0 ]]
