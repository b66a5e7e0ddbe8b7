#!/usr/bin/env python3
"""cg_by_file.py CALLGRIND_OUT [JUMPS] [--lines FILE_SUBSTR]: self Ir per
source file (inlined code counted in the file it comes from: fi=/fe=
records), and per function, from a callgrind output (--dump-instr=no). With
JUMPS, also Ir per jump. With --lines, instead self Ir per (function, source
line) for the source files whose name contains FILE_SUBSTR (line numbers
may be relative in the output: +N, -N, *)."""
import re, sys, collections
args = sys.argv[1:]
want = None
if "--lines" in args:
    i = args.index("--lines")
    want = args[i + 1]
    del args[i:i + 2]
path = args[0]
jumps = float(args[1]) if len(args) > 1 else None
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
by_line = collections.Counter()
line_no = 0
cur_fl = cur_file = cur_fn = "?"
skip = False
total = 0
for line in open(path):
    line = line.rstrip("\n")
    if not line:
        continue
    c = line[0]
    if c.isdigit() or c in "+-*":
        parts = line.split()
        if parts[0][0] in "+-":
            line_no += int(parts[0])
        elif parts[0] != "*":
            line_no = int(parts[0])
        if skip:
            skip = False
            continue
        if len(parts) < 2:
            continue
        ir = int(parts[1])
        by_file[cur_file] += ir
        by_fn[cur_fn] += ir
        if want is not None and want in cur_file:
            by_line[(cur_fn, cur_file.split("/")[-1], line_no)] += ir
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
if want is not None:
    print(f"total self Ir {total}")
    for (fn, f, ln), v in sorted(by_line.items(), key=lambda kv: -kv[1]):
        if v >= total * 1e-4:
            print(f"{fn[:28]:28s} {f:12s} {ln:5d} {v:12d} {100.0 * v / total:6.2f}" + (f" {v / jumps:8.1f}" if jumps else ""))
    sys.exit(0)
print(f"total self Ir {total}" + (f", {total / jumps:.1f} per jump" if jumps else ""))
for title, ctr in (("file", by_file), ("function", by_fn)):
    print(f"\n{title:50s} {'Ir':>14s} {'%':>6s}" + ("  Ir/jump" if jumps else ""))
    for k, v in ctr.most_common(25):
        short = k.split("/src/")[-1] if "/src/" in k else k
        print(f"{short[-50:]:50s} {v:14d} {100.0 * v / total:6.2f}" + (f" {v / jumps:8.1f}" if jumps else ""))
