#!/usr/bin/env bash
# crossover.sh - one event run in a large dilute 2D box (the gas barely
# used up), its cluster's mass-radius profile M(r) with the local slope
# against r / lambda (window.c), the series (time, stuck) for the cost
# extrapolation, the free gas's packing in rings around the seed at the end,
# and a picture of the box centre. README "Looking for the
# DLA-like window at packing 0.03".
# From the repository root after `ninja -C build`:
#   nice -n 10 runs/event/crossover.sh 0.03 300000 15000 1 > runs/event/crossover-2d.txt
# REFS=3 adds pdla's DLA and ballistic aggregation (BPCA, ballistic.c) of STUCK
# particles, seeds 1..3, by the same estimate over the same window.
# REUSE=1 analyses an existing run of the same arguments instead of rerunning it.
# Arguments: PACKING N STUCK SEED. p = 1, elastic walls, Maxwell-Boltzmann
# kT = 1, seed radius 0.5, stop at STUCK stuck particles. Window: r from
# 2 lambda to 0.4 R_max as in fractal-window.sh.
set -eu
eta=$1 n=$2 stuck=$3 s=$4
b=build/pdla
o=runs/event/out
mkdir -p "$o"
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE runs/event/window.c -lm -o build/window
dir=$o/cross_p${eta}_n${n}_s$s
git log -1 --format='# commit %h (%cd)' --date=iso
echo "# $b --model event --dim 2 --particles $n --packing $eta --seed $s --max-stuck $stuck --series-dt 200 --out $dir"
if [ -z "${REUSE:-}" ] || [ ! -f "$dir/cluster.h5" ] || [ ! -f "$dir.log" ]; then
    /usr/bin/time -f "%U user %S sys %e wall %M KB" $b --model event --dim 2 --particles "$n" --packing "$eta" \
        --seed "$s" --max-stuck "$stuck" --series-dt 200 --out "$dir" --force --no-progress > "$dir.log" 2>&1
else
    echo "# (REUSE=1: the run below was made earlier by this command, its output kept in $dir.log)"
fi
sed 's/^/# /' "$dir.log"
info=$($b info "$dir/cluster.h5")
get() { echo "$info" | awk -v k="$1" '$1 == k { print $2 }'; }
lam=$(get mean_free_path_over_diameter) L=$(get box_side)
echo "# lambda/sigma $lam, box $L, collisions $(get collisions), events $(get events), time $(get time)"
echo "# series: time stuck"
h5dump -d /series/time -d /series/stuck "$dir/cluster.h5" | awk '/DATA \{/ { on = 1; next } on && /\}/ { on = 0 }
    on { sub(/^ *\([0-9]+\): */, ""); gsub(/,/, " "); printf "%s", $0 } /DATASET "\/series\/stuck"/ { print "" }' |
    awk 'NR == 1 { nt = split($0, t, " ") } NR == 2 { split($0, m, " "); for (i = 1; i <= nt; i++) printf "#   %10s %8s\n", t[i], m[i] }'
$b export "$dir/cluster.h5" -o "$dir.csv" --force >/dev/null
c=$(awk -v L="$L" 'BEGIN { printf "%.17g", L / 2 }')
rmax=$(build/window 2 1 2 "$c" "$c" "$dir.csv" | awk '$1 == "file" { print $6 }')
set -- $(awk -v l="$lam" -v r="$rmax" 'BEGIN { printf "%.3g %.3g\n", 2 * l, 0.4 * r }')
echo "## event packing $eta, N $n, seed $s, $stuck stuck, R_max $rmax, window [$1, $2]"
build/window 2 "$1" "$2" "$c" "$c" "$dir.csv" | grep -v '^file' |
    awk -v l="$lam" '$1 == "r" { print $0, "  r/lambda"; next } $1 + 0 > 0 { printf "%s %9.2f\n", $0, $1 / l; next } { print }'
if [ -n "${REFS:-}" ]; then # pdla's DLA and BPCA of STUCK particles, seeds 1..REFS, the same window
    cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE -Iinclude -Itests/event runs/event/ballistic.c build/libpdla.a \
        $(pkg-config --libs hdf5 hwloc) -lm -lpthread -o build/ballistic
    for k in $(seq 1 "$REFS"); do
        f=$o/cross_dla_${stuck}_s$k
        $b --dim 2 --target "$stuck" --threads 1 --arrival --seed "$k" --rg-per-decade 0 --out "$f.tmp" >/dev/null
        $b export "$f.tmp/cluster.h5" -o "$f.csv" --force >/dev/null
        rm -rf "$f.tmp"
        build/ballistic bpca 2 "$stuck" "$k" "$o/cross_bpca_${stuck}_s$k.csv" >/dev/null
    done
    for ref in dla bpca; do
        echo "## reference $ref, $stuck particles, seeds 1..$REFS, the same window [$1, $2] (r/lambda: packing $eta's lambda)"
        build/window 2 "$1" "$2" 0 0 $(ls $o/cross_${ref}_${stuck}_s*.csv | head -n "$REFS") | grep -v '^file' |
            awk -v l="$lam" '$1 == "r" { print $0, "  r/lambda"; next } $1 + 0 > 0 { printf "%s %9.2f\n", $0, $1 / l; next } { print }'
    done
fi
echo "## free gas at the end: packing in rings around the seed (h5dump of /free/positions, 6 digits)"
h5dump -d /free/positions -y -w 0 "$dir/cluster.h5" | grep -E '^ *[0-9.e+-]+, [0-9.e+-]+' | tr -d ',' |
    awk -v c="$c" -v d="$eta" 'BEGIN { nb = split("0 60 120 150 180 240 300 400 600 800 1000 1300", e, " ") }
    { r = sqrt(($1 - c)^2 + ($2 - c)^2); for (i = 1; i < nb; i++) if (r >= e[i] && r < e[i + 1]) k[i]++ }
    END { for (i = 1; i < nb; i++) printf "#   r %5d-%-5d free %7d packing %.4f\n", e[i], e[i + 1], k[i],
          k[i] * 3.14159265 / 4 / (3.14159265 * (e[i + 1]^2 - e[i]^2)) }'
if [ "$s" = 1 ]; then # the committed picture: seed 1
    $b render "$dir/cluster.h5" -o "$dir.png" --size 4096 --force >/dev/null
    convert "$dir.png" ppm:- > "$dir.ppm"
    python3 runs/event/crop-png.py "$dir.ppm" 480 "runs/event/crossover_2d_p$eta.png"
    rm -f "$dir.ppm"
fi
