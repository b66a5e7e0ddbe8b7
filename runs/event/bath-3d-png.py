#!/usr/bin/env python3
"""bath-3d-png.py - the picture of runs/event/bath-3d.sh: 3D clusters of the
same mass side by side, each projected along z around its seed at one
scale (1.1 x the largest farthest particle), stuck spheres drawn as discs
of radius 0.5, far ones first (painter's order) and shaded darker with
depth, coloured by arrival (viridis, dark first); free spheres are not
drawn (the bath would hide the cluster). Panels: the event cluster in a
bath and its control (cluster.h5), pdla's DLA and BPCA (csv from
bath-3d.sh, seed at the origin).
Usage: bath-3d-png.py BATH.h5 CONTROL.h5 DLA.csv BPCA.csv OUT.png
(h5py, matplotlib; the PNG is then cut to 64 colours by Pillow)."""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection  # noqa: E402
from PIL import Image  # noqa: E402


def load_h5(path):
    with h5py.File(path, "r") as f:
        L = float(f["results"].attrs["box_side"])
        cp = f["cluster/positions"][...][:, :3] - L / 2
        lam = float(f["results"].attrs["mean_free_path_over_diameter"])
    return cp, f"lambda {lam:.3g}"


def load_csv(path):
    return np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1, 2)), ""


def main():
    paths, out = sys.argv[1:5], sys.argv[5]
    sets = [load_h5(paths[0]), load_h5(paths[1]), load_csv(paths[2]), load_csv(paths[3])]
    names = ["in a bath", "no bath (control)", "pdla DLA", "BPCA"]
    half = 1.1 * max(np.max(np.linalg.norm(p, axis=1)) for p, _ in sets)
    fig, axes = plt.subplots(1, 4, figsize=(9.6, 2.8), dpi=100)
    for ax, (p, note), name in zip(axes, sets, names):
        n = len(p)
        col = plt.cm.viridis(np.linspace(0, 1, n))
        shade = 0.45 + 0.55 * (p[:, 2] + half) / (2 * half)  # nearer (larger z): brighter
        col[:, :3] *= np.clip(shade, 0.3, 1)[:, None]
        order = np.argsort(p[:, 2])  # far first
        ax.add_collection(EllipseCollection(np.ones(n), np.ones(n), np.zeros(n), units="xy",
                                           offsets=p[order, :2], offset_transform=ax.transData,
                                           facecolors=col[order], edgecolors="none"))
        ax.set_xlim(-half, half)
        ax.set_ylim(-half, half)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"{n} {name}" + (f", {note}" if note else ""), fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    Image.open(out).convert("RGB").quantize(64).save(out, optimize=True)


if __name__ == "__main__":
    main()
