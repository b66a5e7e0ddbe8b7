#!/usr/bin/env bash
# Session 5, second driver: t4 with the straggler bound only (the arm the
# brief puts first), on the seeds the alternating driver will not reach.
#   nice -n 10 runs/pdla-bias/drive-bias5-bound.sh FIRST LAST
cd "$(dirname "$0")/../.."
PDLA=/tmp/bias5bin/pdla exec scripts/pdla-bias-ensemble t4b-2d-1e5 "$1" "$2" --threads 4 --serial-until 1e4
