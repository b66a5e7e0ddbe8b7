#!/usr/bin/env bash
# fractal.sh - the physics record: D_f of the grown cluster against the mean
# free path (packing 1e-3 .. 0.3), 2D and 3D, all particles sticking (p = 1),
# Maxwell-Boltzmann start, elastic walls, seed radius = particle radius.
# D_f is fitted from R_g(k) of the cluster in arrival order (see
# ev_fractal_dimension in src/event/ev_out.c). Run from the repository root:
#   runs/event/fractal.sh > runs/event/fractal.txt
set -eu
b=build/pdla
o=runs/event/out
mkdir -p "$o"
printf "%-3s %-8s %-7s %-10s %-8s %-14s %-10s %-8s\n" dim packing N lambda/sig D_f_rg "fit k range" collisions cpu_s
for spec in "2 0.001 10000" "2 0.01 10000" "2 0.05 10000" "2 0.1 10000" "2 0.2 10000" "2 0.3 10000" \
            "3 0.001 10000" "3 0.01 10000" "3 0.05 10000" "3 0.1 10000" "3 0.3 10000"; do
    set -- $spec
    d=$1 eta=$2 n=$3
    dir=$o/d${d}_p${eta}
    out=$($b --model event --dim "$d" --particles "$n" --packing "$eta" --seed 1 --series-dt 50 \
          --out "$dir" --force)
    info=$($b info "$dir/cluster.h5")
    get() { echo "$info" | awk -v k="$1" '$1 == k { print $2 }'; }
    cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
    printf "%-3s %-8s %-7s %-10.4g %-8.4f %-14s %-10s %-8s\n" "$d" "$eta" "$n" \
        "$(get mean_free_path_over_diameter)" "$(get D_f_rg)" "$(get D_f_k_lo)-$(get D_f_k_hi)" \
        "$(get collisions)" "$cpu"
    if [ "$d" = 2 ]; then $b render "$dir/cluster.h5" -o "runs/event/cluster_2d_p${eta}.png" --size 512 --force; fi
done
