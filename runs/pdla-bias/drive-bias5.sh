#!/usr/bin/env bash
# Session 5 driver: t4 with the straggler bound (branch bias5) and t4 without
# it (the same code before the bound, commit ab75f05), same seeds, in chunks
# of 20 seeds alternating, so both arms run under the same load.
#   nice -n 10 runs/pdla-bias/drive-bias5.sh FIRST LAST
cd "$(dirname "$0")/../.."
first=$1 last=$2
for ((c = first; c <= last; c += 20)); do
    e=$((c + 19 > last ? last : c + 19))
    PDLA=/tmp/bias5bin/pdla scripts/pdla-bias-ensemble t4b-2d-1e5 $c $e --threads 4 --serial-until 1e4 || exit 1
    PDLA=/tmp/bias5bin/pdla-nobound scripts/pdla-bias-ensemble t4nb-2d-1e5 $c $e --threads 4 --serial-until 1e4 || exit 1
done
