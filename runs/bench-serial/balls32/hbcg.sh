#!/bin/bash
# config seeds -> Ir per config
for cfg in "none" "2.5 4" "3 8" "2 8"; do
  set -- $cfg
  if [ $1 = none ]; then unset HB_T; else export HB_T=$1 HB_K=$2 HB_MAP=0; fi
  tot=0; jt=0
  for s in 1 2 3 4 5 6; do
    ir=$(valgrind --tool=callgrind --callgrind-out-file=/tmp/cgh.out /tmp/bhb/pdla --dim 3 --target 3e4 --seed $s --no-output 2>&1 | grep Collected | awk '{print $4}')
    j=$(/tmp/bhb/pdla --dim 3 --target 3e4 --seed $s --no-output 2>&1 | grep 'jumps/p' | awk '{print $2}')
    echo "cfg=$cfg seed=$s Ir=$ir jumps=$j"
  done
done
