#!/usr/bin/env python3
"""bath-png.py - the picture of runs/event/bath.sh: two event-model 2D
cluster.h5 files side by side (the sticky kind in a bath, and the control
without it), the central square around the seed at one scale (1.15 x the
first cluster's farthest particle), every particle a disc of its radius:
stuck ones coloured by arrival (viridis, dark first), free sticky ones red,
bath ones light grey. Usage: bath-png.py BATH.h5 CONTROL.h5 OUT.png
(h5py, matplotlib; the PNG is then cut to 64 colours by Pillow)."""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402
from PIL import Image  # noqa: E402


def load(path):
    with h5py.File(path, "r") as f:
        L = float(f["results"].attrs["box_side"])
        cp = f["cluster/positions"][...]
        cr = f["cluster/radii"][...] if "cluster/radii" in f else np.full(len(cp), 0.5)
        fp = f["free/positions"][...]
        fr = f["free/radii"][...]
        fs = f["free/species"][...]
        sticky = f["species/sticky"][...] if "sticky" in f["species"] else np.ones(8, np.uint8)
        lam = float(f["results"].attrs["mean_free_path_over_diameter"])
    return L, cp, cr, fp, fr, sticky[fs] != 0, lam


def discs(ax, xy, r, colors):
    if len(xy):
        ax.add_collection(EllipseCollection(2 * r, 2 * r, np.zeros(len(r)), units="xy", offsets=xy,
                                           offset_transform=ax.transData, facecolors=colors,
                                           edgecolors="none"))


def main():
    a, b, out = sys.argv[1], sys.argv[2], sys.argv[3]
    La, cpa = load(a)[:2]
    half = 1.15 * np.max(np.hypot(cpa[:, 0] - La / 2, cpa[:, 1] - La / 2))
    fig, axes = plt.subplots(1, 2, figsize=(7.2, 3.75), dpi=100)
    for ax, path, title in zip(axes, (a, b), ("in a bath", "no bath (control)")):
        L, cp, cr, fp, fr, fsticky, lam = load(path)
        c = L / 2
        keep = (np.abs(fp[:, 0] - c) < half + 1) & (np.abs(fp[:, 1] - c) < half + 1)
        bath = keep & ~fsticky
        free = keep & fsticky
        discs(ax, fp[bath], fr[bath], "#d9d9d9")
        discs(ax, fp[free], fr[free], "#d62728")
        discs(ax, cp, cr, plt.cm.viridis(np.linspace(0, 1, len(cp))))
        ax.set_xlim(c - half, c + half)
        ax.set_ylim(c - half, c + half)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"{len(cp)} stuck {title}, lambda {lam:.3g}", fontsize=9)
    fig.tight_layout()
    fig.savefig(out)
    Image.open(out).convert("RGB").quantize(64).save(out, optimize=True)


if __name__ == "__main__":
    main()
