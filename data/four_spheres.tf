# Transfer function for the four-spheres phantom, coloured as Nakao et al.'s Fig. 5 names its
# spheres: density 0.4 blue (soft), 0.6 green (hard), 0.8 red, 1.0 white (hapvox's label
# order, data/four_spheres.toml). Narrow opaque bands at those densities and nothing between,
# so a sphere's partial-volume rim does not show another sphere's colour.
# Format: docs/render.md ("density r g b a" a line).
0.00  0.00 0.00 0.00  0.00
0.36  0.20 0.35 0.95  0.00
0.38  0.20 0.35 0.95  0.70
0.42  0.20 0.35 0.95  0.70
0.44  0.20 0.35 0.95  0.00
0.56  0.20 0.80 0.25  0.00
0.58  0.20 0.80 0.25  0.70
0.62  0.20 0.80 0.25  0.70
0.64  0.20 0.80 0.25  0.00
0.76  0.90 0.20 0.15  0.00
0.78  0.90 0.20 0.15  0.70
0.82  0.90 0.20 0.15  0.70
0.84  0.90 0.20 0.15  0.00
0.96  0.95 0.95 0.95  0.00
0.98  0.95 0.95 0.95  0.70
1.00  0.95 0.95 0.95  0.70
