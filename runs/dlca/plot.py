#!/usr/bin/python3
"""runs/dlca/plot.py - the seed's Fig. 5 and Fig. 6 from run.sh's tables,
and summary.txt (totals, the grid-boxing / all-pairs ratio near 2365
clusters). Run from the repo root: /usr/bin/python3 runs/dlca/plot.py (Debian matplotlib)"""
import glob, os
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

here = os.path.dirname(os.path.abspath(__file__))

def load(name):
    rows, total = [], None
    for line in open(os.path.join(here, name)):
        if line.startswith("# total:"):
            w = line.split()[2:]
            total = {w[i]: w[i + 1] for i in range(0, len(w) - 1, 2)}
        elif not line.startswith("#"):
            f = line.split()
            rows.append((int(f[0]), float(f[1]), int(f[2]), float(f[3]), float(f[4]), float(f[5]), f[6]))
    return rows, total

out = []
fig, ax = plt.subplots(figsize=(5, 3.6))
for f, c in (("0.01", "C0"), ("0.05", "C3")):
    for s in (1, 2, 3):
        rows, _ = load(f"lattice-{f}-s{s}.txt")
        ax.loglog([r[1] for r in rows if r[1] > 0], [r[2] for r in rows if r[1] > 0], color=c, lw=1,
                  label=f"fill {float(f):.0%}" if s == 1 else None)
ax.set_xlabel("t (monomer-move units)")
ax.set_ylabel("clusters N_c")
ax.set_title("DLCA 1024 x 512, gamma = 0 (3 seeds each)")
ax.legend()
fig.tight_layout()
fig.savefig(os.path.join(here, "fig5-nc-vs-t.png"), dpi=80)

fig, ax = plt.subplots(figsize=(5, 3.6))
for f, m in (("0.01", "-"), ("0.05", "--")):
    for search, c in (("lattice", "C0"), ("boxes", "C1"), ("allpairs", "C2")):
        name = f"{search}-{f}-s1.txt"
        if not os.path.exists(os.path.join(here, name)):
            continue
        rows, total = load(name)
        ax.loglog([r[2] for r in rows], [r[3] for r in rows], m, color=c, lw=1,
                  label=f"{search} {float(f):.0%}")
        out.append(f"{name}: attempts {total['attempts']} cpu_s {total['cpu_s']} "
                   f"ns/attempt {total['ns_per_attempt']} ns/monomer-move {total['ns_per_monomer_move']} "
                   f"N_c {total['n_clusters']} stop {total['stop']}")
ax.invert_xaxis()
ax.set_xlabel("clusters N_c (time runs to the right)")
ax.set_ylabel("CPU ns per attempted move")
ax.set_title("DLCA 1024 x 512: cost per move")
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(os.path.join(here, "fig6-time-per-move.png"), dpi=80)

# The seed's comparison: per-attempt cost near 2365 clusters (1%).
def near(name, nc):
    rows, _ = load(name)
    return min(rows, key=lambda r: abs(r[2] - nc))
for f in ("0.01",):  # the 5% all-pairs run stops at 300000 attempts, N_c ~ 8800
    try:
        a, b, l = near(f"allpairs-{f}-s1.txt", 2365), near(f"boxes-{f}-s1.txt", 2365), near(f"lattice-{f}-s1.txt", 2365)
    except (FileNotFoundError, ValueError):
        continue
    out.append(f"fill {f} near N_c 2365: allpairs {a[3]:.0f} ns ({a[5]:.0f} clusters tested, at N_c {a[2]}), "
               f"boxes {b[3]:.0f} ns ({b[5]:.1f} tested, N_c {b[2]}), lattice {l[3]:.0f} ns (N_c {l[2]}); "
               f"allpairs/boxes {a[3] / b[3]:.1f}x, allpairs/lattice {a[3] / l[3]:.1f}x, boxes/lattice {b[3] / l[3]:.1f}x")
for f in ("0.01", "0.05"):
    tot = [load(f"lattice-{f}-s{s}.txt")[1] for s in (1, 2, 3)]
    out.append(f"lattice fill {f}, seeds 1-3: attempts " + ", ".join(t["attempts"] for t in tot) +
               "; cpu_s " + ", ".join(t["cpu_s"] for t in tot) + "; ns/attempt " +
               ", ".join(t["ns_per_attempt"] for t in tot) + "; ns/monomer-move " +
               ", ".join(t["ns_per_monomer_move"] for t in tot))
open(os.path.join(here, "summary.txt"), "w").write("\n".join(out) + "\n")
print("\n".join(out))
