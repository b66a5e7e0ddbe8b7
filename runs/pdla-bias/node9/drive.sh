#!/usr/bin/env bash
# Session 9 (node9): the delayed-frontier probe through the test hook
# node_work (each frontier particle's node work sleeps 500 us), 8 workers,
# 2D 1e4 -> 3e4, paired with serial DLA of the same seeds, for the engine as
# fixed (node work inside the bucket mutex) and with the fix switched off
# (hook node_before_bucket: node work before the bucket mutex, as on main).
#   runs/pdla-bias/node9/drive.sh FIRST CHUNKS PER_CHUNK   (build/ is release)
cd "$(dirname "$0")/../../.."
first=$1 chunks=$2 per=$3
out=runs/pdla-bias/node9
for mode in fixed before; do
    for ((c = 0; c < chunks; c++)); do
        s=$((first + c * per))
        nice -n 10 build/tests/physics/test_frontier 2 "$per" 3e4 1e4 8 500 0.01 "$mode" "$s" \
            > "$out/xs500-$mode-$s.tsv" 2> "$out/xs500-$mode-$s.log" &
    done
done
wait
