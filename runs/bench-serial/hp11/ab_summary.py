#!/usr/bin/env python3
"""ab_summary.py FILE...: paired summary of ab.sh output (lines
'A|B dim n seed user sys maxrss_kib jumps rg_diam peak_rss_bytes', A and B
alternating). Prints per case: the mean user s of A and B, the mean of the
paired ratios B/A - 1 with its standard error, and whether the clusters
(jumps, R_g) are the same in every run."""
import statistics as st
import sys

for path in sys.argv[1:]:
    rows = [l.split() for l in open(path) if l.strip()]
    a = [r for r in rows if r[0] == "A"]
    b = [r for r in rows if r[0] == "B"]
    n = min(len(a), len(b))
    ua = [float(r[4]) for r in a[:n]]
    ub = [float(r[4]) for r in b[:n]]
    d = [y / x - 1 for x, y in zip(ua, ub)]
    se = st.stdev(d) / n ** 0.5 if n > 1 else float("nan")
    same = len({(r[7], r[8]) for r in rows}) == 1
    rss_a = st.mean(int(r[9]) for r in a[:n]) / 2**20
    rss_b = st.mean(int(r[9]) for r in b[:n]) / 2**20
    print(f"{path}: dim {rows[0][1]} N {rows[0][2]}, {n} pairs: A {st.mean(ua):.2f} s, "
          f"B {st.mean(ub):.2f} s, B/A-1 {100*st.mean(d):+.2f}% +/- {100*se:.2f}% (se); "
          f"peak RSS A {rss_a:.2f} MiB, B {rss_b:.2f} MiB; clusters {'identical' if same else 'DIFFER'}")
