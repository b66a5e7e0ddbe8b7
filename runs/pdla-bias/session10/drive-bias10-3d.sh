#!/usr/bin/env bash
# Session 10 driver (3D, 1e4 -> 1e5): 2 workers on the 2 CPUs (t2n) and 8
# workers pinned to one CPU (o8, runs/pdla-bias/pdla-core1.sh) from seed 1001,
# pairing with session 6's serial and reference-2 arms (seeds 1001-1320),
# which continue from 1321; chunks of 10 seeds so the arms share the load.
#   nice -n 15 drive-bias10-3d.sh FIRST LAST
export PATH=/usr/bin:$PATH DIM=3 TARGET=1e5
bin=${BIN:-/work/big/bin10/pdla} core1=${CORE1:-/work/big/b10/core1.sh}
first=$1 last=$2
for ((c = first; c <= last; c += 10)); do
    e=$((c + 9 > last ? last : c + 9))
    PDLA=$bin scripts/pdla-bias-ensemble serial-3d-1e5 $c $e || exit 1
    PDLA=$bin scripts/pdla-bias-ensemble ref2-3d-1e5 $c $e --reference-walkers 2 --serial-until 1e4 || exit 1
    PDLA=$bin scripts/pdla-bias-ensemble t2n-3d-1e5 $c $e --threads 2 --serial-until 1e4 || exit 1
    PDLA=$core1 scripts/pdla-bias-ensemble o8-3d-1e5 $c $e --threads 8 --serial-until 1e4 || exit 1
    echo "$c-$e $(date -u +%H:%M) $(uptime)"
done
