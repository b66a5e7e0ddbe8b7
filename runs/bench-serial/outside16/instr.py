import re, sys
root = sys.argv[1]
def sub(path, old, new, count=1):
    s = open(path).read()
    if old not in s: sys.exit(f"not found in {path}: {old!r}")
    s = s.replace(old, new, count)
    open(path, "w").write(s)
h = root + "/src/dla/distmap.h"
sub(h, '#include "tree.h"\n', '#include "tree.h"\nextern _Thread_local int src_k;\n')
sub(h, "if (vc >= 5) return coarse;", "if (vc >= 5) { src_k = 1; return coarse; }")
sub(h, "    return fine > coarse ? fine : coarse;\n}", "    src_k = fine > coarse ? 0 : 1;\n    return fine > coarse ? fine : coarse;\n}")
c = root + "/src/dla/search.c"
sub(c, "if (k->lb_unknown) return UINT64_MAX;", "if (k->lb_unknown) { src_k = 2; return UINT64_MAX; }")
s = open(c).read()
if "return leaf_bound2(row, k->lb_nz, x, y, p);" in s:
    sub(c, "if (!(r0 | r1 | r2)) return leaf_bound2(row, k->lb_nz, x, y, p);", "if (!(r0 | r1 | r2)) { src_k = 3; return leaf_bound2(row, k->lb_nz, x, y, p); }")
else:
    sub(c, "    if (!(r0 | r1 | r2)) {\n", "    if (!(r0 | r1 | r2)) {\n        src_k = 3;\n")
sub(c, "    return best2 < out2 ? best2 : out2;\n}", "    src_k = best2 < out2 ? 4 : 5;\n    return best2 < out2 ? best2 : out2;\n}")
w = root + "/src/dla/walker.c"
sub(w, "static inline __attribute__((always_inline)) int walk_step_dim(", r'''#include <stdio.h>
_Thread_local int src_k;
static const char *const src_name[10] = {"mapfine", "mapcoarse", "unknown->tree", "leafbound", "blk-exact", "blk-cut", "-", "-", "tree", "return"};
static _Thread_local uint64_t src_n[10];
static _Thread_local uint64_t src_tick;
static void src_dump(uint64_t n)
{
    fprintf(stderr, "SRC at %llu:", (unsigned long long)n);
    for (int i = 0; i < 10; i++) if (src_n[i]) fprintf(stderr, " %s=%llu", src_name[i], (unsigned long long)src_n[i]);
    fprintf(stderr, "\n");
}
static inline void src_count(const tree *t, int k)
{
    src_n[k]++;
    if (!(++src_tick & ((1u << 26) - 1))) {
        static _Thread_local uint64_t next = 1000000;
        const uint64_t n = tree_count(t);
        if (n >= next) { src_dump(n); next = n + n / 4; }
    }
}
static inline __attribute__((always_inline)) int walk_step_dim(''')
sub(w, "        jump(w, p, (double)far - D - 1.0, dim);", "        src_count(t, src_k);\n        jump(w, p, (double)far - D - 1.0, dim);")
sub(w, "    uint64_t d2 = UINT64_MAX;\n", "    uint64_t d2 = UINT64_MAX;\n    src_k = 8;\n")
sub(w, "    if (d2 == UINT64_MAX) d2 = search_lower_bound2(t, &e->search, p, UINT64_MAX, &w->ss);", "    if (d2 == UINT64_MAX) { if (src_k != 2) src_k = 8; d2 = search_lower_bound2(t, &e->search, p, UINT64_MAX, &w->ss); }")
sub(w, "    jump(w, p, sqrt((double)d2) - D - 1.0, dim);", "    src_count(t, src_k);\n    jump(w, p, sqrt((double)d2) - D - 1.0, dim);")
print("ok")
