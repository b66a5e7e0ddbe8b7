#!/usr/bin/env python3
"""lawstat.py OLD NEW: paired (same seed) differences of R_g and jumps/particle, mean +- standard error."""
import statistics as st, sys
def load(f): return {int(l.split()[0]): (float(l.split()[1]), float(l.split()[2])) for l in open(f)}
o, n = load(sys.argv[1]), load(sys.argv[2])
ks = sorted(set(o) & set(n))
for i, name in ((0, 'R_g/D'), (1, 'jumps/particle')):
    d = [n[k][i] - o[k][i] for k in ks]
    mo = st.mean(o[k][i] for k in ks); mn = st.mean(n[k][i] for k in ks)
    se = st.stdev(d) / len(d) ** .5
    print(f"{name}: seeds {len(ks)}, old {mo:.4f} new {mn:.4f}, new-old {mn-mo:+.4f} +- {se:.4f} (SE), z {(mn-mo)/se:+.2f}, {100*(mn-mo)/mo:+.2f}% +- {100*se/mo:.2f}%")
