#!/usr/bin/env bash
# board_property.sh — the motion property test (tests/test_motion_limits.c:
# every mode, random programs at 1 to 400 steps/mm; rates, accelerations and
# path deviation within their bounds) built with a board's knobs
# (BUILD/firmware/<board>/host/test_motion_limits: the same firmware/ sources
# and PK_* knobs as the image, compiled for the host). What a board changes in
# the motion core (the AVR boards' 4 ms segments, PK_SG_SEG_HZ=250; their
# shorter queues) is held to the bounds of the default build.
# The Mega only: its image builds every scheme and 3 axes, which the sweep
# uses; the Uno's refuses most of them (FIXED smoothing, 3 axes) at
# pk_machine_init, as it must (tests/extra/board_refusals.sh), and shares the
# Mega's segment and step-generator knobs.
# Needs only a host C compiler.
set -uo pipefail
cd "$(dirname "$0")/../.."
BUILD=${PLOTKIN_BUILD:-build}
t="$BUILD/firmware/mega-ramps/host/test_motion_limits"
if ! out=$(${MAKE:-make} --no-print-directory -s BUILD="$BUILD" "$t" 2>&1); then
  printf '%s\n' "$out" | tail -n 20
  echo "not ok the property test builds with the mega-ramps knobs"; echo "0 passed, 1 failed"; exit 1
fi
exec "$t"
