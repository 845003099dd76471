#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite with ctest.
# Usage: scripts/test.sh [--sanitize address|thread] [--targets "TARGET..."] [ctest arguments...]
# --targets builds only the targets named (scripts/build.sh --target), for a run whose ctest
# arguments (-R) select only tests in those binaries. ctest lists a test binary that was not
# built as one test, TARGET_NOT_BUILT, which fails if selected; the tests inside it are not
# listed at all, so a selection that names them silently runs none of them.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sanitize=""
targets=()
while true; do
  case "${1:-}" in
    --sanitize)
      sanitize=${2:?"--sanitize needs address or thread"}
      shift 2
      ;;
    --targets)
      targets=(--target "${2:?"--targets needs target names, e.g. \"haptics_tests hapvox\""}")
      shift 2
      ;;
    *) break ;;
  esac
done
bash "$root/scripts/setup.sh"
build_dir="$root/build${sanitize:+-$sanitize}"
# The build's own output goes to a log; on failure its tail is shown.
mkdir -p "$build_dir"
if ! bash "$root/scripts/build.sh" "${targets[@]}" "$build_dir" -DHAPVOX_SANITIZE="$sanitize" \
  >"$build_dir/build.log" 2>&1; then
  tail -n 60 "$build_dir/build.log"
  echo "test.sh: build failed (full log: $build_dir/build.log)" >&2
  exit 1
fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-"detect_leaks=0:abort_on_error=1"}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
# history_size=7 (4M accesses per thread, the most): a report whose earlier access is older
# than the history shows "failed to restore the stack", and then a suppression cannot match
# it (scripts/tsan.supp names libtbb's frames).
export TSAN_OPTIONS=${TSAN_OPTIONS:-"halt_on_error=1 second_deadlock_stack=1 history_size=7 suppressions=$root/scripts/tsan.supp"}
cd "$build_dir"
if [ ${#targets[@]} -gt 0 ]; then
  not_built=$(ctest -N | sed -n 's/^ *Test *#[0-9]*: \(.*\)_NOT_BUILT$/\1/p' | sort -u)
  echo "test.sh: built only ${targets[*]:1}; not built, so none of their tests run:" $not_built
fi
ctest --output-on-failure -j "$(nproc)" "$@"
