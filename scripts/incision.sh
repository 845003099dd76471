#!/usr/bin/env bash
# Nakao et al.'s Fig. 7 on the bundled engine CT: an incision (data/engine_incision.toml, a
# vertical cut at x = 165 mm held open 8 mm) and then a deformation of the cut volume (the
# engine's right end grabbed and lifted 12 mm, traces/engine_grab.csv), drawn from the proxy
# mesh with volume shadows. Writes OUT/incision_render.png: intact, cut open, cut and grabbed.
# Usage: scripts/incision.sh [OUT_DIR]  (needs build/tools/hapvox; python3 with matplotlib)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-incision}
hapvox="$root/build/tools/hapvox"
[ -x "$hapvox" ] || { echo "incision.sh: build hapvox first (scripts/build.sh --target hapvox)" >&2; exit 2; }
mkdir -p "$out"
common=(--model fem --materials "$root/data/engine_grab.toml" --spacing-mm 16 --boundary-levels 0
        --size 480x360 --azimuth-deg -70 --elevation-deg 40 --shadows -q)
volume="$root/data/engine_256x256x128_uint8.nrrd"
"$hapvox" render "$volume" "${common[@]}" -o "$out/intact"
"$hapvox" render "$volume" "${common[@]}" --incision "$root/data/engine_incision.toml" \
  --trace "$root/traces/engine_grab.csv" --interaction grab --tool-diameter-mm 24 \
  --coupling-n-per-mm 1000 --every-ticks 499 -o "$out/cut"
python3 - "$out" <<'PY'
import sys
import matplotlib.image as image
import numpy as np
out = sys.argv[1]
frames = [f"{out}/intact/frame_0000.png", f"{out}/cut/frame_0000.png", f"{out}/cut/frame_0002.png"]
panels = [image.imread(p)[60:300, 80:420, :3] for p in frames]
image.imsave(f"{out}/incision_render.png", np.concatenate(panels, axis=1))
print(f"wrote {out}/incision_render.png: intact | cut open 8 mm | cut and grabbed")
PY
