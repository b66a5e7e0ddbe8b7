#!/usr/bin/env bash
# Session 11 driver (3D, 1e4 -> 1e5): continues session 10's serial, reference-2
# and one-CPU 8-worker (o8) arms with the same binary (main 5b05d08, 3D walk
# bit-identical to session 6's), chunks of 10 seeds so the arms advance together.
# (Session 10's t2n arm, 2 workers on the loaded 2 CPUs, is not continued: under
# load it measures the machine, not the engine.)
#   nice -n 15 drive-bias11-3d.sh FIRST LAST
export PATH=/usr/bin:$PATH DIM=3 TARGET=1e5
bin=${BIN:-/work/big/bin10/pdla} core1=${CORE1:-/work/big/b10/core1.sh}
first=$1 last=$2
for ((c = first; c <= last; c += 10)); do
    e=$((c + 9 > last ? last : c + 9))
    PDLA=$bin scripts/pdla-bias-ensemble serial-3d-1e5 $c $e || exit 1
    PDLA=$bin scripts/pdla-bias-ensemble ref2-3d-1e5 $c $e --reference-walkers 2 --serial-until 1e4 || exit 1
    PDLA=$core1 scripts/pdla-bias-ensemble o8-3d-1e5 $c $e --threads 8 --serial-until 1e4 || exit 1
    echo "$c-$e $(date -u +%H:%M) $(uptime)"
done
