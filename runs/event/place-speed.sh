#!/bin/sh
# place-speed.sh OLD NEW ROUNDS - user CPU of random placement, old and new
# binaries interleaved (A B A B per case and round). The run stops at
# t = 1e-4 (a few hundred events), so the process's user CPU is placement,
# the sort by cell, the first predictions and the output; "cpu" is the
# engine's own. Periodic gas, sticking off, Maxwell-Boltzmann, seed 5.
# Also checks that both put the particles at the same positions
# (h5diff of /free/positions and /free/velocities at the end).
set -eu
old=$1 new=$2 rounds=${3:-2}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf "%-5s %-3s %-8s %-7s %-4s %-8s %-8s %-8s %s\n" round dim N packing bin user_s engine_s RSS_MB same
for r in $(seq 1 "$rounds"); do
    for c in "3 10000 0.3" "3 100000 0.3" "3 1000000 0.3" "2 10000 0.3" "2 100000 0.3" "2 1000000 0.3" \
             "3 1000000 0.05" "2 1000000 0.05" "2 1000000 0.5"; do
        set -- $c
        for b in old new; do
            bin=$old; [ $b = new ] && bin=$new
            out=$(nice -n 10 /usr/bin/time -f "TIME %U %M" "$bin" --model event --dim "$1" --particles "$2" \
                  --packing "$3" --box-walls periodic --seed-radius 0 --t-max 1e-4 --series-dt 1e-4 --seed 5 \
                  --out "$tmp/$b" --force --no-progress 2>&1)
            cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
            same=-
            if [ $b = new ]; then
                same=yes
                for d in /free/positions /free/velocities; do
                    h5diff "$tmp/old/cluster.h5" "$tmp/new/cluster.h5" $d $d >/dev/null 2>&1 || same=NO
                done
            fi
            echo "$out" | awk -v r="$r" -v d="$1" -v n="$2" -v p="$3" -v b="$b" -v c="$cpu" -v s="$same" \
                '$1 == "TIME" { printf "%-5s %-3s %-8s %-7s %-4s %-8s %-8s %-8.1f %s\n", r, d, n, p, b, $2, c, $3 / 1024, s }'
        done
    done
done
