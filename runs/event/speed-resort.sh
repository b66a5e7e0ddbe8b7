#!/bin/sh
# speed-resort.sh PDLA - the most that keeping the particles in cell order
# during a run could gain (speed.md, session 10). PDLA is built with
# speed-resort.diff (a scratch patch, not kept): after every series
# interval, EVRESORT=1 syncs, renumbers the particles in cell order and
# rebuilds cells, predictions and queue; EVRESORT=2 syncs and rebuilds only;
# unset (0): the engine as it is. The three modes interleaved, two rounds;
# periodic gas at packing 0.3, sticking off, lattice start, seed 5.
set -eu
B=${1:?usage: speed-resort.sh PDLA_BUILT_WITH_speed-resort.diff}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for r in 1 2; do
for c in "3 100000 1.5 0.25" "2 100000 6 1" "3 1000000 0.45 0.15" "2 1000000 3 0.75"; do
  set -- $c
  for m in 0 1 2; do
    out=$(EVRESORT=$m nice -n 10 /usr/bin/time -f "TIME %U" $B --model event --dim $1 --particles $2 --packing 0.3 --box-walls periodic --seed-radius 0 --start lattice --t-max $3 --series-dt $4 --seed 5 --out $tmp/rs$m --force --no-progress 2>&1)
    coll=$(echo "$out" | sed -n 's/.*events \([0-9]*\), collisions \([0-9]*\),.*/\2/p')
    cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
    echo "round $r dim $1 N $2 t $3 dt $4 mode $m collisions $coll engine_cpu $cpu $(echo "$out" | grep TIME)"
  done
done
done
