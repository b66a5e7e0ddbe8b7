#!/usr/bin/python3
"""test_dlca_xdmf.py PDLA PV_CHECK - a DLCA run's cluster.xdmf2 in the real
ParaView: pvpython (tests/formats/pv_check.py) opens it with ParaView's own
choice of reader and must see N points and N cells at the monomers' site
coordinates (checked against the k-index of /monomers/site decoded here:
x_1 = k mod L_1, x_2 = (k div L_1) mod L_2, ...), bounds within the box, and
the "cluster" array equal to /monomers/cluster (range 0..N_c-1). 2D and 3D;
in 4D no sidecar is written (ParaView shows 2D and 3D points). A missing
pvpython is a failure, not a skip.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

fails = 0
count = 0


def check(cond, msg):
    global fails, count
    count += 1
    if not cond:
        fails += 1
        print("FAIL:", msg)
    return cond


def run(args):
    # Without MALLOC_PERTURB_ (set by meson test): it makes pvpython's X and
    # GL libraries fail now and then, which says nothing about pdla.
    env = {k: v for k, v in os.environ.items() if k != "MALLOC_PERTURB_"}
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, env=env)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


def series(pdla, tmp):
    """With --snapshot-every the sidecar is a temporal collection: ParaView
    sees one time step per snapshot and the end, at their t, each with the
    snapshot's points (its sites decoded) and cluster numbers."""
    pv_series = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pv_series.py")
    for box, fill, T in (("40x30", "0.05", "15"), ("12x10x8", "0.05", "2")):
        L = [int(v) for v in box.split("x")]
        d = len(L)
        out = os.path.join(tmp, "s%d" % d)
        rc, so, se = run([pdla, "--model", "dlca", "--dim", str(d), "--box", box, "--fill", fill,
                          "--until-clusters", "3", "--snapshot-every", T, "--seed", "3", "--out", out, "-q"])
        if not check(rc == 0, "%s snapshots: pdla exit %d: %s" % (box, rc, se)):
            continue
        want = []
        with h5py.File(os.path.join(out, "cluster.h5"), "r") as f:
            groups = [f["snapshots/%d" % i] for i in range(int(f["snapshots"].attrs["count"]))]
            t_end = float(f["results"].attrs["t"])
            for g in groups + ([f["monomers"]] if t_end > float(groups[-1].attrs["t"]) else []):
                k = g["site"][:].astype(np.int64)
                xyz = np.zeros((len(k), 3))
                for a in range(d):
                    xyz[:, a] = k % L[a]
                    k //= L[a]
                want.append((float(g.attrs["t"]) if "t" in g.attrs else t_end, xyz, g["cluster"][:].tolist()))
        check(len(want) >= 3, "%s: only %d time steps" % (box, len(want)))
        rc, so, se = run(["pvpython", pv_series, os.path.abspath(os.path.join(out, "cluster.xdmf2"))])
        last = [ln for ln in so.splitlines() if ln.startswith("{")]
        if not check(rc == 0 and last, "%s series: pvpython exit %d: %s" % (box, rc, (se or so)[-500:])):
            continue
        j = json.loads(last[-1])
        check(j["reader"] == "XdmfReader", "%s series: reader %s" % (box, j["reader"]))
        check(j["times"] == [w[0] for w in want], "%s: time steps %s, want %s" % (box, j["times"], [w[0] for w in want]))
        for i, (st, w) in enumerate(zip(j["steps"], want)):
            check(st["points"] == len(w[1]) and st["xyz"] == w[1].tolist() and st["cluster"] == w[2],
                  "%s: time step %d (t %g) is not its snapshot's points and clusters" % (box, i, w[0]))


def main():
    pdla, pv_check = sys.argv[1], sys.argv[2]
    if not check(shutil.which("pvpython") is not None, "pvpython not found: apt-get install paraview"):
        return
    tmp = tempfile.mkdtemp()
    try:
        for box, fill in (("64x48", "0.05"), ("16x12x10", "0.04"), ("8x6x5x4", "0.05")):
            L = [int(v) for v in box.split("x")]
            d = len(L)
            out = os.path.join(tmp, "r%d" % d)
            rc, so, se = run([pdla, "--model", "dlca", "--dim", str(d), "--box", box, "--fill", fill,
                              "--until-clusters", "5", "--seed", "2", "--out", out, "-q"])
            if not check(rc == 0, "%s: pdla exit %d: %s" % (box, rc, se)):
                continue
            with h5py.File(os.path.join(out, "cluster.h5"), "r") as f:
                site = f["monomers/site"][:].astype(np.int64)
                cid = f["monomers/cluster"][:].astype(np.int64)
                pos = f["monomers/position"][:].astype(np.int64)
                nc = int(f["results"].attrs["n_clusters"])
            n = len(site)
            want = np.zeros((n, d), dtype=np.int64)
            k = site.copy()
            for a in range(d):
                want[:, a] = k % L[a]
                k //= L[a]
            check(pos.shape == (n, d) and (pos == want).all(), "%s: /monomers/position is not the decoded site" % box)
            side = os.path.join(out, "cluster.xdmf2")
            if d > 3:
                check(not os.path.exists(side), "%s: a sidecar in %dD" % (box, d))
                continue
            if not check(os.path.exists(side), "%s: no cluster.xdmf2" % box):
                continue
            rc, so, se = run(["pvpython", pv_check, os.path.abspath(side)])
            last = [ln for ln in so.splitlines() if ln.startswith("{")]
            if not check(rc == 0 and last, "%s: pvpython exit %d: %s" % (box, rc, (se or so)[-500:])):
                continue
            j = json.loads(last[-1])
            check(j["reader"] == "XdmfReader", "%s: reader %s" % (box, j["reader"]))
            check(j["points"] == n and j["cells"] == n, "%s: %d points %d cells, want %d" % (box, j["points"], j["cells"], n))
            p = np.zeros((n, 3))
            p[:, :d] = want
            want_b = [float(v) for a in range(3) for v in (p[:, a].min(), p[:, a].max())]
            check(j["bounds"] == want_b, "%s: bounds %s, want %s" % (box, j["bounds"], want_b))
            rows = j["rows"]
            check(j["xyz"] == p[rows].tolist(), "%s: points at rows %s differ" % (box, rows))
            c = j["arrays"].get("cluster")
            if check(c is not None, "%s: no cluster array" % box):
                check(c["range"] == [0, nc - 1] and c["at"] == cid[rows].tolist() and c["tuples"] == n,
                      "%s: cluster array %s, want 0..%d and %s" % (box, c, nc - 1, cid[rows].tolist()))
        series(pdla, tmp)
    finally:
        shutil.rmtree(tmp)


main()
print("%d checks, %d failed" % (count, fails))
sys.exit(1 if fails else 0)
