#!/bin/sh
# chunks.sh BIN FIRST_SEED CHUNKS M: 2D paired ensembles, 2 workers against the
# race-free reference of 2 walkers (2e3 serial -> 2e4), M pairs a chunk, fresh seeds
# FIRST_SEED + k*M; one line per chunk with the sums (pool.py pools them).
bin=$1 first=$2 chunks=$3 m=$4
k=0
while [ "$k" -lt "$chunks" ]; do
    s0=$((first + k * m))
    printf '%s load %s\n' "$(date -u +%H:%M:%S)" "$(cut -d' ' -f1 /proc/loadavg)"
    "$bin" pair 2 "$m" 2e4 2e3 2 0 1 2 0.01 "$s0" 2>&1 | grep -v '^[0-9]* checks'
    k=$((k + 1))
done
