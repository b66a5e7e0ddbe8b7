#!/usr/bin/env python3
"""ab_measure.py BIN LABEL DIM N [SEED]: one run of pdla under nice (seed 1 unless given); prints
label, (seed when given,) dim, N, user s (wait4), peak RSS KiB, jumps/particle, user ns/jump, R_g."""
import json, os, subprocess, sys, tempfile
b, label, dim, n = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
seed = sys.argv[5] if len(sys.argv) > 5 else None
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    cmd = ["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", seed or "1", "--no-output", "-q", "--stats-json", sj]
    p = subprocess.Popen(cmd)
    _, st, ru = os.wait4(p.pid, 0)
    s = json.load(open(sj))
user = ru.ru_utime
tag = f"{label},{seed}" if seed else label
print(f"{tag},{dim},{n},{user:.2f},{s['peak_rss_bytes']/1024:.0f},{s['jumps']/s['particles']:.3f},{1e9*user/s['jumps']:.1f},{s['rg_diam']:.6f}", flush=True)
