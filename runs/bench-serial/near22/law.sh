#!/bin/bash
# law.sh BIN DIM N S0 S1 OUT: R_g (diameters) and jumps/particle per seed,
# one line each (runs/bench-serial/issue12-near22-2026-11-30.md)
B=$1; DIM=$2; N=$3; T=$(mktemp); for s in $(seq $4 $5); do
  $B --dim $DIM --target $N --seed $s --no-output -q --stats-json $T 2>/dev/null
  python3 -c "import json; s=json.load(open('$T')); print($s, s['rg_diam'], s['jumps']/s['particles'])"
done > $6; rm -f $T
