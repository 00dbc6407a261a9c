#!/usr/bin/env bash
# campaign.sh SECONDS [TARGET...] — the long run: each target in turn (never
# two fuzzers at once: shared machines), its work corpus kept in
# build/fuzz/work/<target> between runs. Builds first. The summary lines are
# what tests/fuzz/README.md reports.
set -uo pipefail
cd "$(dirname "$0")/../.."
secs=${1:-600}; shift || true
make -s fuzz-build >/dev/null || exit 1
targets=("$@"); [[ ${#targets[@]} -eq 0 ]] && targets=(fuzz_refine fuzz_gcode fuzz_protocol fuzz_motion)
exec bash tests/fuzz/run_fuzz.sh build/fuzz "$secs" "${targets[@]}"
