#!/usr/bin/env python3
"""law.py A B DIM N SEED0 NSEEDS OUT.csv: run pdla binaries A and B (one
thread, --no-output) on seeds SEED0..SEED0+NSEEDS-1, interleaved, under
nice -n 10; write seed, R_g, jumps/particle, returns/particle per binary
and print the mean R_g difference B - A (relative, paired by seed) with its
standard error, and the same for each binary's mean. The two binaries grow
different clusters from one seed (their walks differ), so pairing removes
nothing; the SE is that of a difference of two independent means."""
import csv, json, math, os, subprocess, sys, tempfile

a, b, dim, n, s0, ns, out = sys.argv[1:8]
s0, ns = int(s0), int(ns)
rows = []
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    for seed in range(s0, s0 + ns):
        r = [seed]
        for binary in (a, b):
            subprocess.run(["nice", "-n", "10", binary, "--dim", dim, "--target", n, "--seed", str(seed),
                            "--no-output", "-q", "--stats-json", sj], check=True)
            s = json.load(open(sj))
            r += [s["rg_diam"], s["jumps"] / s["particles"], s["returns"] / s["particles"]]
        rows.append(r)
with open(out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["seed", "rg_a", "jumps_a", "returns_a", "rg_b", "jumps_b", "returns_b"])
    w.writerows(rows)

def mean_se(x):
    m = sum(x) / len(x)
    v = sum((y - m) ** 2 for y in x) / (len(x) - 1)
    return m, math.sqrt(v / len(x))

for k, name in ((1, "R_g"), (2, "jumps/particle"), (3, "returns/particle")):
    ma, sa = mean_se([r[k] for r in rows])
    mb, sb = mean_se([r[k + 3] for r in rows])
    d = (mb - ma) / ma
    se = math.sqrt((sa / ma) ** 2 + (sb / ma) ** 2)
    print(f"{name}: A {ma:.4f} +/- {sa:.4f}, B {mb:.4f} +/- {sb:.4f}, B/A - 1 = {100*d:+.3f}% +/- {100*se:.3f}% "
          f"({d/se:+.2f} SE), {len(rows)} seeds each")
