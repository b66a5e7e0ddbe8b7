#!/usr/bin/env bash
# bath.sh - the DLA-like window: a dilute sticky kind diffusing through a
# dense bath of a kind that never sticks (STICKY 0 in --species), against
# the same sticky particles without the bath (the control), pdla's DLA and
# ballistic particle-cluster aggregation (BPCA, ballistic.c) of the same
# mass; mass-radius D_f around the seed (window.c) as in fractal-window.sh.
# README "A bath that never sticks: the DLA-like window".
# From the repository root after `ninja -C build`:
#   nice -n 10 runs/event/bath.sh 2000 20000 0.22 1000 3 8 > runs/event/bath-2d.txt
# Arguments: NSTICKY NBATH PACKING STUCK SEEDS REFSEEDS: bath runs of seeds
# 1..SEEDS; the control, DLA and BPCA (cheap) of seeds 1..REFSEEDS. 2D, every particle radius
# 0.5 and density 1 (sticky and bath alike: one mean free path), p = 1,
# elastic walls, Maxwell-Boltzmann kT = 1, seed radius 0.5, stop at STUCK
# stuck. PACKING is the total (sticky + bath); the control has only the
# NSTICKY sticky ones in the same box (packing PACKING * NSTICKY / (NSTICKY
# + NBATH)). Window: r from max(2 lambda, 4) to 0.4 R_max (the smallest
# R_max of the set's seeds: the rim is still growing), lambda the bath
# run's dilute mean free path (`pdla info` mean_free_path_over_diameter;
# with equal sizes and masses it is the sticky particles' too). Errors:
# sd / sqrt(seeds) of the per-seed slopes. Last, every set over the common
# window [max(2 lambda, 4), the smallest of the sets' upper ends].
# REUSE=1: analyse the runs already in runs/event/out (made by this command)
# instead of running them again.
set -eu
ns=$1 nb=$2 eta=$3 stuck=$4 nseeds=$5 nref=$6
b=build/pdla
o=runs/event/out
w=build/window
mkdir -p "$o"
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE runs/event/window.c -lm -o "$w"
cc -O2 -Wall -Wextra -std=c11 -D_GNU_SOURCE -Iinclude -Itests/event runs/event/ballistic.c build/libpdla.a \
    $(pkg-config --libs hdf5 hwloc) -lm -lpthread -o build/ballistic
eta_c=$(awk -v e="$eta" -v s="$ns" -v b="$nb" 'BEGIN { printf "%.6g", e * s / (s + b) }')
git log -1 --format='# commit %h (%cd)' --date=iso
echo "# 2D: $ns sticky + $nb bath at packing $eta (control: $ns sticky alone, packing $eta_c), stop at $stuck stuck, seeds 1..$nseeds (control and references 1..$nref)"
get() { echo "$2" | awk -v k="$1" '$1 == k { print $2 }'; }
run() { # run NAME SEED SPECIES PACKING: one event run (or REUSE), its csv, a line on it
    local dir=$o/$1_s$2
    local cmd="$b --model event --dim 2 --species $3 --packing $4 --seed $2 --max-stuck $stuck --series-dt 500 --out $dir --force --no-progress"
    if [ -z "${REUSE:-}" ] || [ ! -f "$dir/cluster.h5" ] || [ ! -f "$dir.log" ]; then
        /usr/bin/time -f "%U user %S sys %e wall %M KB" $cmd > "$dir.log" 2>&1
    fi
    local info
    info=$($b info "$dir/cluster.h5")
    $b export "$dir/cluster.h5" -o "$dir.csv" --force >/dev/null
    echo "# $cmd"
    echo "#   stuck $(get stuck "$info"), time $(get time "$info"), collisions $(get collisions "$info")," \
         "events $(get events "$info"), lambda/sigma $(get mean_free_path_over_diameter "$info")," \
         "box $(get box_side "$info"), $(grep -o 'cpu [0-9.]* s' "$dir.log"), $(grep user "$dir.log")"
}
bathname=bath_2d_n${ns}_b${nb}_p${eta}_m$stuck
ctrlname=ctrl_2d_n${ns}_p${eta_c}_m$stuck
for s in $(seq 1 "$nseeds"); do run "$bathname" "$s" "$ns:0.5:1,$nb:0.5:1:0" "$eta"; done
for s in $(seq 1 "$nref"); do run "$ctrlname" "$s" "$ns:0.5:1" "$eta_c"; done
for s in $(seq 1 "$nref"); do
    f=$o/bath_dla_${stuck}_s$s
    [ -n "${REUSE:-}" ] && [ -f "$f.csv" ] || {
        $b --dim 2 --target "$stuck" --threads 1 --arrival --seed "$s" --rg-per-decade 0 --out "$f.tmp" >/dev/null
        $b export "$f.tmp/cluster.h5" -o "$f.csv" --force >/dev/null
        rm -rf "$f.tmp"
    }
    [ -n "${REUSE:-}" ] && [ -f "$o/bath_bpca_${stuck}_s$s.csv" ] ||
        build/ballistic bpca 2 "$stuck" "$s" "$o/bath_bpca_${stuck}_s$s.csv" >/dev/null
