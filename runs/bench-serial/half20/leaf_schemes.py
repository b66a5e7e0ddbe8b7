#!/usr/bin/env python3
"""leaf_schemes.py CLUSTER.h5: chunk bytes/particle of a cluster under leaf layouts (leaves of 256 units):
old = chunks of 10 only; serial = chunks and one last half of 5 (16 B); conc-* = chains grown while workers append."""
import h5py, numpy as np, sys
f=h5py.File(sys.argv[1]); p=f['/cluster/positions'][:]
dim=p.shape[1]; N=len(p)
li=np.floor_divide(p.astype(np.int64),256)
_,cnt=np.unique(li,axis=0,return_counts=True)
FULL=24 if dim==2 else 36; HALF=16 if dim==2 else 20
def chain(n, seq):
    b=0; i=0
    while n>0:
        c=seq(i); b+= HALF if c==5 else FULL; n-=c; i+=1
    return b
alt=sum(chain(n, lambda i: 5 if i%2==0 else 10) for n in cnt)/N
first=sum(chain(n, lambda i: 5 if i==0 else 10) for n in cnt)/N
old=(np.ceil(cnt/10)*FULL).sum()/N
full=cnt//10; rem=cnt%10
serial=(full*FULL+np.where(rem==0,0,np.where(rem<=5,HALF,FULL))).sum()/N
print(dim, "old %.3f serial %.3f conc-alternate %.3f conc-first-half %.3f"%(old,serial,alt,first))
