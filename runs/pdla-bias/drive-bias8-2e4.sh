#!/usr/bin/env bash
# Session 8 (lead): a cheaper, more sensitive probe of the residual -0.1%:
# 2D 1e4 -> 2e4 (half the mass is the shared serial prefix, so pairs differ
# less: pair sd ~0.7% instead of 2.15%), serial vs 8 workers (oversubscribed,
# bound on) vs the race-free reference of 2 walkers, in chunks of 50 seeds.
# Binary of main 556bb55.
#   nice -n 15 runs/pdla-bias/drive-bias8-2e4.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH PDLA=${PDLA:-/work/big/bias8bin/pdla} TARGET=2e4
first=$1 last=$2
for ((c = first; c <= last; c += 50)); do
    e=$((c + 49 > last ? last : c + 49))
    scripts/pdla-bias-ensemble serial-2d-2e4 "$c" "$e" || exit 1
    scripts/pdla-bias-ensemble t8b-2d-2e4 "$c" "$e" --threads 8 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble ref2-2d-2e4 "$c" "$e" --reference-walkers 2 --serial-until 1e4 || exit 1
done
