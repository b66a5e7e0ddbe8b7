#!/bin/sh
# 2D 4096^2 1% seed 1: both binaries resume the same checkpoint (N_c 10000, attempt 52515254)
# for 30 M attempts; interleaved, nice 10; user CPU and peak RSS.
# make the checkpoint first: ./pdla-old --model dlca --box 4096 --fill 0.01 --until-clusters 10000 --seed 1 --checkpoint --out /tmp/dlca7-ck4096
# (session 7, runs/dlca/memory.txt); binaries ./pdla-old ./pdla-new (or BIN_PREFIX).
for rep in 1 2; do
for b in old new; do
  rm -rf /tmp/dlca7-r4096; cp -r /tmp/dlca7-ck4096 /tmp/dlca7-r4096
  printf '%s 4096^2 resume 52.5M->82.5M: ' $b
  /usr/bin/time -f "user %U sys %S maxrss_kb %M" nice -n 10 ${BIN_PREFIX:-./pdla-}$b --model dlca --resume /tmp/dlca7-r4096/checkpoint.h5 --until-clusters 100 --max-attempts 82515254 -q 2>&1 | tr '\n' ' '
  ${BIN_PREFIX:-./pdla-}new info /tmp/dlca7-r4096/cluster.h5 | awk '$1=="n_clusters"||$1=="history_digest"||$1=="monomer_moves"{printf "%s %s ", $1, $2}'
  echo
done
done
