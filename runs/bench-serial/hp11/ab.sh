#!/bin/bash
# usage: ab.sh OUT DIM N SEED PAIRS "A-cmdprefix" "B-cmdprefix"
# each prefix is e.g. "env /tmp/hp11-pdla-old" ; runs A B A B..., records user,sys,maxrss,jumps
out=$1 dim=$2 n=$3 seed=$4 pairs=$5 A=$6 B=$7
for i in $(seq $pairs); do
  for lab in A B; do
    if [ $lab = A ]; then cmd=$A; else cmd=$B; fi
    /usr/bin/time -f "%U %S %M" -o /tmp/hp11/t.$$ nice -n 10 $cmd --dim $dim --target $n --seed $seed --no-output -q --stats-json /tmp/hp11/s.$$.json
    j=$(/usr/bin/python3 -c "import json;d=json.load(open('/tmp/hp11/s.$$.json'));print(d['jumps'],d['rg_diam'],d['peak_rss_bytes'])")
    echo "$lab $dim $n $seed $(cat /tmp/hp11/t.$$) $j" >> $out
  done
done
