#!/usr/bin/env bash
# Session 8 (lead): the straggler bound's check at the append selects where
# walkers stick. A walker whose particle needs new tree nodes or new distance-
# map cells (the frontier: ~8% of particles) takes the node mutex first, so
# it spends longer between its last step and its append, and is relaunched
# there more often (counted: 0.43% of such particles vs 0.08% of the others
# at 8 workers, 2D 1e5). Amplified here: an experimental build of 556bb55
# (/work/big/f1src, not in the repository: parallel.c sleeps X_NODE_US
# microseconds under the node mutex; X_NO_APPEND_BOUND=1 skips the bound's
# check at the append, keeping the one at every step), 2D 1e4 -> 3e4, 8 workers.
#   runs/pdla-bias/drive-bias8-node.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH TARGET=3e4
first=$1 last=$2 mid=$(( ($1 + $2) / 2 ))
X=/work/big/f1src/build/pdla
arm() { local name=$1 lo=$2 hi=$3; shift 3; env "$@" PDLA=$X scripts/pdla-bias-ensemble "$name" "$lo" "$hi" --threads 8 --serial-until 1e4 2>/dev/null; }
arm xs500b-2d-3e4 "$first" "$mid" X_NODE_US=500 & arm xs500b-2d-3e4 $((mid + 1)) "$last" X_NODE_US=500 &
arm xs500nb-2d-3e4 "$first" "$mid" X_NODE_US=500 X_NO_APPEND_BOUND=1 & arm xs500nb-2d-3e4 $((mid + 1)) "$last" X_NODE_US=500 X_NO_APPEND_BOUND=1 &
wait
PDLA=/work/big/bias8bin/pdla scripts/pdla-bias-ensemble serial-2d-3e4 "$first" "$last"
PDLA=/work/big/bias8bin/pdla scripts/pdla-bias-ensemble t8b-2d-3e4 "$first" "$last" --threads 8 --serial-until 1e4
