"""Plots Nakao et al.'s Fig. 5 from hapvox FEM sessions (scripts/fig5.sh runs them).

Usage: fig5_plot.py OUT.png TITLE PAPER.h5 UNIFORM.h5 AXIS VALUE CENTRES...

Each session's displacement at its last FEM step is cut by the plane AXIS = VALUE (mm): the
mesh's linear tets cross the plane in points where the displacement is interpolated exactly
along the cut edges; those points are triangulated and |u| is drawn in colour with the
in-plane displacement as arrows on a regular grid, for the paper's moduli, the uniform ones, and their
difference. CENTRES are "x,y,z,r" spheres (mm) drawn as outlines where the plane cuts them.
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.tri as mtri  # noqa: E402
import numpy as np  # noqa: E402

EDGES = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def load(path):
    with h5py.File(path, "r") as f:
        rest = f["mesh/rest_mm"][...]
        tets = f["mesh/tets"][...]
        u = f["fem/displacement_mm"][-1]
    return rest, tets, u


def cut(rest, tets, u, axis, value):
    """Points (mm) where tet edges cross the plane, with the displacement there."""
    points, values = [], []
    for a, b in EDGES:
        pa, pb = rest[tets[:, a]], rest[tets[:, b]]
        ca, cb = pa[:, axis] - value, pb[:, axis] - value
        crossing = (ca * cb <= 0) & (ca != cb)
        t = (ca[crossing] / (ca[crossing] - cb[crossing]))[:, None]
        points.append(pa[crossing] + t * (pb[crossing] - pa[crossing]))
        ua, ub = u[tets[crossing, a]], u[tets[crossing, b]]
        values.append(ua + t * (ub - ua))
    points, values = np.concatenate(points), np.concatenate(values)
    _, unique = np.unique(np.round(points, 6), axis=0, return_index=True)
    return points[unique], values[unique]


def main():
    out, title, paper_path, uniform_path, axis_name, value = sys.argv[1:7]
    spheres = [tuple(map(float, s.split(","))) for s in sys.argv[7:]]
    axis, value = "xyz".index(axis_name), float(value)
    plane = [i for i in range(3) if i != axis]
    paper, uniform = load(paper_path), load(uniform_path)
    p_points, p_u = cut(*paper, axis, value)
    u_points, u_u = cut(*uniform, axis, value)
    if not np.array_equal(p_points, u_points):
        sys.exit("fig5_plot: the two sessions' meshes differ")
    tri = mtri.Triangulation(p_points[:, plane[0]], p_points[:, plane[1]])
    fields = [("paper's moduli", p_u), ("uniform 10 MPa", u_u), ("difference", p_u - u_u)]
    top = max(np.linalg.norm(p_u, axis=1).max(), np.linalg.norm(u_u, axis=1).max())
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.8), constrained_layout=True)
    # Arrows on a regular 20 x 20 grid, interpolated linearly on the cut's triangles, the
    # longest one twice a grid cell.
    lo = p_points[:, plane].min(axis=0)
    hi = p_points[:, plane].max(axis=0)
    gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], 22)[1:-1], np.linspace(lo[1], hi[1], 22)[1:-1])
    cell = (hi[0] - lo[0]) / 21
    for ax, (name, field) in zip(axes, fields):
        magnitude = np.linalg.norm(field, axis=1)
        levels = np.linspace(0, top if name != "difference" else magnitude.max(), 21)
        shade = ax.tricontourf(tri, magnitude, levels=levels, cmap="viridis")
        fig.colorbar(shade, ax=ax, label="|u| (mm)")
        ax_u = mtri.LinearTriInterpolator(tri, field[:, plane[0]])(gx, gy)
        ax_v = mtri.LinearTriInterpolator(tri, field[:, plane[1]])(gx, gy)
        scale = max(np.sqrt(ax_u ** 2 + ax_v ** 2).max(), 1e-12) / (2 * cell)
        ax.quiver(gx, gy, ax_u, ax_v, color="white", angles="xy", scale_units="xy",
                  scale=scale, width=0.004)
        for x, y, z, r in spheres:
            centre = (x, y, z)
            d = abs(centre[axis] - value)
            if d < r:
                ax.add_patch(plt.Circle((centre[plane[0]], centre[plane[1]]),
                                        np.sqrt(r * r - d * d), fill=False, color="red", lw=1))
        ax.set_aspect("equal")
        ax.set_title(f"{name}\nin-plane arrows: longest {2 * cell * scale:.3g} mm", fontsize=10)
        ax.set_xlabel("xyz"[plane[0]] + " (mm)")
        ax.set_ylabel("xyz"[plane[1]] + " (mm)")
    fig.suptitle(f"{title}: displacement at the last FEM step on the plane "
                 f"{axis_name} = {value:g} mm")
    fig.savefig(out, dpi=90)


if __name__ == "__main__":
    main()
