#!/bin/bash
# callgrind_ir.sh BIN DIM N: callgrind total Ir, plus jumps from the stats
T=$(mktemp --suffix=.json)
ir=$(nice -n 10 valgrind --tool=callgrind --callgrind-out-file=/dev/null "$1" --dim $2 --target $3 --seed 1 --no-output -q --stats-json $T 2>&1 | grep -o "refs: *[0-9,]*" | tr -d ' ,' | cut -d: -f2)
python3 -c "import json,sys; s=json.load(open('$T')); print('$1 dim $2 N $3 Ir', $ir, 'jumps', s['jumps'], 'Ir/jump %.1f' % ($ir/s['jumps']))"
rm -f $T
