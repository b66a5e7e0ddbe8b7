#!/bin/bash
# same_cluster.sh BIN_A BIN_B DIM N [SEED]: cluster.h5 positions and jumps identical?
A=$1; B=$2; D=$3; N=$4; S=${5:-1}
T=$(mktemp -d)
for x in A B; do
  bin=${!x}
  nice -n 10 $bin --dim $D --target $N --seed $S -q --out $T/$x --stats-json $T/$x.json >/dev/null 2>&1 || echo "run $x failed"
done
python3 - $T <<'PY'
import json,sys
t=sys.argv[1]
a=json.load(open(t+'/A.json')); b=json.load(open(t+'/B.json'))
keys=['jumps','particles','rg_diam','walkers','returns']
print(' '.join(f"{k}:{a.get(k)}{'==' if a.get(k)==b.get(k) else '!='}{b.get(k)}" for k in keys))
PY
h5diff -c $T/A/cluster.h5 $T/B/cluster.h5 /cluster/positions /cluster/positions && echo "h5diff positions: identical"
rm -rf $T
