#!/bin/bash
# bin then configs "T K BETA"
bin=$1; shift
for cfg in "$@"; do
  set -- $cfg
  if [ $1 = none ]; then unset HB_T; else export HB_T=$1 HB_K=$2 HB_BETA=$3 HB_MAP=0; fi
  for s in 1 2 3 4 5 6; do
    ir=$(valgrind --tool=callgrind --callgrind-out-file=/tmp/cgh2.out $bin --dim 3 --target 3e4 --seed $s --no-output 2>&1 | grep Collected | awk '{print $4}')
    j=$($bin --dim 3 --target 3e4 --seed $s --no-output 2>&1 | grep 'jumps/p' | awk '{print $2}')
    echo "cfg=$cfg seed=$s Ir=$ir jumps=$j"
  done
done
