"""Puts frames side by side, each under its name: Nakao et al.'s Fig. 5 as pictures.

Usage: fig5_panels.py OUT.png NAME=FRAME.png... [--difference NAME_A NAME_B]

With --difference, a last panel shows |A - B| (RGB, brightened 4x): where two frames differ.
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(out, panels, difference):
    images = {}
    for panel in panels:
        name, path = panel.split("=", 1)
        images[name] = mpimg.imread(path)[..., :3]
    count = len(images) + (1 if difference else 0)
    fig, axes = plt.subplots(1, count, figsize=(3.2 * count, 3.5))
    for ax, (name, image) in zip(axes, images.items()):
        ax.imshow(image)
        ax.set_title(name)
        ax.axis("off")
    if difference:
        a, b = difference
        axes[-1].imshow(np.clip(4.0 * np.abs(images[a] - images[b]), 0.0, 1.0))
        axes[-1].set_title(f"|{a} - {b}| x4")
        axes[-1].axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=100)


if __name__ == "__main__":
    args = sys.argv[1:]
    pair = None
    if "--difference" in args:
        i = args.index("--difference")
        pair = args[i + 1 : i + 3]
        args = args[:i] + args[i + 3 :]
    if len(args) < 2:
        sys.exit(__doc__)
    main(args[0], args[1:], pair)
