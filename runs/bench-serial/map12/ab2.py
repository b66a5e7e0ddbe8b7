#!/usr/bin/env python3
"""ab2.py BIN LABEL DIM N: like ab_measure.py, plus tree bytes and peak RSS minus tree bytes (the part not the cluster's)."""
import json, os, subprocess, sys, tempfile
b, label, dim, n = sys.argv[1:5]
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    p = subprocess.Popen(["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", "1", "--no-output", "-q", "--stats-json", sj])
    _, st, ru = os.wait4(p.pid, 0)
    s = json.load(open(sj))
print(f"{label},{dim},{n},{ru.ru_utime:.2f},{s['peak_rss_bytes']},{s['tree_bytes']},{s['peak_rss_bytes']-s['tree_bytes']},"
      f"{s['jumps']/s['particles']:.3f},{1e9*ru.ru_utime/s['jumps']:.1f},{s['rg_diam']:.6f}", flush=True)
