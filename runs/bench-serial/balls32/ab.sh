#!/bin/bash
# interleaved old/new, 3D 1e6 seeds 1-3, then 3D 1e5 seeds 1-8
M=/work/main/runs/bench-serial/ab_measure.py
for s in 1 2 3; do
  python3 $M /tmp/pdla_old old 3 1e6 $s; python3 $M /tmp/pdla_new new 3 1e6 $s
done
for s in 1 2 3 4 5 6 7 8; do
  python3 $M /tmp/pdla_old old 3 1e5 $s; python3 $M /tmp/pdla_new new 3 1e5 $s
done
for s in 1 2 3; do
  python3 $M /tmp/pdla_new new 3 1e6 $s; python3 $M /tmp/pdla_old old 3 1e6 $s
done
