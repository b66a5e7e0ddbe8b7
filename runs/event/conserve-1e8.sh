#!/usr/bin/env bash
# conserve-1e8.sh - the slow tests event-conserve-1e8-3d / -2d run by hand
# (test_event conserve-long DIM 1e8: N = 1e4, two species, packing 0.3,
# periodic, sticking off; energy, momentum and overlaps against bounds of
# 1e-10), with the user CPU time and peak RSS of each. From the repository
# root after `ninja -C build`:
#   nice -n 10 runs/event/conserve-1e8.sh >> runs/event/conserve-1e8.txt
set -eu
git log -1 --format='# engine of commit %h (%cd), test binary build/tests/event/test_event' --date=iso
for d in 3 2; do
    echo "# DIM $d, $(date -u +%H:%M) UTC, load average $(cut -d' ' -f1-3 /proc/loadavg):"
    /usr/bin/time -f "%U user %S sys %e wall %M KB" build/tests/event/test_event conserve-long "$d" 1e8 2>&1
done
