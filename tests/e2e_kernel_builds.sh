#!/usr/bin/env bash
# e2e_kernel_builds.sh — every kernel build the README offers, compiled from
# the firmware sources with its own macros and checked by
# tests/kernel_build_check.c: init answers exactly as the build promises
# (PK_ENOTSUP for what is left out), every output is the exactly rounded
# rational, the block pull equals the point pull, and whatever a restricted
# build supports gives bit for bit what the full build gives (limit points
# and tangents included). Builds with PK_MAX_DEPTH <= 5 and no cascade run on
# 32-bit working values: this is where those are tested on the host.
set -uo pipefail
cd "$(dirname "$0")/.."
B=${PLOTKIN_BUILD:-build}
out=$B/kernel-builds
mkdir -p "$out"
pass=0; fail=0
ok()  { pass=$((pass+1)); echo "ok $*"; }
bad() { fail=$((fail+1)); echo "not ok $*"; }

KSRC="firmware/pk_refine.c firmware/pk_refine_span.c firmware/pk_refine_cascade.c firmware/pk_limit.c firmware/pk_refine_chaikin.c
      firmware/pk_masks.c firmware/pk_fixed.c"
CFLAGS="-std=c11 -O2 -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wundef
        -Ifirmware -Itests"
# name: flags (the README's build table)
builds=(
  "full:"
  "full-nolimit:-DPK_BUILD_LIMIT=0"
  "splines:-DPK_BUILD_DEGREES=0x0E -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x0A"
  "chaikin-limit:-DPK_AXES=2 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0"
  "chaikin:-DPK_AXES=2 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0"
  "chaikin-d5-limit:-DPK_AXES=2 -DPK_MAX_DEPTH=5 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0"
  "chaikin-d5:-DPK_AXES=2 -DPK_MAX_DEPTH=5 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0"
  "chaikin-d5-fast-pull:-DPK_AXES=2 -DPK_MAX_DEPTH=5 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0 -DPK_REFINE_FAST_PULL=1"
  "chaikin-d5-all-ends:-DPK_MAX_DEPTH=5 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x0A"
  "cubic-d3:-DPK_MAX_DEPTH=3 -DPK_BUILD_DEGREES=0x08 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x0A"
  "linear:-DPK_BUILD_DEGREES=0x02 -DPK_BUILD_DLG=0"
  "dlg:-DPK_BUILD_DEGREES=0 -DPK_BUILD_DLG=1"
  "board-mega-ramps:-DPK_BUILD_LIMIT=0 -DPK_MAX_DEPTH=6 -DPK_WIN=4"
  "board-uno:-DPK_AXES=2 -DPK_BUILD_DEGREES=0x06 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0"
)
declare -A full
for b in "${builds[@]}"; do
  name=${b%%:*}; flags=${b#*:}
  exe=$out/check-$name
  # shellcheck disable=SC2086
  if ! cc $CFLAGS $flags -o "$exe" tests/kernel_build_check.c $KSRC 2>"$out/$name.err"; then
    bad "$name builds ($(head -n 3 "$out/$name.err" | tr '\n' ' '))"; continue
  fi
  # shellcheck disable=SC2086
  if cc $CFLAGS $flags -DLAYOUT_FIXED_FIRST=1 -c -o "$out/layout-$name-a.o" tests/kernel_layout_check.c 2>"$out/$name.err" &&
     cc $CFLAGS $flags -DLAYOUT_FIXED_FIRST=0 -o "$out/layout-$name" tests/kernel_layout_check.c "$out/layout-$name-a.o" 2>>"$out/$name.err"; then
    lay=$("$out/layout-$name") && ok "$name: one layout of the kernel state in every unit ($lay)" \
      || bad "$name: the kernel state's layout depends on the include order ($lay)"
  else bad "$name: the layout check builds ($(head -n 3 "$out/$name.err" | tr '\n' ' '))"; fi
  "$exe" > "$out/$name.out"; rc=$?
  last=$(tail -n 1 "$out/$name.out"); info=$(grep '^#' "$out/$name.out")
  if [[ $rc -eq 0 ]]; then ok "$name: $last ${info#\# }"; else
    bad "$name: $last"; grep '^not ok' "$out/$name.out" | head -n 5; fi
  if [[ $name == full ]]; then
    while read -r key h; do full[$key]=$h; done < <(grep -E '^[0-9]+/' "$out/$name.out")
  else
    diffs=0; n=0
    while read -r key h; do
      n=$((n+1))
      [[ ${full[$key]:-} == "$h" ]] || { diffs=$((diffs+1)); [[ $diffs -le 3 ]] && echo "  $key: $h, full build ${full[$key]:-none}"; }
    done < <(grep -E '^[0-9]+/' "$out/$name.out")
    [[ $diffs -eq 0 && $n -gt 0 ]] && ok "$name: its $n configurations give what the full build gives" \
      || bad "$name: $diffs of its $n configurations differ from the full build"
  fi
done
echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
