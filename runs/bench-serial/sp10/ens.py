#!/usr/bin/env python3
"""ens.py OUT.csv DIM N SEED0 SEED1 LABEL=BIN [LABEL=BIN ...]: for each seed in
turn, one run of each binary (interleaved, nice 10, one thread, --no-output);
appends label, seed, user s (wait4), jumps/particle, returns/particle, R_g
(diameters), fitted D_f to OUT.csv."""
import csv, json, os, subprocess, sys, tempfile
out, dim, n, s0, s1 = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
bins = [a.split("=", 1) for a in sys.argv[6:]]
new = not os.path.exists(out)
with open(out, "a", newline="") as f:
    w = csv.writer(f)
    if new:
        w.writerow(["label", "dim", "n", "seed", "user_s", "jumps_per_p", "returns_per_p", "rg_diam", "df"])
    for seed in range(s0, s1 + 1):
        for label, b in bins:
            with tempfile.TemporaryDirectory() as tmp:
                sj = os.path.join(tmp, "s.json")
                p = subprocess.Popen(["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed",
                                      str(seed), "--no-output", "-q", "--stats-json", sj])
                _, st, ru = os.wait4(p.pid, 0)
                s = json.load(open(sj))
            w.writerow([label, dim, n, seed, f"{ru.ru_utime:.3f}", f"{s['jumps'] / s['particles']:.4f}",
                        f"{s['returns'] / s['particles']:.4f}", f"{s['rg_diam']:.6f}",
                        f"{s['fit']['df']:.6f}"])
            f.flush()
