#!/bin/bash
# 2D 2e3 -> 3e4, serial vs 8 workers on one CPU, straggler factor 8 (shipped) and 1 (amplified)
export PATH=/usr/bin:$PATH TARGET=3e4
for ((c = 1000; c < 1800; c += 40)); do
  PDLA=/work/big/bf8/pdla scripts/pdla-bias-ensemble s-3e4 $c $((c+39)) --serial-until 2000
  PDLA=/work/big/b10/core1-f8.sh scripts/pdla-bias-ensemble o8f8-3e4 $c $((c+39)) --threads 8 --serial-until 2000
  PDLA=/work/big/b10/core1-f1.sh scripts/pdla-bias-ensemble o8f1-3e4 $c $((c+39)) --threads 8 --serial-until 2000
done
