#!/usr/bin/env bash
# The kernel's --limit --tangents stage against the independent exact limit
# vectors (tests/vectors/cases and the reference set tests/vectors/exact):
# positions within 1 LSB, tangents within 0.05 degrees, closed curves up to a
# rotation. See tests/tools/check_limit_vectors.py and tests/vectors/README.md.
set -uo pipefail
cd "$(dirname "$0")/.."
B=${PLOTKIN_BUILD:-build}
dirs=(tests/vectors/cases tests/vectors/exact)
if [[ ! -x $B/plotkin ]]; then echo "FAIL: $B/plotkin not built"; echo "0 passed, 1 failed"; exit 1; fi
python3 tests/tools/check_limit_vectors.py "$B/plotkin" "${dirs[@]}"
