#!/usr/bin/env bash
# Install the Debian packages plotkin needs, only those that are missing.
#   bash .ci/deps.sh base      build + host tests (libgpiod headers, pty/serial tools)
#   bash .ci/deps.sh targets   Cortex-M (QEMU) and AVR (simavr) cross toolchains
#   bash .ci/deps.sh fuzz      clang + libFuzzer runtime
#   bash .ci/deps.sh bench     valgrind, node/npm for the peer benchmarks
# Several groups may be given. Needs root (apt-get) only when something is missing.
set -euo pipefail
declare -A GROUP=(
  [base]="gcc make libc6-dev pkg-config libgpiod-dev gpiod python3 python3-serial socat"
  [targets]="gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm gcc-avr avr-libc simavr libsimavr-dev libelf-dev"
  [fuzz]="clang libclang-rt-14-dev"
  [bench]="valgrind nodejs npm"
)
want=()
for g in "${@:-base}"; do
  [[ -n "${GROUP[$g]:-}" ]] || { echo "deps.sh: unknown group '$g'" >&2; exit 2; }
  for p in ${GROUP[$g]}; do
    # node and npm may come from outside Debian (a NodeSource or nvm install);
    # asking apt for them then conflicts, so a working command is enough
    if [[ $p == nodejs || $p == npm ]]; then
      cmd=$p; [[ $p == nodejs ]] && cmd=node
      command -v "$cmd" >/dev/null 2>&1 && continue
    fi
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || want+=("$p")
  done
done
[[ ${#want[@]} -eq 0 ]] && exit 0
echo "deps.sh: installing ${want[*]}" >&2
if [[ $(id -u) -ne 0 ]]; then
  echo "deps.sh: not root; run: sudo apt-get install -y ${want[*]}" >&2; exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq >/dev/null
extra=()
# The ARM toolchain pulls 3 GB of recommends; without them it is under 1 GB.
for p in "${want[@]}"; do [[ $p == gcc-arm-none-eabi ]] && extra=(--no-install-recommends); done
apt-get install -y -qq "${extra[@]}" "${want[@]}" >/dev/null
