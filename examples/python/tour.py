"""A notebook-style tour of hapvox from Python (docs/api.md shows its output).

Run from the repository root after building:  PYTHONPATH=build/python python3 examples/python/tour.py
"""
import numpy as np

import hapvox

print("hapvox", hapvox.__version__)

# 1. A volume: the bundled engine CT, its intensities thresholded by Otsu's method.
ct = hapvox.Volume.load("data/engine_256x256x128_uint8.nrrd")
print("CT", ct.dims, "voxels of", ct.spacing_mm, "mm")

# 2. `hapvox replay` as a function: the session's datasets are numpy arrays.
session = hapvox.replay(volume="data/engine_256x256x128_uint8.nrrd",
                        trace="traces/engine_press.csv", tool_diameter_mm=6)
force = session["force_n"]                      # (ticks, 3), newtons
print(session.rows, "ticks; peak force %.3f N at t = %.3f s" % (
    np.linalg.norm(force, axis=1).max(), session["time_s"][np.linalg.norm(force, axis=1).argmax()]))

# 3. Your own volume from a numpy array: a 40 mm clay cube in a 64 mm box, 1 mm voxels.
density = np.zeros((64, 64, 64), np.float32)
density[12:52, 12:52, 0:40] = 1.0               # [i, j, k] = (x, y, z); clay below z = 40 mm
clay = hapvox.Volume.from_array(density)
model = hapvox.Model.voxel(clay, youngs_modulus_pa=20e3, tool_diameter_mm=8)

# 4. Step the 1 kHz force stage from a Python loop: press 3 mm into the top, then hold.
stage = hapvox.ForceStage(model)
top_mm = clay.origin_mm[2] + 39.5                # the clay's top face (voxel faces at +-0.5)
depth = np.concatenate([np.linspace(0.0, 3.0, 300), np.full(200, 3.0)])
for d in depth:
    tick = stage.step([32.0, 32.0, top_mm + model.tool_radius_mm - d])
print("pressed %.1f mm: force %s N, contact area %.1f mm^2" % (
    depth[-1], np.round(tick.force_n, 4), tick.contact_area_mm2))

# The same 500 ticks in one call, the GIL released: the same forces.
positions = np.stack([np.full_like(depth, 32.0), np.full_like(depth, 32.0),
                      top_mm + model.tool_radius_mm - depth], axis=1)
forces = hapvox.ForceStage(model).step_many(positions)
print("step_many: last force", np.round(forces[-1], 4), "N")

# 5. Bad input raises hapvox.InputError with the command line's message.
try:
    hapvox.Model.voxel(clay, poisson_ratio=0.7)
except hapvox.InputError as error:
    print("InputError:", error)