done
info=$($b info "$o/${bathname}_s1/cluster.h5")
lam=$(get mean_free_path_over_diameter "$info") L=$(get box_side "$info")
c=$(awk -v L="$L" 'BEGIN { printf "%.17g %.17g", L / 2, L / 2 }')
lo=$(awk -v l="$lam" 'BEGIN { printf "%.3g", (2 * l > 4 ? 2 * l : 4) }')
his=
hi_of() { $w 2 1 2 "$@" | awk '$1 == "file" { print $6 }' | sort -g | head -1 | awk '{ printf "%.3g", 0.4 * $1 }'; }
window() { # window TITLE CENTRE(2 words) FILES...: the set's window [lo, 0.4 min R_max] and profile
    local title=$1 cx=$2 cy=$3
    shift 3
    local hi
    hi=$(hi_of "$cx" "$cy" "$@")
    his="$his $hi"
    echo "## $title, window [$lo, $hi] (r/lambda in the last column, lambda $lam)"
    $w 2 "$lo" "$hi" "$cx" "$cy" "$@" | grep -v '^file' |
        awk -v l="$lam" '$1 == "r" { print $0, "  r/lambda"; next } $1 + 0 > 0 { printf "%s %9.2f\n", $0, $1 / l; next } { print }'
    $w 2 "$lo" "$hi" "$cx" "$cy" "$@" | awk '$1 == "file" { printf "#   %s\n", $0 }'
}
fb=$(for s in $(seq 1 "$nseeds"); do echo "$o/${bathname}_s$s.csv"; done)
fc=$(for s in $(seq 1 "$nref"); do echo "$o/${ctrlname}_s$s.csv"; done)
fd=$(for s in $(seq 1 "$nref"); do echo "$o/bath_dla_${stuck}_s$s.csv"; done)
fp=$(for s in $(seq 1 "$nref"); do echo "$o/bath_bpca_${stuck}_s$s.csv"; done)
window "event, sticky in a bath" $c $fb
window "control: the sticky ones alone" $c $fc
window "reference pdla DLA, $stuck particles" 0 0 $fd
window "reference BPCA, $stuck particles" 0 0 $fp
hc=$(echo $his | tr ' ' '\n' | sort -g | head -1)
echo "## every set over the common window [$lo, $hc]"
for set in "bath:$c:$fb" "control:$c:$fc" "DLA:0 0:$fd" "BPCA:0 0:$fp"; do
    name=${set%%:*} rest=${set#*:}
    echo "#   $name: $($w 2 "$lo" "$hc" ${rest%%:*} ${rest#*:} | grep '^D_f')"
done
echo "## series of the bath runs (time: stuck per seed)"
for s in $(seq 1 "$nseeds"); do
    h5dump -d /series/time -d /series/stuck "$o/${bathname}_s$s/cluster.h5" |
        awk '/DATA \{/ { on = 1; next } on && /\}/ { on = 0 }
        on { sub(/^ *\([0-9]+\): */, ""); gsub(/,/, " "); printf "%s", $0 } /DATASET "\/series\/stuck"/ { print "" }' |
        awk -v s="$s" 'NR == 1 { nt = split($0, t, " ") } NR == 2 { split($0, m, " "); printf "#   seed %s:", s;
            for (i = 1; i <= nt; i++) printf " %g:%s", t[i], m[i]; print "" }'
done
echo "## sticky gas left at the end, packing in rings around the seed (seed 1; start $eta_c)"
for set in "$bathname" "$ctrlname"; do
    python3 - "$o/${set}_s1/cluster.h5" <<'PY'
import sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r") as f:
    L = float(f["results"].attrs["box_side"])
    p = f["free/positions"][...]
    st = f["species/sticky"][...][f["free/species"][...]] != 0
d = np.hypot(p[st, 0] - L / 2, p[st, 1] - L / 2)
e = [0, 40, 60, 80, 100, 120, 140]
row = []
for a, b in zip(e, e[1:]):
    n = np.count_nonzero((d >= a) & (d < b))
    row.append(f"{a}-{b}: {n * np.pi * 0.25 / (np.pi * (b * b - a * a)):.4f}")
print(f"#   {sys.argv[1].split('/')[-2]}: " + ", ".join(row))
PY
done
if [ -n "${PICTURE:-}" ]; then # the committed picture: seed 1, bath run and control
    python3 runs/event/bath-png.py "$o/${bathname}_s1/cluster.h5" "$o/${ctrlname}_s1/cluster.h5" runs/event/bath_2d.png
fi
