#!/bin/bash
# ab.sh N DIM ROUNDS SEED label=cmd... : alternate; print label user_s jumps
N=$1; DIM=$2; R=$3; SEED=$4; shift 4
for r in $(seq $R); do
  for spec in "$@"; do
    lab=${spec%%=*}; cmd=${spec#*=}
    /usr/bin/time -f "%U" -o /tmp/ab_t $cmd --dim $DIM --target $N --seed $SEED --no-output -q --stats-json /tmp/ab_s.json >/dev/null 2>&1
    j=$(python3 -c "import json; s=json.load(open('/tmp/ab_s.json')); print('%.4f %.4f' % (s['jumps']/s['particles'], s['rg_diam']))")
    echo "$r $lab $(cat /tmp/ab_t) $j"
  done
done
