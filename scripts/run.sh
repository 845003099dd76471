#!/usr/bin/env bash
# The main job: installs what is missing, builds the hapvox command (not the test suite:
# scripts/test.sh builds that), and replays the bundled press trace on the bundled engine
# CT, writing engine_press.h5 (an HDF5 session) in the current folder.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh"
mkdir -p "$root/build"
if ! bash "$root/scripts/build.sh" --target hapvox "$root/build" >"$root/build/build.log" 2>&1; then
  tail -n 60 "$root/build/build.log"
  echo "run.sh: build failed (full log: $root/build/build.log)" >&2
  exit 1
fi
"$root/build/tools/hapvox" replay "$root/traces/engine_press.csv" \
  --volume "$root/data/engine_256x256x128_uint8.nrrd" -o "${1:-engine_press.h5}"
