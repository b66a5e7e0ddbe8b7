#!/bin/sh
# runs/dlca/run.sh - the seed's Fig. 5 (N_c against t) and Fig. 6 (time per
# attempted move against N_c) for 1024 x 512 at 1% and 5%, gamma = 0 (all
# clusters equally mobile, as in the seed and the zhangns/DLCA anchor), down
# to 100 clusters, with the three searches. CPU time of the process (the
# 2-core machine is shared: wall clock is not trusted). From the repo root:
#   ninja -C build && sh runs/dlca/run.sh
set -eu
b=build/tests/dlca/bench_dlca
o=runs/dlca
for f in 0.01 0.05; do
    for seed in 1 2 3; do
        nice -n 10 $b 2 1024x512 $f 100 $seed lattice 20000 >$o/lattice-$f-s$seed.txt
    done
    nice -n 10 $b 2 1024x512 $f 100 1 boxes 20000 >$o/boxes-$f-s1.txt
done
# All pairs: the whole run at 1%; the first 300000 attempts at 5%.
nice -n 10 $b 2 1024x512 0.01 100 1 allpairs 20000 >$o/allpairs-0.01-s1.txt
nice -n 10 $b 2 1024x512 0.05 100 1 allpairs 20000 300000 >$o/allpairs-0.05-s1.txt
