#!/bin/bash
# cgseeds.sh BIN N SEEDS... : Ir and jumps per seed (env passes through)
B=$1; N=$2; shift 2
for s in "$@"; do
  T=$(mktemp --suffix=.json)
  ir=$(nice -n 10 valgrind --tool=callgrind --callgrind-out-file=/dev/null $B --dim 3 --target $N --seed $s --no-output -q --stats-json $T 2>&1 | grep -o "refs: *[0-9,]*" | tr -d ' ,' | cut -d: -f2)
  python3 -c "import json; s=json.load(open('$T')); print('$B', $N, $s, $ir, s['jumps'], s['rg_diam'])"
  rm -f $T
done
