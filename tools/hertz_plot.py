"""hapvox validate hertz: the contact law against Hertz, as a picture.

Usage: hertz_plot.py hertz.csv hertz.png (run by `hapvox validate hertz`). Left: the
force over Hertz's F = 4/3 E* sqrt(R) d^1.5 against d/R for every case with hapvox's
default law, the +-5 % band and the checked range shaded; middle: the same for the seed's
fixed-L law; right: force against depth on log-log axes for nu = 0.3, finest voxels.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png_path):
    cases = {}
    with open(csv_path) as f:
        for row in csv.DictReader(f):
            key = (float(row["radius_mm"]), float(row["poisson"]), float(row["voxel_mm"]))
            cases.setdefault(key, []).append(
                (float(row["depth_mm"]), float(row["force_hertz_law_n"]),
                 float(row["force_paper_law_n"]), float(row["force_hertz_n"])))
    radii = sorted({k[0] for k in cases})
    colours = dict(zip(radii, ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"]))
    styles = {}
    for h in sorted({k[2] for k in cases}):
        styles[h] = ["-", "--", ":", "-."][len(styles) % 4]
    fig, (left, middle, right) = plt.subplots(1, 3, figsize=(17, 5.2))
    for ax in (left, middle):
        ax.axvspan(0.02, 0.15, color="0.93", lw=0)
    left.axhspan(0.95, 1.05, color="0.85", lw=0, label="±5 %")
    for (r, nu, h), rows in sorted(cases.items()):
        rows = [x for x in rows if x[0] >= h]  # at least one voxel deep
        if not rows:
            continue
        ratio = [d / r for d, *_ in rows]
        left.plot(ratio, [a / c for _, a, _, c in rows], color=colours[r], ls=styles[h], lw=1.0,
                  alpha=0.8)
        middle.plot(ratio, [b / c for _, _, b, c in rows], color=colours[r], ls=styles[h],
                    lw=1.0, alpha=0.8)
        middle.annotate(f"nu {nu:g}", (ratio[-1], rows[-1][2] / rows[-1][3]), fontsize=6,
                        color=colours[r])
    for r in radii:
        left.plot([], [], color=colours[r], label=f"R = {r:g} mm")
    for h, ls in styles.items():
        left.plot([], [], color="0.3", ls=ls, label=f"voxels {h:g} mm")
    left.set_xscale("log")
    left.set_ylim(0.9, 1.1)
    left.set_xlabel("indentation d / R (shaded: the checked range)")
    left.set_ylabel("F / F_Hertz")
    left.set_title("hapvox (hertz law): R x nu x voxel size, d >= one voxel\n"
                   "(F / F_Hertz depends on d / R only: the R curves coincide)", fontsize=10)
    left.legend(fontsize=8, loc="lower right", ncol=2)
    middle.set_xscale("log")
    middle.set_yscale("log")
    middle.set_xlabel("indentation d / R")
    middle.set_ylabel("F / F_Hertz")
    middle.set_title("the seed's law (L = R), same cases, by nu", fontsize=10)
    finest = min(k[2] for k in cases)
    for (r, nu, h), rows in sorted(cases.items()):
        if h != finest or abs(nu - 0.3) > 1e-9:
            continue
        rows = [x for x in rows if x[0] >= h]
        d = [x[0] for x in rows]
        right.plot(d, [x[1] for x in rows], color=colours[r], lw=2.5, alpha=0.7,
                   label=f"hapvox, R = {r:g} mm")
        right.plot(d, [x[3] for x in rows], color="k", lw=0.9, ls=":")
        right.plot(d, [x[2] for x in rows], color=colours[r], lw=0.9, ls="--")
    right.plot([], [], color="k", ls=":", label="Hertz 4/3 E* sqrt(R) d^1.5")
    right.plot([], [], color="0.4", ls="--", label="seed's law, L = R")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlabel("indentation d (mm)")
    right.set_ylabel("force (N)")
    right.set_title(f"nu = 0.3, voxels {finest:g} mm, E = 100 kPa")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)  # hapvox prints the path once it is in place


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
