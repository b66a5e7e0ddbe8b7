#!/usr/bin/python3
"""pool.py FILE...: pool the chunks test_physics pair printed (their "sums S S2"
and pair counts) into one mean of R_g(A)/R_g(B) - 1 with its standard error,
per comparison (the text between "serial:" and "= ")."""
import math
import re
import sys

LINE = re.compile(r"(\d+)D, (\d+) pairs \(seeds (\d+)\.\.(\d+)\) of (\d+) after (\d+) serial: "
                  r"(.*?) = .*sums (\S+) (\S+)\)")
pools = {}
for path in sys.argv[1:]:
    for line in open(path):
        m = LINE.match(line)  # lines kept as "# ..." comments are not pooled
        if not m:
            continue
        key = "%sD %s->%s %s" % (m.group(1), m.group(6), m.group(5), m.group(7))
        p = pools.setdefault(key, [0, 0.0, 0.0, []])
        p[0] += int(m.group(2))
        p[1] += float(m.group(8))
        p[2] += float(m.group(9))
        p[3].append((int(m.group(3)), int(m.group(4))))
for key, (n, s, s2, seeds) in pools.items():
    mean = s / n
    sd = math.sqrt(max(s2 / n - mean * mean, 0) * n / (n - 1))
    se = sd / math.sqrt(n)
    seeds.sort()
    ranges = ", ".join("%d..%d" % r for r in seeds)
    print("%s: %d pairs in %d chunks (seeds %s), mean %+.4f%% +- %.4f%% (z %+.2f, pair sd %.3f%%)"
          % (key, n, len(seeds), ranges, 100 * mean, 100 * se, mean / se, 100 * sd))
