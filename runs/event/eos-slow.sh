#!/usr/bin/env bash
# eos-slow.sh - the slow suite's equation-of-state tests (event-eos-slow-*,
# N = 1e4, tests/event/meson.build), run one by one with their CPU time.
# Each prints Z from the collision virial against Henderson (2D) or
# Carnahan-Starling (3D) and the collision rate against Enskog. Run from the
# repository root after `ninja -C build`:
#   nice -n 10 runs/event/eos-slow.sh > runs/event/eos-slow.txt 2>&1
set -u
t=build/tests/event/test_event
for a in "2 0.1 10000 400" "2 0.2 10000 300" "2 0.3 10000 200" "2 0.4 10000 150" \
         "3 0.1 10000 200" "3 0.2 10000 120" "3 0.3 10000 80" "3 0.4 10000 60"; do
    # shellcheck disable=SC2086
    /usr/bin/time -f "cpu %U s user, %M KB peak" $t eos $a 2>&1 | sed "s/^/[$a] /"
done
