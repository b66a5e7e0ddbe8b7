import sys, math
def load(f):
    d={}
    for l in open(f):
        p=l.split('\t'); d[p[0]]=p
    return d
a=load(sys.argv[1]); b=load(sys.argv[2])
ks=[k for k in a if k in b]
x=[float(a[k][1])/float(b[k][1])-1 for k in ks]
n=len(x); m=sum(x)/n; sd=math.sqrt(sum((v-m)**2 for v in x)/(n-1))
rel=[float(a[k][10]) for k in ks if a[k][10] not in ('-','')]
print("%s vs %s: %d pairs, mean %+.3f%% +/- %.3f%% (sd %.2f%%), relaunches/run %.0f" % (sys.argv[1].split('/')[-1], sys.argv[2].split('/')[-1], n, 100*m, 100*sd/math.sqrt(n), 100*sd, sum(rel)/len(rel) if rel else -1))
