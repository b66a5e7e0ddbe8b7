#!/bin/sh
# Interleaved CPU-time comparison of two pdla binaries (event5, 2026-11-24).
# usage: speed-compare5.sh OLD NEW ROUNDS "dim N t_max packing [start]" ...
# Each spec runs OLD then NEW, ROUNDS times over the whole list (so the two
# binaries see the same machine load); prints the CLI's own `cpu` line
# (clock(): the process's CPU time, placement excluded). Periodic gas,
# sticking off, seed 5. start: random (default) or lattice.
old=$1 new=$2 rounds=$3
shift 3
specs=""
for sp in "$@"; do specs="$specs$sp;"; done
out=${TMPDIR:-/tmp}/speed-compare5.$$
for r in $(seq 1 "$rounds"); do
  IFS=';'
  for spec in $specs; do
    unset IFS
    set -- $spec
    st=${5:-random}
    for b in "$old" "$new"; do
      printf "round %s %s dim %s N %s t %s packing %s start %s: " "$r" "$(basename "$b")" $1 $2 $3 $4 "$st"
      nice -n 10 "$b" --model event --dim $1 --particles $2 --packing $4 --box-walls periodic \
        --seed-radius 0 --start "$st" --t-max $3 --series-dt $3 --seed 5 --out "$out" --force |
        grep -E "^(stuck|cpu)" | tr '\n' ' '
      echo
    done
    IFS=';'
  done
  unset IFS
done
rm -rf "$out"
