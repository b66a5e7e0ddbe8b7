#!/usr/bin/env python3
"""pairs.py ARMS.tsv... - paired R_g differences between the arms that
drive16b.py/drive16c.py write (arm, seed, rg, particles, jumps, relaunches,
lag_mean, lag0 share, parallel s): for each case, workers vs serial, workers
vs reference, reference vs serial, as mean of R_g(a)/R_g(b) - 1 +/- one
standard error over the seeds both arms grew."""
import sys, math, collections
rows = collections.defaultdict(dict)  # arm -> seed -> row
for fn in sys.argv[1:]:
    for line in open(fn):
        f = line.rstrip("\n").split("\t")
        if f[2] == "failed":
            rows[f[0]][int(f[1])] = None; continue
        rows[f[0]][int(f[1])] = dict(rg=float(f[2]), lag=f[6], lag0=f[7], par=f[8])
def pair(a, b):
    A, B = rows[a], rows[b]
    s = [k for k in A if k in B and A[k] and B[k]]
    d = [A[k]["rg"] / B[k]["rg"] - 1 for k in s]
    n = len(d); m = sum(d) / n; sd = math.sqrt(sum((x - m) ** 2 for x in d) / (n - 1))
    return n, m, sd / math.sqrt(n)
def fails(a): return sum(1 for v in rows[a].values() if v is None)
tags = sorted({k.rsplit("-", 1)[0] for k in rows})
for t in tags:
    arms = [k for k in rows if k.startswith(t + "-")]
    th = [k for k in arms if k.rsplit("-",1)[1].startswith("t")][0]
    ref = [k for k in arms if "ref" in k]
    for a, b in [(th, t + "-serial")] + ([(th, ref[0]), (ref[0], t + "-serial")] if ref else []):
        n, m, se = pair(a, b)
        print(f"{a:18s} vs {b:18s} pairs {n:5d}  {100*m:+.3f}% +/- {100*se:.3f}%  ({m/se:+.1f} se)")
    for a in arms:
        L = [float(v["lag"]) for v in rows[a].values() if v and v["lag"] != "-"]
        L0 = [float(v["lag0"]) for v in rows[a].values() if v and v["lag0"] != "-"]
        print(f"   {a:18s} runs {len(rows[a])} failed {fails(a)} lag_mean {sum(L)/max(1,len(L)):.2f} lag0 {100*sum(L0)/max(1,len(L0)):.2f}%")
