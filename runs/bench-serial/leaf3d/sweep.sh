#!/bin/bash
# sweep.sh N SEEDS T...: mean counters over seeds
N=$1; S=$2; shift 2
for T in "$@"; do
  for s in $(seq 1 $S); do
    OCC3_T=$T nice -n 10 /work/wt/leaf3d/build/pdla --dim 3 --target $N --seed $s --no-output -q --stats-json /tmp/leaf3d/sw.json 2>/tmp/leaf3d/sw.err
    python3 -c "import json; s=json.load(open('/tmp/leaf3d/sw.json')); print($T, $s, s['jumps'], s['rg_diam'], open('/tmp/leaf3d/sw.err').read().split()[4:])"
  done
done
