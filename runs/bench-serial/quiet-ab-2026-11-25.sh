#!/bin/bash
# interleaved old/new, quiet machine: wall and user seconds of the whole process
for r in 1 2 3; do
 for b in old new; do
  bin=/work/big/old/bo/pdla; [ $b = new ] && bin=/work/big/new-pdla
  for case in "2 1e6" "3 1e6"; do
   set -- $case
   /usr/bin/time -f "$b dim=$1 N=$2 wall %e user %U maxrss %M" $bin --dim $1 --target $2 --seed 1 --no-output -q
  done
 done
done
