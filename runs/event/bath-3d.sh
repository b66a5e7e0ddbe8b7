#!/usr/bin/env bash
# bath-3d.sh - the DLA-like window in 3D: a dilute sticky kind diffusing
# through a dense bath of a kind that never sticks (STICKY 0), against the
# same sticky spheres without the bath (the control), pdla's 3D DLA and 3D
# ballistic particle-cluster aggregation (BPCA, ballistic.c) of the same
# mass; mass-radius D_f around the seed (window.c). The 3D twin of bath.sh.
# From the repository root after `ninja -C build`:
#   nice -n 10 runs/event/bath-3d.sh NSTICKY NBATH PACKING STUCK SEEDS REFSEEDS > runs/event/bath-3d.txt
# Bath runs of seeds 1..SEEDS; control, DLA and BPCA of seeds 1..REFSEEDS.
# Every sphere radius 0.5 and density 1 (sticky and bath alike: one mean
# free path), p = 1, elastic walls, Maxwell-Boltzmann kT = 1, seed radius
# 0.5, stop at STUCK stuck. PACKING is the total; the control has only the
# NSTICKY sticky ones in the same box. Window: r from LO (default max(2
# lambda, 2): in 3D the clusters this CPU allows are small, so the inner end
# is 2 diameters, not bath.sh's 4) to 0.4 R_max (smallest R_max of the
# set's seeds), lambda the bath run's dilute mean free path (`pdla info`);
# then every set over the common window [LO, smallest upper end], and a
# fixed window HI (default unset) if given. Errors: sd / sqrt(seeds).
# REUSE=1: analyse the runs already in runs/event/out (made by this command).
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
echo "# 3D: $ns sticky + $nb bath at packing $eta (control: $ns sticky alone, packing $eta_c), stop at $stuck stuck, seeds 1..$nseeds (control and references 1..$nref)"
get() { echo "$2" | awk -v k="$1" '$1 == k { print $2 }'; }
run() { # run NAME SEED SPECIES PACKING: one event run (or REUSE), its csv, a line on it
    local dir=$o/$1_s$2
    local cmd="$b --model event --dim 3 --species $3 --packing $4 --seed $2 --max-stuck $stuck --series-dt 100 --out $dir --force --no-progress"
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
bathname=bath_3d_n${ns}_b${nb}_p${eta}_m$stuck
ctrlname=ctrl_3d_n${ns}_p${eta_c}_m$stuck
for s in $(seq 1 "$nseeds"); do run "$bathname" "$s" "$ns:0.5:1,$nb:0.5:1:0" "$eta"; done
for s in $(seq 1 "$nref"); do run "$ctrlname" "$s" "$ns:0.5:1" "$eta_c"; done
for s in $(seq 1 "$nref"); do
    f=$o/bath3_dla_${stuck}_s$s
    [ -n "${REUSE:-}" ] && [ -f "$f.csv" ] || {
        $b --dim 3 --target "$stuck" --threads 1 --arrival --seed "$s" --rg-per-decade 0 --out "$f.tmp" >/dev/null
        $b export "$f.tmp/cluster.h5" -o "$f.csv" --force >/dev/null
        rm -rf "$f.tmp"
    }
    [ -n "${REUSE:-}" ] && [ -f "$o/bath3_bpca_${stuck}_s$s.csv" ] ||
        build/ballistic bpca 3 "$stuck" "$s" "$o/bath3_bpca_${stuck}_s$s.csv" >/dev/null
done
info=$($b info "$o/${bathname}_s1/cluster.h5")
lam=$(get mean_free_path_over_diameter "$info") L=$(get box_side "$info")
c=$(awk -v L="$L" 'BEGIN { printf "%.17g %.17g %.17g", L / 2, L / 2, L / 2 }')
lo=${LO:-$(awk -v l="$lam" 'BEGIN { printf "%.3g", (2 * l > 2 ? 2 * l : 2) }')}
his=
hi_of() { $w 3 1 2 "$@" | awk '$1 == "file" { print $6 }' | sort -g | head -1 | awk '{ printf "%.3g", 0.4 * $1 }'; }
window() { # window TITLE CENTRE(3 words) FILES...: the set's window [lo, 0.4 min R_max] and profile
    local title=$1 cx=$2 cy=$3 cz=$4
    shift 4
    local hi
    hi=$(hi_of "$cx" "$cy" "$cz" "$@")
    his="$his $hi"
    echo "## $title, window [$lo, $hi] (r/lambda in the last column, lambda $lam)"
    $w 3 "$lo" "$hi" "$cx" "$cy" "$cz" "$@" | grep -v '^file' |
        awk -v l="$lam" '$1 == "r" { print $0, "  r/lambda"; next } $1 + 0 > 0 { printf "%s %9.2f\n", $0, $1 / l; next } { print }'
    $w 3 "$lo" "$hi" "$cx" "$cy" "$cz" "$@" | awk '$1 == "file" { printf "#   %s\n", $0 }'
}
fb=$(for s in $(seq 1 "$nseeds"); do echo "$o/${bathname}_s$s.csv"; done)
fc=$(for s in $(seq 1 "$nref"); do echo "$o/${ctrlname}_s$s.csv"; done)
fd=$(for s in $(seq 1 "$nref"); do echo "$o/bath3_dla_${stuck}_s$s.csv"; done)
fp=$(for s in $(seq 1 "$nref"); do echo "$o/bath3_bpca_${stuck}_s$s.csv"; done)
window "event, sticky in a bath" $c $fb
window "control: the sticky ones alone" $c $fc
window "reference pdla DLA, $stuck particles" 0 0 0 $fd
window "reference BPCA, $stuck particles" 0 0 0 $fp
hc=$(echo $his | tr ' ' '\n' | sort -g | head -1)
for win in "$lo $hc" ${HI:+"$lo $HI"}; do
    echo "## every set over the window [${win% *}, ${win#* }]"
    for set in "bath:$c:$fb" "control:$c:$fc" "DLA:0 0 0:$fd" "BPCA:0 0 0:$fp"; do
        name=${set%%:*} rest=${set#*:}
        echo "#   $name: $($w 3 ${win% *} ${win#* } ${rest%%:*} ${rest#*:} | grep '^D_f')"
    done
done
echo "## series of the bath runs (time: stuck per seed)"
for s in $(seq 1 "$nseeds"); do
    h5dump -d /series/time -d /series/stuck "$o/${bathname}_s$s/cluster.h5" |
        awk '/DATA \{/ { on = 1; next } on && /\}/ { on = 0 }
        on { sub(/^ *\([0-9]+\): */, ""); gsub(/,/, " "); printf "%s", $0 } /DATASET "\/series\/stuck"/ { print "" }' |
        awk -v s="$s" 'NR == 1 { nt = split($0, t, " ") } NR == 2 { split($0, m, " "); printf "#   seed %s:", s;
            for (i = 1; i <= nt; i++) printf " %g:%s", t[i], m[i]; print "" }'
done
echo "## sticky gas left at the end, packing in shells around the seed (seed 1; start $eta_c)"
for set in "$bathname" "$ctrlname"; do
    python3 - "$o/${set}_s1/cluster.h5" <<'PY'
import sys
import h5py
import numpy as np
with h5py.File(sys.argv[1], "r") as f:
    L = float(f["results"].attrs["box_side"])
    p = f["free/positions"][...]
    st = f["species/sticky"][...][f["free/species"][...]] != 0
d = np.sqrt(((p[st, :3] - L / 2) ** 2).sum(axis=1))
e = [0, 5, 10, 15, 20, 25, 30]
row = []
for a, b in zip(e, e[1:]):
    n = np.count_nonzero((d >= a) & (d < b))
    row.append(f"{a}-{b}: {n * (np.pi / 6) / (4 / 3 * np.pi * (b ** 3 - a ** 3)):.4f}")
print(f"#   {sys.argv[1].split('/')[-2]}: " + ", ".join(row))
PY
done
