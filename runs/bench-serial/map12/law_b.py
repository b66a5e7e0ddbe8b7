#!/usr/bin/env python3
"""law_b.py A.csv C DIM N OUT.csv: run binary C on the seeds of a law.py CSV
(its A columns: main) and compare C's R_g with A's the same way law.py does."""
import csv, json, math, os, subprocess, sys, tempfile
src, c, dim, n, out = sys.argv[1:6]
rows = list(csv.DictReader(open(src)))
res = []
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    for r in rows:
        subprocess.run(["nice", "-n", "10", c, "--dim", dim, "--target", n, "--seed", r["seed"], "--no-output", "-q",
                        "--stats-json", sj], check=True)
        s = json.load(open(sj))
        res.append((int(r["seed"]), float(r["rg_a"]), s["rg_diam"], s["jumps"] / s["particles"]))
with open(out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["seed", "rg_a", "rg_c", "jumps_c"])
    w.writerows(res)
def mean_se(x):
    m = sum(x) / len(x)
    return m, math.sqrt(sum((y - m) ** 2 for y in x) / (len(x) - 1) / len(x))
ma, sa = mean_se([r[1] for r in res])
mc, sc = mean_se([r[2] for r in res])
d = (mc - ma) / ma
se = math.sqrt((sa / ma) ** 2 + (sc / ma) ** 2)
print(f"R_g: A {ma:.4f} +/- {sa:.4f}, C {mc:.4f} +/- {sc:.4f}, C/A - 1 = {100*d:+.3f}% +/- {100*se:.3f}% ({d/se:+.2f} SE), {len(res)} seeds")
