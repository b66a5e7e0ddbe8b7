import collections,sys
d=collections.defaultdict(list)
for l in open(sys.argv[1]):
    a=l.replace('[','').replace(']','').replace("'",'').replace(',',' ').split()
    T=a[0]; jumps=int(a[2]); rg=float(a[3]); c=[int(a[i]) for i in (4,6,8,10,12)]
    d[T].append([jumps,rg]+c)
for T,v in d.items():
    n=len(v); m=[sum(x[i] for x in v)/n for i in range(7)]
    print(T, n, 'jumps %.0f rg %.2f near %.0f bounds %.0f used %.0f near2 %.0f tree %.0f'%tuple(m))
