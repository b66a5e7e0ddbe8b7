#!/usr/bin/env python3
"""cg_groups.py CALLGRIND_OUT N JUMPS QUERIES (run from the repo root): the
function rows of runs/bench-serial/cg_by_file.py summed into the groups of
issue12-floor-session7.md, per particle, per jump and (the query group) per query."""
import subprocess, sys, re
out = subprocess.run(["python3", "runs/bench-serial/cg_by_file.py", sys.argv[1]], capture_output=True, text=True).stdout
fn = {}
sec = None
for line in out.splitlines():
    if line.startswith("function"): sec = "fn"; continue
    if line.startswith("file"): sec = "file"; continue
    parts = line.split()
    if sec == "fn" and len(parts) >= 3: fn[parts[0]] = int(parts[1])
N = float(sys.argv[2]); J = float(sys.argv[3]); Q = float(sys.argv[4])
g = {
 "query (block2/near2/lower_bound2)": ["search_block2", "search_near2", "search_lower_bound2"],
 "walker loop (map look-up, sampling, move)": ["walker_run"],
 "snapping": ["walker_snap_to_contact", "search_nearest_point_cached", "__floor_sse41"],
 "insertion (tree, map, sums)": ["distmap_add", "transform", "tree_make_path", "tree_append", "tree_insert", "engine_add_particle", "engine_gyration_add", "chunk_new", "pdla_engine_grow"],
 "returns and launches": ["sample_return_angle2", "sample_rotate_to2", "__tan_fma", "__atan_fma", "__sincos_fma", "hypot@@GLIBC_2.35", "sample_cone_point3", "sample_return3", "lrint"],
}
tot = 0
for k, names in g.items():
    v = sum(fn.get(n, 0) for n in names); tot += v
    print(f"{k:45s} {v/1e6:9.1f}M  {v/N:8.0f} Ir/particle  {v/J:7.1f} Ir/jump" + (f"  {v/Q:7.0f} Ir/query" if k.startswith("query") else ""))
print("sum", tot/1e6)
