#!/usr/bin/env bash
# Nakao et al.'s Fig. 5 on the four-spheres phantom (128^3, 1 mm voxels): the white sphere's
# right side pulled 8 mm while its left side is fixed (traces/fig5_pull.csv), and the red
# sphere grabbed 8 mm toward the blue one (traces/fig5_grab.csv), each with the paper's
# moduli (data/four_spheres.toml) and with uniform ones (data/four_spheres_homogeneous.toml).
# Prints each run's mean strain per sphere (`hapvox info`) and writes OUT/fig5_pull.png and
# OUT/fig5_grab.png: the displacement on the mid-slice through the spheres involved; and
# OUT/fig5_render.png: the deformed CT itself, drawn from the proxy mesh (docs/render.md) as
# the paper shows it: initial, pulled, grabbed, and grabbed with uniform moduli.
# A stiff coupling (1000 N/mm, the most `replay` takes; a force limit far above it) makes the grab displacement-
# controlled, as in the paper, all but F/k_c: the pull's 1.4 kN leaves it 1.4 mm short of 8 mm.
# Usage: scripts/fig5.sh [OUT_DIR] [extra replay flags...]  (needs build/tools/hapvox)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-fig5}
shift || true
hapvox="$root/build/tools/hapvox"
[ -x "$hapvox" ] || { echo "fig5.sh: build hapvox first (scripts/build.sh --target hapvox)" >&2; exit 2; }
mkdir -p "$out"
# The interaction areas: the pull grabs the white sphere's right side within 8 mm, the grab
# the red sphere's core within 15 mm of its centre (its radius is 23 mm).
declare -A capture_diameter_mm=([pull]=16 [grab]=30)
for experiment in pull grab; do
  for materials in four_spheres four_spheres_homogeneous; do
    session="$out/${experiment}_${materials}.h5"
    "$hapvox" replay "$root/traces/fig5_$experiment.csv" --volume four-spheres --model fem \
      --materials "$root/data/$materials.toml" --interaction grab --boundary-levels 1 \
      --tool-diameter-mm "${capture_diameter_mm[$experiment]}" \
      --coupling-n-per-mm 1000 --max-force-n 100000 --ramp-in-s 0 -q -o "$session" \
      --render-dir "$out/frames_${experiment}_$materials" --render-every-ticks 1000000 \
      --render-size 320 --render-transfer "$root/data/four_spheres.tf" \
      --render-azimuth-deg -30 --render-elevation-deg 30 "$@"
    echo "== $experiment, $materials.toml (labels: 1 blue, 2 green, 3 red, 4 white, 0 background)"
    "$hapvox" info "$session" | sed -n '/strain at the last/,$p'
  done
done
# Sphere outlines (x,y,z,r in mm) and the planes: z through the white and blue centres for
# the pull, y through the red and blue centres for the grab.
lo=41.33 hi=85.67 r=23.04
spheres="$hi,$hi,$hi,$r $hi,$lo,$lo,$r $lo,$hi,$lo,$r $lo,$lo,$hi,$r"
/usr/bin/python3 "$root/scripts/fig5_plot.py" "$out/fig5_pull.png" "Fig. 5 pull (white sphere)" \
  "$out/pull_four_spheres.h5" "$out/pull_four_spheres_homogeneous.h5" z $hi $spheres
/usr/bin/python3 "$root/scripts/fig5_plot.py" "$out/fig5_grab.png" "Fig. 5 grab (red toward blue)" \
  "$out/grab_four_spheres.h5" "$out/grab_four_spheres_homogeneous.h5" y $hi $spheres
# Each run drew its first and last tick: frame_0000.png and frame_0001.png.
/usr/bin/python3 "$root/scripts/fig5_panels.py" "$out/fig5_render.png" \
  "initial=$out/frames_pull_four_spheres/frame_0000.png" \
  "pulled=$out/frames_pull_four_spheres/frame_0001.png" \
  "grabbed=$out/frames_grab_four_spheres/frame_0001.png" \
  "homogeneous=$out/frames_grab_four_spheres_homogeneous/frame_0001.png" \
  --difference grabbed homogeneous
echo "fig5.sh: wrote $out/fig5_pull.png, $out/fig5_grab.png and $out/fig5_render.png"
