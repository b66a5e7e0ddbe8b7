#!/usr/bin/env bash
# Session 5, third driver (after the second finished): t4 without the bound
# on the seeds the second driver grew with it.
#   nice -n 10 runs/pdla-bias/drive-bias5-nobound.sh FIRST LAST
cd "$(dirname "$0")/../.."
PDLA=/tmp/bias5bin/pdla-nobound exec scripts/pdla-bias-ensemble t4nb-2d-1e5 "$1" "$2" --threads 4 --serial-until 1e4
