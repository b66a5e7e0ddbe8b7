#!/usr/bin/env python3
"""bath-3d-phi.py - the cluster's packing inside r (M(r) v / V(r), v the
volume of a sphere of radius 0.5) per seed, mean and sd / sqrt(seeds), for
the four sets of bath-3d.sh. Usage: bath-3d-phi.py BOX_SIDE R... (from the
repository root, after bath-3d.sh 4000 40000 0.11 2000 3 8)."""
import sys

import numpy as np

L = float(sys.argv[1])
rs = [float(a) for a in sys.argv[2:]]
o = "runs/event/out"
sets = {"bath": ([f"{o}/bath_3d_n4000_b40000_p0.11_m2000_s{s}.csv" for s in (1, 2, 3)], L / 2),
        "control": ([f"{o}/ctrl_3d_n4000_p0.01_m2000_s{s}.csv" for s in range(1, 9)], L / 2),
        "DLA": ([f"{o}/bath3_dla_2000_s{s}.csv" for s in range(1, 9)], 0.0),
        "BPCA": ([f"{o}/bath3_bpca_2000_s{s}.csv" for s in range(1, 9)], 0.0)}
for name, (files, c) in sets.items():
    phi = []
    for f in files:
        p = np.loadtxt(f, delimiter=",", skiprows=1, usecols=(0, 1, 2))
        d = np.linalg.norm(p - c, axis=1)
        phi.append([np.count_nonzero(d <= r) * (np.pi / 6) / (4 / 3 * np.pi * r ** 3) for r in rs])
    phi = np.array(phi)
    m, se = phi.mean(0), phi.std(0, ddof=1) / np.sqrt(len(files))
    print(f"#   {name:8s} ({len(files)} seeds): " +
          ", ".join(f"phi_c({r:g}) {a:.4f} +- {b:.4f}" for r, a, b in zip(rs, m, se)))
