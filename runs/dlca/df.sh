#!/bin/sh
# runs/dlca/df.sh - D_f of the final clusters (R_g against size, sizes >= 8,
# /results/D_f of cluster.h5) of the anchor's setups, three seeds each.
set -eu
for f in 0.01 0.05; do
    for seed in 1 2 3; do
        d=/tmp/dlca-df-$f-$seed
        build/pdla --model dlca --dim 2 --box 1024x512 --fill $f --until-clusters 100 --seed $seed --out $d --force -q
        printf 'fill %s seed %s: ' $f $seed
        build/pdla info $d/cluster.h5 | awk '$1=="D_f"||$1=="D_f_err"||$1=="largest"||$1=="attempts"{printf "%s %s  ", $1, $2} END{print ""}'
    done
done
