#!/bin/bash
# interleaved old/new bench-event-cost, 2D and 3D at packing 0.3, 1e4 and 1e6, scale 4
for rep in 1 2; do
  for b in /tmp/b-old /tmp/b32; do
    echo "# build $b rep $rep"
    scripts/bench-event-cost $b 1 4 "10000 1000000" 0.3 "2 3" | tail -n +2
  done
done
