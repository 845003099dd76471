"""hapvox validate contact: the Hertz law's energy and friction, as a picture.

Usage: contact_plot.py contact.csv contact.png (run by `hapvox validate contact`). Left:
the hand's work along the sticking loops, as a fraction of the press-in work, for both
laws (a conservative force returns to the same value after every loop); middle: the
friction cycle, F_x and F_z against the stroke's x, with the Coulomb bound +-mu F_z;
right: the 45-degree press, F_z against the depth below the face, with Hertz.
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def decorate(ax, xlabel, ylabel, title):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best")
    ax.grid(alpha=0.3)


def main(csv_path, png_path):
    cases = {}
    with open(csv_path) as f:
        for row in csv.DictReader(f):
            cases.setdefault(row["case"], []).append({k: (v if k == "case" else float(v))
                                                      for k, v in row.items()})
    fig, (left, middle, right) = plt.subplots(1, 3, figsize=(17, 5.2))

    for name, colour, label in (("energy_hertz", "tab:blue", "Hertz law (hapvox)"),
                                ("energy_paper", "tab:red", "the seed's law (F along -u)")):
        press, loop_rows = cases.get(name + "_press", []), cases.get(name + "_loops", [])
        if not press or not loop_rows:
            continue
        press_in = press[-1]["work_mj"]
        loop_rows = press[-1:] + loop_rows
        travelled, s = [], 0.0
        for a, b in zip(loop_rows, loop_rows[1:]):
            s += math.hypot(b["x_mm"] - a["x_mm"], b["z_mm"] - a["z_mm"])
            travelled.append(s)
        left.plot(travelled, [100.0 * r["work_mj"] / press_in for r in loop_rows[1:]],
                  color=colour, lw=1.0, label=label)
    decorate(left, "path after the press (mm): offset 0.8 mm, then three loops of r = 0.5 mm",
             "hand's work, % of the press-in work",
             "energy on sticking loops (conservative: each loop ends where it began)")

    rows = cases.get("friction", [])
    if rows:
        z = [r["z_mm"] for r in rows]
        bottom = min(z)
        stroke = [r for r in rows if abs(r["z_mm"] - bottom) < 1e-9]
        xs = [r["x_mm"] - stroke[0]["x_mm"] for r in stroke]
        middle.plot(xs, [r["force_x_n"] for r in stroke], color="tab:blue", lw=1.0, label="F_x")
        middle.plot(xs, [r["force_z_n"] for r in stroke], color="tab:green", lw=1.0, label="F_z")
        middle.plot(xs, [0.5 * r["force_z_n"] for r in stroke], color="0.5", ls="--", lw=0.8,
                    label="±μ F_z (μ = 0.5)")
        middle.plot(xs, [-0.5 * r["force_z_n"] for r in stroke], color="0.5", ls="--", lw=0.8)
    decorate(middle, "stroke x (mm), 1.5 mm deep, ±3 mm twice", "force on the tool (N)",
             "friction cycle: stick ramps, slip on the bound, F_z unchanged")

    rows = cases.get("oblique", [])
    if rows:
        top = rows[0]["z_mm"] - 0.5
        inside = [(top - r["z_mm"], r) for r in rows if top - r["z_mm"] > 0]
        right.plot([d for d, _ in inside], [r["force_z_n"] for _, r in inside], color="tab:blue",
                   lw=1.2, label="F_z, press at 45°")
        right.plot([d for d, _ in inside], [r["hertz_n"] for _, r in inside], color="k",
                   ls="--", lw=0.9, label="Hertz 4/3 E* √R d^1.5")
        decorate(right, "depth below the face (mm)", "F_z (N)",
                 "oblique press: the normal force is Hertz's")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
