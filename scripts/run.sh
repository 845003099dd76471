#!/usr/bin/env bash
# The main job: installs what is missing, builds, and replays the bundled press trace on
# the bundled engine CT, writing engine_press.h5 (an HDF5 session) in the current folder.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh" "$root/build" >/dev/null
"$root/build/tools/hapvox" replay "$root/traces/engine_press.csv" \
  --volume "$root/data/engine_256x256x128_uint8.nrrd" -o "${1:-engine_press.h5}"
