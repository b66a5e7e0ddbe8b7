#!/usr/bin/env python3
"""cg_by_file.py CALLGRIND_OUT [JUMPS]: self Ir per source file (inlined code
counted in the file it comes from: fi=/fe= records), and per function, from a
callgrind output (--dump-instr=no). With JUMPS, also Ir per jump."""
import re, sys, collections
path = sys.argv[1]
jumps = float(sys.argv[2]) if len(sys.argv) > 2 else None
names = {"fl": {}, "fi": {}, "fe": {}, "fn": {}}
def name(kind, rest):
    m = re.match(r"\((\d+)\)(?: (.*))?", rest)
    if not m:
        return rest
    tab = names["fl" if kind in ("fl", "fi", "fe", "cfi", "cfl") else "fn"]
    if m.group(2) is not None:
        tab[m.group(1)] = m.group(2)
    return tab.get(m.group(1), "?")
by_file = collections.Counter()
by_fn = collections.Counter()
cur_fl = cur_file = cur_fn = "?"
skip = False
total = 0
for line in open(path):
    line = line.rstrip("\n")
    if not line:
        continue
    c = line[0]
    if c.isdigit() or c in "+-*":
        if skip:
            skip = False
            continue
        parts = line.split()
        if len(parts) < 2:
            continue
        ir = int(parts[1])
        by_file[cur_file] += ir
        by_fn[cur_fn] += ir
        total += ir
        continue
    key, _, rest = line.partition("=")
    if key == "fl":
        cur_fl = cur_file = name("fl", rest)
    elif key in ("fi", "fe"):
        cur_file = name(key, rest)
    elif key == "fn":
        cur_fn = name("fn", rest)
        cur_file = cur_fl
    elif key in ("cfi", "cfl"):
        name(key, rest)
    elif key == "cfn":
        name("fn", rest)
    elif key == "calls":
        skip = True
print(f"total self Ir {total}" + (f", {total / jumps:.1f} per jump" if jumps else ""))
for title, ctr in (("file", by_file), ("function", by_fn)):
    print(f"\n{title:50s} {'Ir':>14s} {'%':>6s}" + ("  Ir/jump" if jumps else ""))
    for k, v in ctr.most_common(25):
        short = k.split("/src/")[-1] if "/src/" in k else k
        print(f"{short[-50:]:50s} {v:14d} {100.0 * v / total:6.2f}" + (f" {v / jumps:8.1f}" if jumps else ""))
