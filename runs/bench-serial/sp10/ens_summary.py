#!/usr/bin/env python3
"""ens_summary.py CSV [CSV ...]: per label (and N), mean and standard error of
R_g, D_f, jumps/p, returns/p and user s; for two labels, the difference of the
means with its standard error (Welch) and z; for seeds run by both labels,
the mean paired user-s ratio."""
import csv, math, sys, collections
rows = [r for f in sys.argv[1:] for r in csv.DictReader(open(f))]
by = collections.defaultdict(list)
for r in rows:
    by[(r["n"], r["label"])].append(r)
def ms(v):
    m = sum(v) / len(v)
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else float("nan")
    return m, sd / math.sqrt(len(v)), sd
keys = ["rg_diam", "df", "jumps_per_p", "returns_per_p", "user_s"]
for n in sorted({k[0] for k in by}, key=float):
    labels = sorted(l for (nn, l) in by if nn == n)
    for l in labels:
        rs = by[(n, l)]
        print(f"N {n} {l}: {len(rs)} seeds " + ", ".join(
            f"{k} {ms([float(r[k]) for r in rs])[0]:.4f} +/- {ms([float(r[k]) for r in rs])[1]:.4f}" for k in keys))
    if len(labels) == 2:
        a, b = by[(n, labels[0])], by[(n, labels[1])]
        for k in keys:
            ma, sa, _ = ms([float(r[k]) for r in a]); mb, sb, _ = ms([float(r[k]) for r in b])
            se = math.hypot(sa, sb)
            print(f"  {labels[1]} - {labels[0]} {k}: {mb - ma:+.4f} +/- {se:.4f} ({100 * (mb - ma) / ma:+.3f}% +/- {100 * se / ma:.3f}%), z = {(mb - ma) / se if se > 0 else float('nan'):+.2f}")
        # pairs: the k-th run of a seed by one label with the k-th by the other
        ua, ub = collections.defaultdict(list), collections.defaultdict(list)
        for r in a: ua[r["seed"]].append(float(r["user_s"]))
        for r in b: ub[r["seed"]].append(float(r["user_s"]))
        pairs = [(x, y) for s in ua if s in ub for x, y in zip(ua[s], ub[s]) if x > 0 and y > 0]
        if pairs:
            rat = [math.log(y / x) for x, y in pairs]
            m, se, _ = ms(rat)
            print(f"  paired user s, {len(pairs)} pairs: {labels[1]}/{labels[0]} = {math.exp(m):.4f} (log se {se:.4f}); sums {sum(x for x, _ in pairs):.2f} vs {sum(y for _, y in pairs):.2f}")
