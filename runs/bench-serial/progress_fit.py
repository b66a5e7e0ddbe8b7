#!/usr/bin/env python3
"""progress_fit.py OUT.csv N0 T0 [N0 T0 ...]: the time exponent a in
T ~ N^a from a progress_cpu.py record (particles, user CPU s, VmHWM KiB),
plus optional separate short runs (N0, user s), by least squares on
log T over log N at one point per half decade (1e5, 3.16e5, 1e6, ...,
interpolated between the record's rows in log-log); prints the points, the fit, and the local
exponent between successive decades."""
import math, sys

rows = []
with open(sys.argv[1]) as f:
    next(f)
    for line in f:
        n, t, _ = line.strip().split(",")
        if float(t) > 0:
            rows.append((float(n), float(t)))
extra = [(float(sys.argv[i]), float(sys.argv[i + 1])) for i in range(2, len(sys.argv), 2)]
nmax = max(n for n, _ in rows)
pl = list(extra)
for k in range(10, 41):  # 1e5, 3.16e5, 1e6, ... in half decades
    want = 10 ** (k / 2)
    if want > nmax * 1.001:
        break
    # log-log interpolation between the two rows around it
    lo = [r for r in rows if r[0] <= want]
    hi = [r for r in rows if r[0] >= want]
    if not lo or not hi or any(abs(math.log(n / want)) < 0.05 for n, _ in extra):
        continue
    (n0, t0), (n1, t1) = lo[-1], hi[0]
    t = t0 if n1 == n0 else math.exp(math.log(t0) + math.log(t1 / t0) * math.log(want / n0) / math.log(n1 / n0))
    pl.append((want, t))
pl.sort()
for n, t in pl:
    print(f"N {n:.4g}  user s {t:.2f}  us/particle {1e6 * t / n:.2f}")
x = [math.log(n) for n, _ in pl]
y = [math.log(t) for _, t in pl]
mx, my = sum(x) / len(x), sum(y) / len(y)
a = sum((xi - mx) * (yi - my) for xi, yi in zip(x, y)) / sum((xi - mx) ** 2 for xi in x)
print(f"fit over N {pl[0][0]:.3g}..{pl[-1][0]:.3g} ({len(pl)} points): a = {a:.3f}")
dec = [p for p in pl if abs(math.log10(p[0]) - round(math.log10(p[0]))) < 0.01]
for (n0, t0), (n1, t1) in zip(dec, dec[1:]):
    print(f"local a {n0:.3g}..{n1:.3g}: {math.log(t1 / t0) / math.log(n1 / n0):.3f}")
