#!/bin/bash
# speed-ab11.sh - interleaved CPU-time comparison of pdla binaries (session
# 11, 2026-11-25). Usage:
#   speed-ab11.sh REPS "LABEL:ENV:BINARY" ... -- "DIM N T_MAX" ...
# For each repeat, each case, each binary in turn (so all see the same load):
# periodic gas, sticking off, packing 0.3, random start, Maxwell-Boltzmann,
# seed 5; ENV is one VAR=VALUE put in the environment (X=1 for none).
# Prints: rep label dim N t_max collisions engine_cpu_s us/coll M/s, where
# engine_cpu_s is the CLI's `cpu` (clock(), placement excluded).
reps=$1; shift
vars=(); while [ "$1" != "--" ]; do vars+=("$1"); shift; done; shift; cases=("$@")
for rep in $(seq 1 "$reps"); do for c in "${cases[@]}"; do set -- $c
  for v in "${vars[@]}"; do IFS=: read -r lab envs bin <<< "$v"
    out=$(env $envs nice -n 10 $bin --model event --dim $1 --particles $2 --packing 0.3 --box-walls periodic \
          --seed-radius 0 --t-max $3 --series-dt $3 --seed 5 --out ${TMPDIR:-/tmp}/ab11_$lab --force --no-progress 2>&1)
    coll=$(echo "$out" | sed -n 's/.*events \([0-9]*\), collisions \([0-9]*\),.*/\2/p')
    cpu=$(echo "$out" | sed -n 's/^cpu \([0-9.]*\) s.*/\1/p')
    echo "$rep $lab $1 $2 $3 $coll $cpu $(awk -v c="$coll" -v u="$cpu" 'BEGIN{printf "%.3f us/coll %.3f M/s", 1e6*u/c, c/u/1e6}')"
  done; done; done
