#!/bin/sh
# usage: th_cases.sh BIN
B=$1
$B dim 2 particles 3000 packing 0.3 box-walls periodic seed-radius 0 max-events 400000 seed 3
$B dim 3 particles 3000 packing 0.3 box-walls periodic seed-radius 0 max-events 400000 seed 3
$B dim 2 particles 3000 packing 0.05 box-walls elastic seed-radius 1 seed 4
$B dim 3 particles 2000 packing 0.1 box-walls elastic seed-radius 1 stick-p 0.5 seed 4
$B dim 2 particles 20000 packing 0.2 box-walls elastic seed-radius 0 t-max 3 velocities fixed seed 9
$B dim 3 particles 500 packing 0.4 box-walls periodic seed-radius 0 start lattice max-events 300000 seed 1
