#!/bin/sh
# cg.sh BIN TAG: callgrind instruction counts of 2D 1e5 and 3D 2e4 serial runs
BIN=$1; TAG=$2
for c in "2 100000" "3 20000"; do
  set -- $c
  nice -n 10 valgrind --tool=callgrind --callgrind-out-file=/tmp/p3cg/cg.$TAG.${1}d.out \
    $BIN --dim $1 --target $2 --seed 1 --threads 1 --no-output -q > /tmp/p3cg/log.$TAG.${1}d 2>&1
  grep -E 'Collected' /tmp/p3cg/log.$TAG.${1}d
done
