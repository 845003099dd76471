"""hapvox report: pictures of one session (run by `hapvox report SESSION.h5 -o DIR`).

Writes force.png (force over time, contact shaded), lateness.png (histogram of tick start
lateness, realtime sessions), relax.png (queue depth and relaxation work over time,
plastic sessions). Needs python3-matplotlib and python3-h5py.
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def attr(f, name, default=None):
    value = f.attrs.get(name, default)
    if isinstance(value, bytes):
        value = value.decode()
    return value


def shade_contact(ax, t, contact):
    if contact is None or not contact.any():
        return
    edges = np.flatnonzero(np.diff(np.concatenate([[0], contact.astype(int), [0]])))
    for start, end in zip(edges[::2], edges[1::2]):
        ax.axvspan(t[start], t[min(end, len(t) - 1)], color="0.92", lw=0)


def force_plot(f, out_dir, title):
    t = f["time_s"][:]
    force = f["force_n"][:]
    contact = f["contact"][:] if "contact" in f else None
    fig, ax = plt.subplots(figsize=(9, 4.5))
    shade_contact(ax, t, contact)
    for axis, name in enumerate("xyz"):
        ax.plot(t, force[:, axis], lw=1.0, label=f"F{name}")
    ax.plot(t, np.linalg.norm(force, axis=1), lw=1.6, color="k", label="|F|")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force sent (N)")
    ax.set_title(f"{title}: force over time (grey: in contact)")
    ax.legend(loc="upper right", ncol=4, fontsize=8)
    ax.grid(alpha=0.3)
    path = f"{out_dir}/force.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def lateness_plot(f, out_dir, title):
    lateness_us = 1e-3 * f["timing/lateness_ns"][:]
    rate_hz = float(attr(f, "loop_rate_hz", 1000.0))
    period_us = 1e6 / rate_hz
    fig, (ax, ax_t) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    upper = max(lateness_us.max(), 1.0)
    bins = np.logspace(np.log10(0.05), np.log10(upper * 1.5), 60)
    ax.hist(np.maximum(lateness_us, 0.05), bins=bins, color="tab:blue")
    ax.set_xscale("log")
    ax.set_yscale("log")
    for q, style in ((50, ":"), (99, "--"), (99.9, "-.")):
        v = np.percentile(lateness_us, q)
        ax.axvline(max(v, 0.05), color="k", ls=style, lw=1, label=f"p{q:g} {v:.1f} us")
    ax.axvline(period_us, color="tab:red", lw=1.2, label=f"one period {period_us:.0f} us")
    ax.set_xlabel("tick start lateness (us, values below 0.05 shown at 0.05)")
    ax.set_ylabel("ticks")
    ax.set_title(f"{title}: lateness of {len(lateness_us)} ticks")
    ax.legend(fontsize=8)
    t = f["time_s"][:]
    ax_t.plot(t - t[0], lateness_us, lw=0.6)
    watchdog = f["timing/watchdog"][:] if "timing/watchdog" in f else None
    if watchdog is not None and watchdog.any():
        hit = watchdog.astype(bool)
        ax_t.plot((t - t[0])[hit], lateness_us[hit], "rx", label="watchdog trip (force ramped down)")
        ax_t.legend(fontsize=8)
    ax_t.set_yscale("symlog", linthresh=1.0)
    ax_t.set_xlabel("time (s)")
    ax_t.set_ylabel("lateness (us)")
    ax_t.set_title("over time")
    ax_t.grid(alpha=0.3)
    path = f"{out_dir}/lateness.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def relax_plot(f, out_dir, title):
    t = f["time_s"][:]
    queue = f["relax/queue_depth"][:]
    deleted = f["relax/deleted_voxels"][:]
    relaxed = f["relax/relaxed_voxels"][:]
    events = f["plastic/event"][:]
    fig, (ax_q, ax_w) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    ax_q.plot(t, queue, lw=1.0, color="tab:purple")
    ax_q.set_ylabel("queue depth (changes)")
    ax_q.set_title(f"{title}: hand-off queue and relaxation work "
                   f"({int(events.sum())} plastic events)")
    ax_q.grid(alpha=0.3)
    window = max(1, int(float(attr(f, "loop_rate_hz", 1000.0)) / 100))  # 10 ms bins
    kernel = np.ones(window)
    ax_w.plot(t, np.convolve(deleted, kernel, "same") * (1000.0 / window), lw=1.0,
              label="deleted voxels / s")
    ax_w.plot(t, np.convolve(relaxed, kernel, "same") * (1000.0 / window), lw=1.0,
              label="relaxed voxels / s")
    ax_w.set_xlabel("time (s)")
    ax_w.set_ylabel("voxels per second (10 ms bins)")
    ax_w.legend(fontsize=8)
    ax_w.grid(alpha=0.3)
    path = f"{out_dir}/relax.png"
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main():
    session, out_dir = sys.argv[1], sys.argv[2]
    with h5py.File(session, "r") as f:
        title = session.rsplit("/", 1)[-1]
        written = [force_plot(f, out_dir, title)]
        if attr(f, "clock") == "realtime" and "timing/lateness_ns" in f:
            written.append(lateness_plot(f, out_dir, title))
        if int(attr(f, "plastic", 0)) == 1:
            written.append(relax_plot(f, out_dir, title))
    # hapvox prints each picture's path once it is in place.


if __name__ == "__main__":
    main()
