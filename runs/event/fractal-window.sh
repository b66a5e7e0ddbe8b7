#!/usr/bin/env bash
# fractal-window.sh - D_f of the event model's cluster in a window of r set
# by the mean free path, from the mass-radius profile M(r) around the seed
# (window.c), several seeds per packing, the run stopped at a number of
# stuck particles well before the gas is used up; with pdla's DLA and
# ballistic particle-cluster aggregation (ballistic.c) of the same mass by
# the same estimate. See runs/event/README.md, "D_f in a window".
# Run from the repository root after `ninja -C build`:
#   nice -n 10 runs/event/fractal-window.sh 2 100000 20000 "0.3 0.2 0.1 0.05 0.02" 3 > runs/event/fractal-window-2d.txt
# Arguments: DIM N STUCK PACKINGS SEEDS. Event runs: p = 1, elastic walls,
# seed radius 0.5, Maxwell-Boltzmann kT = 1, stop at STUCK stuck particles.
# Window: r from max(2 lambda, 4) to 0.4 R_max (the smallest R_max of the
# seeds: the outer rim is still growing), lambda the dilute mean free path;
# "no window" when that is under a factor 2. References: STUCK particles,
# window [4, 0.4 R_max].
set -eu
d=$1 n=$2 stuck=$3 etas=$4 nseeds=$5
b=build/pdla
o=runs/event/out
mkdir -p "$o"
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE runs/event/window.c -lm -o build/window
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE -Iinclude -Itests/event runs/event/ballistic.c build/libpdla.a \
    $(pkg-config --libs hdf5 hwloc) -lm -lpthread -o build/ballistic
w=build/window
git log -1 --format='# commit %h (%cd)' --date=iso
echo "# dim $d N $n stop at $stuck stuck, packings $etas, seeds 1..$nseeds"
window_of() { # the window [lo, hi] from lambda (or none), the centre and the csv files
    local lam=$1 c=$2; shift 2
    local rmin
    rmin=$($w "$d" 1 2 $c "$@" | awk '$1 == "file" { print $6 }' | sort -g | head -1)
    awk -v l="$lam" -v r="$rmin" 'BEGIN { lo = (l == "" ? 4 : (2 * l > 4 ? 2 * l : 4)); hi = 0.4 * r;
        printf "%.3g %.3g\n", lo, hi }'
}
zero=$([ "$d" = 3 ] && echo "0 0 0" || echo "0 0")
centre() { awk -v L="$1" -v d="$d" 'BEGIN { h = L / 2; printf "%.17g %.17g", h, h; if (d == 3) printf " %.17g", h }'; }
for s in $(seq 1 "$nseeds"); do
    f=$o/win_dla_d${d}_s$s
    $b --dim "$d" --target "$stuck" --threads 1 --arrival --seed "$s" --rg-per-decade 0 --out "$f.tmp" >/dev/null
    $b export "$f.tmp/cluster.h5" -o "$f.csv" --force >/dev/null
    rm -rf "$f.tmp"
    build/ballistic bpca "$d" "$stuck" "$s" "$o/win_bpca_d${d}_s$s.csv" >/dev/null
done
for ref in dla bpca; do
    files=$(ls $o/win_${ref}_d${d}_s*.csv | head -n "$nseeds")
    set -- $(window_of "" "$zero" $files)
    echo "## reference $ref, $stuck particles, window [$1, $2]"
    $w "$d" "$1" "$2" $zero $files | grep -v '^file'
done
for eta in $etas; do
    files=
    for s in $(seq 1 "$nseeds"); do
        dir=$o/win_d${d}_p${eta}_n${n}_s$s
        out=$($b --model event --dim "$d" --particles "$n" --packing "$eta" --seed "$s" --max-stuck "$stuck" \
              --series-dt 1000 --out "$dir" --force --no-progress)
        info=$($b info "$dir/cluster.h5")
        get() { echo "$info" | awk -v k="$1" '$1 == k { print $2 }'; }
        $b export "$dir/cluster.h5" -o "$dir.csv" --force >/dev/null
        files="$files $dir.csv"
        lam=$(get mean_free_path_over_diameter) L=$(get box_side)
        cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
        echo "# run packing $eta seed $s: stuck $(get stuck) of $n, time $(get time), collisions $(get collisions)," \
             "events $(get events), lambda/sigma $lam, box $L, cpu $cpu s"
    done
    set -- $(window_of "$lam" "$(centre "$L")" $files)
    echo "## event packing $eta, lambda/sigma $lam, window [$1, $2]$(awk -v a="$1" -v b="$2" 'BEGIN { if (b < 2 * a) printf " (no window: under a factor 2)" }')"
    $w "$d" "$1" "$2" $(centre "$L") $files | grep -v '^file'
done
