#!/bin/sh
# build-old: main at 9826cca + params commit; build-new: the same with Morton order (reverted). Runs interleaved, nice 10, loaded VM.
# interleaved old/new: dim N t_max
for rep in 1 2; do
for c in "3 10000 1" "3 100000 0.4" "3 1000000 0.08" "2 10000 4" "2 100000 1" "2 1000000 0.25"; do
  set -- $c
  for b in old new; do
    out=$(nice -n 10 /work/wt/event3/build-$b/pdla --model event --dim $1 --particles $2 --packing 0.3 --box-walls periodic --seed-radius 0 --start lattice --t-max $3 --series-dt $3 --seed 5 --out /tmp/ev3/r$b --force 2>&1)
    echo "$rep $b $1 $2 $3 $(echo "$out" | grep -E '^cpu|^stuck' | tr '\n' ' ')"
  done
done
done
