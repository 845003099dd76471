"""hapvox report DIR: pictures across a sweep (run by `hapvox report SWEEP_DIR -o OUT`).

Reads DIR/summary.h5 (hapvox sweep) and writes sweep_peak_force.png: the peak force of the
rows that are done, against the tool's diameter (a line per stiffness: the command line's
Young's modulus, or the materials file) and against the stiffness (a line per tool size).
Each row is a faint dot; a line joins the medians of the rows that share a point (other
traces, volumes, models or options). Prints the path. Needs python3-matplotlib and
python3-h5py.
"""
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def column(f, name):
    values = f[name][()]
    if values.dtype.kind == "S":
        return [v.decode() for v in values]
    return values


def stiffness_of(materials, youngs_pa):
    """A row's stiffness as a sort key: the command line's E first (by value), then each
    materials file (by path)."""
    if materials:
        return (1, 0.0, materials)
    return (0, float(youngs_pa), "")


def labels_of(stiffnesses):
    """A label per stiffness: "E 100 kPa", or a materials file's name (its whole path where
    two files share a name)."""
    names = [os.path.basename(s[2]) for s in stiffnesses if s[0] == 1]
    labels = {}
    for s in stiffnesses:
        if s[0] == 0:
            labels[s] = "E %g kPa" % (s[1] / 1e3)
        else:
            base = os.path.basename(s[2])
            labels[s] = base if names.count(base) == 1 else s[2]
    return labels


def main():
    summary, out_dir = sys.argv[1], sys.argv[2]
    with h5py.File(summary, "r") as f:
        status = column(f, "status")
        materials = column(f, "materials")
        tool_mm = column(f, "tool_diameter_mm")
        youngs_pa = column(f, "youngs_modulus_pa")
        peak_n = column(f, "peak_force_n")
    done = [i for i, s in enumerate(status) if s == "done" and np.isfinite(peak_n[i])]
    if not done:
        sys.exit("hapvox report: %s: no row of the sweep is done" % summary)
    done = [i for i in done if np.isfinite(tool_mm[i]) and
            (materials[i] or np.isfinite(youngs_pa[i]))]
    if not done:
        sys.exit("hapvox report: %s: no done row has a tool size and a stiffness" % summary)
    stiffness = {i: stiffness_of(materials[i], youngs_pa[i]) for i in done}
    order = sorted(set(stiffness.values()))
    label = labels_of(order)
    tools = sorted(set(tool_mm[i] for i in done))

    fig, (by_tool, by_stiffness) = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, name in enumerate(order):
        colour = "C%d" % (k % 10)
        rows = [i for i in done if stiffness[i] == name]
        by_tool.plot([tool_mm[i] for i in rows], [peak_n[i] for i in rows], "o", color=colour,
                     alpha=0.3, ms=4)
        xs = sorted(set(tool_mm[i] for i in rows))
        medians = [np.median([peak_n[i] for i in rows if tool_mm[i] == x]) for x in xs]
        by_tool.plot(xs, medians, "-o", color=colour, label=label[name])
    by_tool.set_xlabel("tool diameter (mm)")
    by_tool.set_ylabel("peak force (N)")
    by_tool.set_title("peak force against tool size")
    by_tool.legend(fontsize=8)

    position = {name: k for k, name in enumerate(order)}
    for k, tool in enumerate(tools):
        colour = "C%d" % (k % 10)
        rows = [i for i in done if tool_mm[i] == tool]
        by_stiffness.plot([position[stiffness[i]] for i in rows], [peak_n[i] for i in rows], "o",
                          color=colour, alpha=0.3, ms=4)
        xs = sorted(set(position[stiffness[i]] for i in rows))
        medians = [np.median([peak_n[i] for i in rows if position[stiffness[i]] == x])
                   for x in xs]
        by_stiffness.plot(xs, medians, "-o", color=colour, label="tool %g mm" % tool)
    by_stiffness.set_xticks(range(len(order)))
    by_stiffness.set_xticklabels([label[s] for s in order], rotation=15, fontsize=8)
    by_stiffness.set_xlabel("stiffness (Young's modulus, or materials file)")
    by_stiffness.set_ylabel("peak force (N)")
    by_stiffness.set_title("peak force against stiffness")
    by_stiffness.legend(fontsize=8)
    fig.suptitle("%s: %d of %d rows done" % (os.path.dirname(os.path.abspath(summary)),
                                              len(done), len(status)), fontsize=9)
    fig.tight_layout()
    path = os.path.join(out_dir, "sweep_peak_force.png")
    fig.savefig(path, dpi=100)  # hapvox prints the path once it is in place


if __name__ == "__main__":
    main()
