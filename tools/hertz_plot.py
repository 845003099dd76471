"""hapvox validate hertz: the contact law against Hertz, as a picture.

Usage: hertz_plot.py hertz.csv hertz.png (run by `hapvox validate hertz`). Top left: the
flat face, F / F_Hertz against d / h for every radius, Poisson's ratio and voxel size, from
a quarter voxel deep (the sub-voxel range shaded); top right: the seed's fixed-L law, same
cases, against d / R; bottom left: a sphere with partial-volume edges, every tick against
Hertz with R* = R R2 / (R + R2), at its pole and along the grid's diagonal; bottom right:
the same sphere as a binary staircase, with the band its +-h/2 |n|_1 surface allows.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"]
STYLES = ["-", "--", ":", "-."]


def read(csv_path):
    flat, curved = {}, {}
    with open(csv_path) as f:
        for row in csv.DictReader(f):
            r, h, d = float(row["radius_mm"]), float(row["voxel_mm"]), float(row["depth_mm"])
            force, closed = float(row["force_n"]), float(row["hertz_n"])
            if row["case"] == "flat":
                key = (r, float(row["poisson"]), h)
                flat.setdefault(key, []).append((d, force, float(row["paper_force_n"]), closed))
            else:
                key = (row["edge"], r, h, row["diagonal"] == "1")
                curved.setdefault(key, []).append(
                    (d, force, closed, float(row["lower_n"]), float(row["upper_n"])))
    return flat, curved


def draw_flat(ax, paper_ax, flat, colours, styles):
    ax.axvspan(0.25, 1.0, color="0.93", lw=0, label="sub-voxel: d < h")
    ax.axhspan(0.99, 1.01, color="0.85", lw=0, label="±1 % (the check from d = h; 5 % below)")
    for (r, nu, h), rows in sorted(flat.items()):
        rows = [x for x in rows if 0.25 * h <= x[0] <= 0.15 * r]
        if not rows:
            continue
        ax.plot([d / h for d, *_ in rows], [a / c for d, a, _, c in rows], color=colours[r],
                ls=styles[h], lw=1.0, alpha=0.8)
        paper_ax.plot([d / r for d, *_ in rows], [b / c for d, _, b, c in rows],
                      color=colours[r], ls=styles[h], lw=1.0, alpha=0.8)
    for r, colour in colours.items():
        ax.plot([], [], color=colour, label=f"R = {r:g} mm")
    for h, ls in styles.items():
        ax.plot([], [], color="0.3", ls=ls, label=f"voxels {h:g} mm")
    ax.set_xscale("log")
    ax.set_ylim(0.985, 1.015)
    ax.set_xlabel("indentation d / voxel size h (to d = 0.15 R)")
    ax.set_ylabel("F / F_Hertz")
    ax.set_title("flat face, hertz law: R x nu x h, from d = h/4", fontsize=10)
    ax.legend(fontsize=7, loc="lower right", ncol=2)
    paper_ax.set_xscale("log")
    paper_ax.set_yscale("log")
    paper_ax.set_xlabel("indentation d / R")
    paper_ax.set_ylabel("F / F_Hertz")
    paper_ax.set_title("flat face, the seed's law (L = R), same cases", fontsize=10)


def draw_curved(ax, curved, edge, colours, styles):
    if edge == "partial":
        ax.axhspan(0.95, 1.05, color="0.85", lw=0, label="±5 %")
    for (e, r, h, diagonal), rows in sorted(curved.items()):
        if e != edge:
            continue
        rows = [x for x in rows if x[0] >= h]
        if not rows:
            continue
        x = [d / h for d, *_ in rows]
        ax.plot(x, [f / c for _, f, c, _, _ in rows], color=colours[r], ls=styles[h],
                        lw=1.2 if diagonal else 2.2, alpha=0.85)
        if edge == "binary":
            ax.fill_between(x, [lo / c for _, _, c, lo, _ in rows],
                            [hi / c for _, _, c, _, hi in rows], color=colours[r], alpha=0.04)
    for r, colour in colours.items():
        ax.plot([], [], color=colour, label=f"R = {r:g} mm")
    ax.plot([], [], color="0.3", lw=2.2, label="pole (normal along z)")
    ax.plot([], [], color="0.3", lw=1.2, label="diagonal (normal along (1,1,1))")
    ax.set_xlabel("indentation d / voxel size h (to d = 0.2 R*)")
    ax.set_ylabel("F / F_Hertz(R*)")
    if edge == "partial":
        ax.set_ylim(0.9, 1.1)
        ax.set_title("sphere R2 = 12 mm, partial-volume edge: every tick from d = h",
                     fontsize=10)
    else:
        ax.set_ylim(0.5, 1.8)
        ax.set_title("the same sphere, binary staircase: every tick, and the band\n"
                     "0.95 F(d - h/2 |n|_1) .. 1.05 F(d + h/2 |n|_1) its surface allows",
                     fontsize=10)
    ax.legend(fontsize=7, loc="upper right", ncol=2)


def main(csv_path, png_path):
    flat, curved = read(csv_path)
    radii = sorted({k[0] for k in flat} | {k[1] for k in curved})
    colours = dict(zip(radii, COLOURS))
    voxels = sorted({k[2] for k in flat} | {k[2] for k in curved})
    styles = {h: STYLES[i % len(STYLES)] for i, h in enumerate(voxels)}
    fig, axes = plt.subplots(2, 2, figsize=(14, 10))
    draw_flat(axes[0][0], axes[0][1], flat, colours, styles)
    draw_curved(axes[1][0], curved, "partial", colours, styles)
    draw_curved(axes[1][1], curved, "binary", colours, styles)
    fig.tight_layout()
    fig.savefig(png_path, dpi=100)  # hapvox prints the path once it is in place


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
