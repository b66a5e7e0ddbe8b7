#!/usr/bin/env python3
"""ab_measure.py BIN LABEL DIM N: one run of pdla under nice; prints user s (wait4), peak RSS, jumps/particle, user ns/jump."""
import json, os, subprocess, sys, tempfile
b, label, dim, n = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    cmd = ["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", "1", "--no-output", "-q", "--stats-json", sj]
    p = subprocess.Popen(cmd)
    _, st, ru = os.wait4(p.pid, 0)
    s = json.load(open(sj))
user = ru.ru_utime
print(f"{label},{dim},{n},{user:.2f},{s['peak_rss_bytes']/1024:.0f},{s['jumps']/s['particles']:.3f},{1e9*user/s['jumps']:.1f},{s['rg_diam']:.6f}", flush=True)
