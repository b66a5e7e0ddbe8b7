#!/bin/sh
# h5cmp.sh OLD NEW: cluster.h5 datasets (monomers, clusters, series) identical on fixed seeds
# and /results/history_digest (the last two: N > 65536, so /monomers is written in more than one piece; W=DIR: work folder)
old=$1 new=$2; w=${W:-/tmp/dlca4mem/cmp}; rm -rf $w; mkdir -p $w; fails=0; dfails=0; n=0
while read -r args; do
  n=$((n+1))
  nice -n 10 $old --model dlca $args --out $w/o$n -q --force >/dev/null 2>&1 || echo "old failed: $args"
  nice -n 10 $new --model dlca $args --out $w/n$n -q --force >/dev/null 2>&1 || echo "new failed: $args"
  for ds in /monomers /clusters /series; do
    h5diff $w/o$n/cluster.h5 $w/n$n/cluster.h5 $ds $ds >/dev/null 2>&1 || { echo "DIFF $ds: $args"; fails=$((fails+1)); }
  done
  dg_o=$(h5dump -a /results/history_digest $w/o$n/cluster.h5 2>/dev/null | grep '(0)')
  dg_n=$(h5dump -a /results/history_digest $w/n$n/cluster.h5 2>/dev/null | grep '(0)')
  [ -n "$dg_o" ] && [ "$dg_o" = "$dg_n" ] || { echo "DIFF digest: $args"; dfails=$((dfails+1)); }
done <<'LIST'
--box 256 --fill 0.05 --until-clusters 50 --seed 1
--box 256 --fill 0.01 --mobility -0.5 --until-clusters 20 --seed 2
--box 200x120 --fill 0.05 --sticking 0.5 --until-clusters 30 --seed 3
--box 256 --fill 0.05 --drift 0.1 --until-clusters 30 --seed 4
--box 256 --fill 0.05 --search boxes --until-clusters 50 --seed 1
--box 128 --fill 0.05 --search allpairs --until-clusters 50 --seed 5
--dim 3 --box 48 --fill 0.05 --mobility -0.5 --until-clusters 20 --seed 2
--dim 3 --box 40 --fill 0.05 --search boxes --sticking 0.7 --until-clusters 20 --seed 6
--dim 4 --box 16 --fill 0.05 --until-clusters 20 --seed 7
--dim 5 --box 8 --fill 0.05 --mobility 0.5 --until-clusters 10 --seed 8
--box 1024 --fill 0.05 --until-clusters 1000 --seed 9
--dim 3 --box 128 --fill 0.15 --max-attempts 300000 --seed 3
--box 2048 --fill 0.07 --until-clusters 20000 --seed 4
LIST
echo "$n runs, $fails datasets differ, $dfails history digests differ"
