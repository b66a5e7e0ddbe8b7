#!/bin/sh
# big-seeds-cost.sh OLD NEW - seeds larger than the particles, before (OLD:
# listed in the cells, which they widened to seed radius + particle radius)
# and after (NEW: out of the cell lists, ev_big.c): 20000 particles of
# radius 0.5 at packing 0.1, to the same time, in three setups:
#   walls, a central seed of radius 0.5, 2, 5, 10 (session 14's cases, and 10);
#   periodic, a central seed of radius 5;
#   walls, a --seeds file of 8 seeds of radius 3 (a grid through the box).
# The clusters, free particles and series of the two binaries must be the
# same (h5diff); only the cell crossings (so the events) and the time differ.
# Prints: dim setup seed_radius binary stuck events collisions cpu_s us/collision same
old=$1 new=$2
t=${TMPDIR:-/tmp}/bigseed.$$
mkdir -p $t
run() { # dim setup radius extra-args...
    d=$1 setup=$2 sr=$3
    shift 3
    args="$*" # no spaces inside an argument here
    tm=20; [ $d = 2 ] && tm=60
    for b in old new; do
        eval bin=\$$b
        out=$($bin --model event --dim $d --particles 20000 --packing 0.1 $args \
              --t-max $tm --series-dt 5 --seed 11 --out $t/$b --force --no-progress 2>&1)
        st=$(echo "$out" | sed -n 's/^stuck \([0-9]*\), events \([0-9]*\), collisions \([0-9]*\),.*/\1 \2 \3/p')
        cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
        set -- $st
        same=-
        if [ $b = new ]; then
            same=yes
            for g in /cluster /free /series; do h5diff $t/old/cluster.h5 $t/new/cluster.h5 $g >/dev/null || same=no; done
        fi
        echo "$d $setup $sr $b $1 $2 $3 $cpu $(awk -v c=$3 -v u=$cpu 'BEGIN{printf "%.3f", 1e6*u/c}') $same"
    done
}
for d in 2 3; do
    for sr in 0.5 2 5 10; do run $d walls $sr --box-walls elastic --seed-radius $sr; done
    run $d periodic 5 --box-walls periodic --seed-radius 5
    # 8 seeds of radius 3 on a grid through the box (side 396.3 in 2D, 47.1 in 3D)
    if [ $d = 2 ]; then L=396.3; else L=47.1; fi
    awk -v d=$d -v L=$L 'BEGIN { for (i = 0; i < 8; i++) {
        x = (i % 2 + 0.5) * L / 2; y = (int(i / 2) % 2 + 0.5) * L / 2; z = (int(i / 4) + 0.5) * L / 2;
        if (d == 2) { x = (i % 4 + 0.5) * L / 4; y = (int(i / 4) + 0.5) * L / 2; printf "%g %g 3\n", x, y }
        else printf "%g %g %g 3\n", x, y, z } }' > $t/seeds.txt
    run $d seeds8 3 --box-walls elastic --seeds $t/seeds.txt
done
rm -rf $t
