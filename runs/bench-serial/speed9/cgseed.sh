#!/bin/bash
# cgseed.sh BIN DIM N SEED: callgrind Ir, jumps
T=$(mktemp --suffix=.json)
ir=$(nice -n 10 valgrind --tool=callgrind --callgrind-out-file=/dev/null "$1" --dim $2 --target $3 --seed $4 --no-output -q --stats-json $T 2>&1 | grep -o "refs: *[0-9,]*" | tr -d ' ,' | cut -d: -f2)
python3 -c "import json; s=json.load(open('$T')); print('$1 seed $4 N $3 Ir', $ir, 'jumps', s['jumps'], 'Ir/jump %.1f Ir/particle %.0f' % ($ir/s['jumps'], $ir/s['particles']))"
rm -f $T
