#!/bin/sh
# seed-radius-cost.sh OLD NEW - the cost of a seed larger than the particles,
# before (cells sized by twice the largest radius) and after (by the largest
# contact distance, seed radius + particle radius): a box with elastic walls,
# packing 0.1, particles of radius 0.5, a central seed of radius 0.5, 2 or 5,
# run to the same time; the clusters, free particles and series of the two
# binaries must be the same (h5diff), only the number of cell crossings and
# the time differ. Prints: dim seed_radius binary stuck events collisions cpu_s us/collision same
old=$1 new=$2
t=${TMPDIR:-/tmp}/seedcost.$$
for d in 2 3; do for sr in 0.5 2 5; do
    tm=20; [ $d = 2 ] && tm=60
    for b in old new; do
        eval bin=\$$b
        out=$($bin --model event --dim $d --particles 20000 --packing 0.1 --box-walls elastic --seed-radius $sr \
              --t-max $tm --series-dt 5 --seed 11 --out $t.$b --force --no-progress 2>&1)
        st=$(echo "$out" | sed -n 's/^stuck \([0-9]*\), events \([0-9]*\), collisions \([0-9]*\),.*/\1 \2 \3/p')
        cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
        set -- $st
        same=-
        if [ $b = new ]; then
            same=yes
            for g in /cluster /free /series; do h5diff $t.old/cluster.h5 $t.new/cluster.h5 $g >/dev/null || same=no; done
        fi
        echo "$d $sr $b $1 $2 $3 $cpu $(awk -v c=$3 -v u=$cpu 'BEGIN{printf "%.3f", 1e6*u/c}') $same"
    done
done; done
rm -rf $t.old $t.new
