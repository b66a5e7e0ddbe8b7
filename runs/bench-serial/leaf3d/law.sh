#!/bin/bash
# law.sh BIN N S0 S1 OUT: R_g, jumps/particle per seed
B=$1; N=$2; for s in $(seq $3 $4); do
  nice -n 10 $B --dim 3 --target $N --seed $s --no-output -q --stats-json /tmp/leaf3d/law_$$.json 2>/dev/null
  python3 -c "import json; s=json.load(open('/tmp/leaf3d/law_$$.json')); print($s, s['rg_diam'], s['jumps']/s['particles'])"
done > $5
