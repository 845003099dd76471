#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest.
# Usage: scripts/test.sh [--sanitize address|thread]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sanitize=""
if [ "${1:-}" = "--sanitize" ]; then
  sanitize=${2:?"--sanitize needs address or thread"}
fi
bash "$root/scripts/setup.sh"
build_dir="$root/build${sanitize:+-$sanitize}"
bash "$root/scripts/build.sh" "$build_dir" -DHAPVOX_SANITIZE="$sanitize" >/dev/null
export ASAN_OPTIONS=${ASAN_OPTIONS:-"detect_leaks=0:abort_on_error=1"}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
export TSAN_OPTIONS=${TSAN_OPTIONS:-"halt_on_error=1"}
cd "$build_dir"
ctest --output-on-failure -j "$(nproc)"
