#!/usr/bin/env bash
# ballistic.sh - the event model's cluster in the limit of a long mean free
# path against ballistic particle-cluster aggregation (BPCA, ballistic.c)
# and pdla's own DLA, all N particles of diameter 1, with the same two
# D_f estimates (ballistic.c: R_g(k) in arrival order with the model's fit,
# and mass-radius M(r) around the seed; see ballistic.c).
# Event runs as in fractal.sh: p = 1, elastic walls, seed radius 0.5,
# Maxwell-Boltzmann kT = 1, run until all stuck. Run from the repository root
# after `ninja -C build`:
#   nice -n 10 runs/event/ballistic.sh > runs/event/ballistic.txt
#   nice -n 10 runs/event/ballistic.sh 100000 2 "0.001 0.01 0.05 0.3" 2 > runs/event/ballistic-1e5.txt
# Arguments: N (default 10000), the dimensions ("2 3"), the event model's
# packings ("0.0001 0.001 0.01 0.05 0.3"), the BPCA and DLA seeds (4).
set -eu
n=${1:-10000}
dims=${2:-2 3}
etas=${3:-0.0001 0.001 0.01 0.05 0.3}
nseeds=${4:-4}
b=build/pdla
o=runs/event/out
mkdir -p "$o"
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE -Iinclude runs/event/ballistic.c build/libpdla.a \
    $(pkg-config --libs hdf5 hwloc) -lm -lpthread -o build/ballistic
r=build/ballistic
for d in $dims; do
    for s in $(seq 1 "$nseeds"); do $r bpca $d "$n" $s; done
    for s in $(seq 1 "$nseeds"); do
        dir=$o/dla_d${d}_s$s
        [ "$n" = 10000 ] || dir=${dir}_n$n
        $b --dim $d --target "$n" --threads 1 --arrival --seed $s --rg-per-decade 0 --out "$dir.tmp" >/dev/null
        $b export "$dir.tmp/cluster.h5" -o "$dir.csv" --force
        rm -rf "$dir.tmp"
        $r csv "$dir.csv" # row 0: the seed at the origin
    done
    for eta in $etas; do
        dir=$o/ball_d${d}_p$eta
        [ "$n" = 10000 ] || dir=${dir}_n$n
        out=$($b --model event --dim $d --particles "$n" --packing $eta --seed 1 --series-dt 1000 \
              --out "$dir" --force)
        cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
        info=$($b info "$dir/cluster.h5")
        get() { echo "$info" | awk -v k="$1" '$1 == k { print $2 }'; }
        L=$(get box_side)
        h=$(awk -v L="$L" 'BEGIN { printf "%.17g", L / 2 }')
        $b export "$dir/cluster.h5" -o "$dir.csv" --force
        echo "event packing $eta lambda/sigma $(get mean_free_path_over_diameter) box $L" \
             "model D_f_rg $(get D_f_rg) cpu $cpu s"
        $r csv "$dir.csv" $h $h $([ $d = 3 ] && echo $h)
    done
done
