#!/bin/bash
# pair.sh DIM N REPS: main and compact simultaneously, REPS times, alternating which starts first
for r in $(seq 1 $3); do
  if [ $((r % 2)) = 1 ]; then
    python3 /work/main/runs/bench-serial/ab_measure.py /tmp/bin_main main $1 $2 & python3 /work/main/runs/bench-serial/ab_measure.py /tmp/bin_cm compact $1 $2 & wait
  else
    python3 /work/main/runs/bench-serial/ab_measure.py /tmp/bin_cm compact $1 $2 & python3 /work/main/runs/bench-serial/ab_measure.py /tmp/bin_main main $1 $2 & wait
  fi
done
