import re,sys
for f in sys.argv[1:]:
    prev=None
    print(f)
    for line in open(f):
        if not line.startswith("SRC"): continue
        n=int(re.search(r"at (\d+)",line).group(1))
        d={k:int(v) for k,v in re.findall(r"(\S+)=(\d+)",line)}
        if prev:
            pn,pd=prev; dn=n-pn
            print(f"{pn/1e6:7.1f}-{n/1e6:7.1f}M", " ".join(f"{k}={(d[k]-pd.get(k,0))/dn:6.2f}" for k in d if k!="tree"), f"total={sum(d[k]-pd.get(k,0) for k in d)/dn:6.2f}")
        prev=(n,d)
