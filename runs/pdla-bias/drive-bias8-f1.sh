#!/usr/bin/env bash
# Session 8 (lead): is there compaction from walkers frozen for fewer than
# the straggler bound's 8n appends? Same seeds as t8b, 8 workers, binary of
# main 556bb55 with PDLA_STRAGGLER_FACTOR 1 instead of 8 (relaunch after more
# than n appends between two steps; the race-free reference appends at most
# n - 1 there, so it still never triggers in lockstep).
#   nice -n 15 runs/pdla-bias/drive-bias8-f1.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH PDLA=${PDLA:-/work/big/bias8f1/pdla}
scripts/pdla-bias-ensemble t8f1-2d-1e5 "$1" "$2" --threads 8 --serial-until 1e4
