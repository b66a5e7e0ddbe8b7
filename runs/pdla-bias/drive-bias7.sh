#!/usr/bin/env bash
# Session 7 (lead): 2D, 1e4 -> 1e5, on the loaded 2-core VM (oversubscribed):
# 8 workers, the race-free reference of 8 walkers, and 32 workers, on the
# seeds of the serial arm (serial-2d-1e5, 1001..2543), in alternating chunks
# of 20 seeds so the arms advance together; binary of main 999a772.
#   nice -n 15 runs/pdla-bias/drive-bias7.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH PDLA=${PDLA:-/work/big/bias7bin/pdla}
first=$1 last=$2
for ((c = first; c <= last; c += 20)); do
    e=$((c + 19 > last ? last : c + 19))
    scripts/pdla-bias-ensemble t8b-2d-1e5 "$c" "$e" --threads 8 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble ref8-2d-1e5 "$c" "$e" --reference-walkers 8 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble t32b-2d-1e5 "$c" "$e" --threads 32 --serial-until 1e4 || exit 1
done
