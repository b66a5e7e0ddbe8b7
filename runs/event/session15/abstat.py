#!/usr/bin/env python3
"""abstat.py FILE [OLD NEW] - speed-ab11.sh output: per case, the median us per
collision of two labels (default old, new), the median of the per-round
ratios new/old and each round's change in %."""
import statistics as st
import sys

f = sys.argv[1]
old, new = (sys.argv[2], sys.argv[3]) if len(sys.argv) > 3 else ("old", "new")
u = {}
for line in open(f):
    w = line.split()
    if len(w) < 8:
        continue
    u[(int(w[0]), w[1], int(w[2]), int(w[3]))] = float(w[7])
cases = sorted({(d, n) for (_, _, d, n) in u})
for d, n in cases:
    rounds = sorted({r for (r, lab, dd, nn) in u if (dd, nn) == (d, n)})
    pairs = [(u[(r, old, d, n)], u[(r, new, d, n)]) for r in rounds
             if (r, old, d, n) in u and (r, new, d, n) in u]
    if not pairs:
        continue
    q = [b / a for a, b in pairs]
    print(f"{d}D N={n:g}: {old} {st.median(a for a, _ in pairs):.3f} {new} {st.median(b for _, b in pairs):.3f} "
          f"us/coll (medians of {len(pairs)} rounds), {new}/{old} median {st.median(q):.3f}, per round "
          + " ".join(f"{100 * (x - 1):+.0f}" for x in q) + " %")
