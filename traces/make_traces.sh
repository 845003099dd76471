#!/usr/bin/env bash
# Regenerates the bundled synthetic traces. Usage: traces/make_traces.sh [path/to/hapvox]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hapvox=${1:-"$here/../build/tools/hapvox"}

# Engine CT (data/engine_256x256x128_uint8.nrrd): the flat top of the block is the
# voxel layer z = 107 around x = 96..160, y = 64.
"$hapvox" trace make press-release -o "$here/engine_press.csv" \
  --start-mm 128,64,120 --travel-mm 12 --speed-mm-s 10 --hold-s 0.5
"$hapvox" trace make stroke -o "$here/engine_stroke.csv" \
  --start-mm 100,64,118 --travel-mm 8 --speed-mm-s 20 --length-mm 40
# Clay block generator `block` (128^3, 1 mm voxels, face at z = 63.5).
"$hapvox" trace make circle -o "$here/block_circle.h5" \
  --start-mm 64,64,72 --travel-mm 6 --speed-mm-s 20 --radius-mm 15

# A recorder-style trace: irregular ~250 Hz sampling, a 120 ms dropout, time in ms,
# positions in metres in the device's own frame (volume = device + (128, 64, 100) mm), and
# an extra button column. Derived from engine_press.csv.
/usr/bin/python3 - "$here" <<'PY'
import csv, random, sys
here = sys.argv[1]
rows = list(csv.DictReader(open(f"{here}/engine_press.csv")))
t = [float(r["t"]) for r in rows]
p = [(float(r["x"]), float(r["y"]), float(r["z"])) for r in rows]
random.seed(11)
out = open(f"{here}/engine_press_irregular.csv", "w")
out.write("time_ms,px_m,py_m,pz_m,button\n")
now = 0.0
while now <= t[-1]:
    if not (1.0 <= now < 1.12):  # dropout
        i = min(int(now * 1000), len(p) - 2)
        f = now * 1000 - i
        q = [p[i][a] + f * (p[i + 1][a] - p[i][a]) for a in range(3)]
        d = [(q[0] - 128) / 1000, (q[1] - 64) / 1000, (q[2] - 100) / 1000]
        out.write(f"{now*1000:.3f},{d[0]:.9f},{d[1]:.9f},{d[2]:.9f},{1 if now > 0.5 else 0}\n")
    now += random.uniform(0.002, 0.006)
PY

# Clay sculpting (replay with --plastic on the `block` generator): press 4 mm below the
# face with the 8 mm tool, plough 40 mm along +x, lift.
"$hapvox" trace make stroke -o "$here/clay_stroke.csv" \
  --start-mm 44,64,72 --travel-mm 12 --speed-mm-s 10 --length-mm 40

# Nakao et al.'s Fig. 5 on the `four-spheres` generator (128^3, 1 mm voxels; materials in
# data/four_spheres.toml), replayed with --model fem --interaction grab: pull the white
# sphere's right side (+x) 8 mm while its left side is fixed, and grab the red sphere
# 8 mm toward the blue one.
"$hapvox" trace make press -o "$here/fig5_pull.csv" \
  --start-mm 58.6,41.33,85.67 --direction 1,0,0 --travel-mm 8 --speed-mm-s 8 --hold-s 0.5
"$hapvox" trace make press -o "$here/fig5_grab.csv" \
  --start-mm 41.33,85.67,41.33 --direction 1,0,1 --travel-mm 8 --speed-mm-s 8 --hold-s 0.5
# Nakao et al.'s Fig. 6 on the engine CT (materials in data/engine_grab.toml, its left part
# fixed): grab the block's right end and lift it 12 mm.
"$hapvox" trace make press -o "$here/engine_grab.csv" \
  --start-mm 188,118,70 --direction 0,0,1 --travel-mm 12 --speed-mm-s 40 --hold-s 0.2
