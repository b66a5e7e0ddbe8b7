#!/usr/bin/env python3
"""cg_by_line.py CALLGRIND_OUT FILE_SUBSTR [JUMPS]: self Ir per (function,
source line) for the source files whose name contains FILE_SUBSTR (inlined
code counted where it comes from, as cg_by_file.py), from a callgrind output
written with --dump-instr=no (line numbers may be relative: +N, -N, *)."""
import re, sys, collections
path, want = sys.argv[1], sys.argv[2]
jumps = float(sys.argv[3]) if len(sys.argv) > 3 else None
names = {"fl": {}, "fn": {}}
def name(kind, rest):
    m = re.match(r"\((\d+)\)(?: (.*))?", rest)
    if not m:
        return rest
    tab = names["fl" if kind in ("fl", "fi", "fe", "cfi", "cfl") else "fn"]
    if m.group(2) is not None:
        tab[m.group(1)] = m.group(2)
    return tab.get(m.group(1), "?")
ctr = collections.Counter()
cur_fl = cur_file = cur_fn = "?"
skip = False
total = 0
line_no = 0
for line in open(path):
    line = line.rstrip("\n")
    if not line:
        continue
    c = line[0]
    if c.isdigit() or c in "+-*":
        parts = line.split()
        p0 = parts[0]
        if p0 == "*":
            pass
        elif p0[0] in "+-":
            line_no += int(p0)
        else:
            line_no = int(p0)
        if skip:
            skip = False
            continue
        if len(parts) < 2:
            continue
        ir = int(parts[1])
        total += ir
        if want in cur_file:
            ctr[(cur_fn, cur_file.split("/")[-1], line_no)] += ir
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
print(f"total self Ir {total}")
for (fn, f, ln), v in sorted(ctr.items(), key=lambda kv: -kv[1]):
    if v < total * 1e-4:
        continue
    print(f"{fn[:28]:28s} {f:12s} {ln:5d} {v:12d} {100.0 * v / total:6.2f}" + (f" {v / jumps:8.1f}" if jumps else ""))
