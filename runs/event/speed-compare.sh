#!/bin/sh
# interleaved old/new: dim N t_max
cd /tmp/ev2
for spec in "3 10000 1" "2 10000 4" "3 100000 1" "2 100000 4" "2 1000000 1" "3 1000000 0.25"; do
  set -- $spec
  for b in pdla_old pdla_new; do
    printf "%s %s %s %s " $b $1 $2 $3
    nice -n 10 ./$b --model event --dim $1 --particles $2 --packing 0.3 --box-walls periodic --seed-radius 0 --t-max $3 --series-dt $3 --seed 5 --out /tmp/ev2/rc_$b --force | grep cpu
  done
done
