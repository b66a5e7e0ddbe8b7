#!/bin/bash
# paired TSan ensembles: serial vs 4 workers, 2D 2e3 -> 3e4, seeds 1000..
export PATH=/usr/bin:$PATH PDLA=/work/big/tsan/pdla TARGET=3e4 TSAN_OPTIONS=halt_on_error=1
for ((c = 1000; c < 1400; c += 20)); do
  scripts/pdla-bias-ensemble tsan-s-3e4 $c $((c+19)) --serial-until 2000
  scripts/pdla-bias-ensemble tsan-t4-3e4 $c $((c+19)) --threads 4 --serial-until 2000
done
