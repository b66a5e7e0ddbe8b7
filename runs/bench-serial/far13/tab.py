import sys, collections
def load(f):
    d = {}; tot=0
    for l in open(f):
        if not l.startswith('F13 ') or 'src,bin' in l: continue
        if 'grid' in l: continue
        if 'total_jumps' in l: tot=int(l.split()[2]); continue
        s,b,n,r,ld = l[4:].strip().split(',')
        d[(s,b)] = (int(n), float(r), float(ld))
    return d, tot
bins = ["<.25", ".25-.5", ".5-1", "1-2", "2-4", "4-8", "8-16", "16-32", "32-64", "64-128", "128-256", ">=256"]
files = sys.argv[1:]
import os
N = float(os.environ.get("N","1e5"))
data = [load(f) for f in files]
# per-bin totals
print("bin | " + " | ".join(f"{f} jumps/p (mean b/d)" for f in files))
for b in bins:
    row=[]
    for d,tot in data:
        n = sum(v[0] for k,v in d.items() if k[1]==b)
        r = sum(v[0]*v[1] for k,v in d.items() if k[1]==b)
        row.append(f"{n/N:.3f} ({r/n if n else 0:.3f})")
    print(b, "|", " | ".join(row))
for f,(d,tot) in zip(files,data):
    if os.environ.get("NOSRC"): break
    print("\n", f, "total jumps/p (excl. returns)", tot/N)
    srcs = sorted(set(k[0] for k in d))
    for s in srcs:
        n = sum(v[0] for k,v in d.items() if k[0]==s)
        line = " ".join(f"{b}:{d[(s,b)][0]/N:.2f}/{d[(s,b)][1]:.2f}" for b in bins if (s,b) in d)
        print(f"  {s:10s} {n/N:7.3f}  {line}")
