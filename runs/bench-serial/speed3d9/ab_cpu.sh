#!/bin/bash
# ab_cpu.sh OLD NEW: interleaved user-CPU pairs (ab_measure.py, nice 10, seed 1):
# 3D 1e5 x4 pairs, 3D 1e6 x2 pairs, 3D 1e4 x2 pairs (RSS base); CSV on stdout.
# Columns: label,dim,N,user_s,peak_rss_KiB,jumps_per_particle,user_ns_per_jump,rg_diam
M=$(dirname "$0")/../ab_measure.py
for i in 1 2 3 4; do python3 $M "$1" old 3 100000; python3 $M "$2" new 3 100000; done
for i in 1 2; do python3 $M "$1" old 3 1000000; python3 $M "$2" new 3 1000000; done
for i in 1 2; do python3 $M "$1" old 3 10000; python3 $M "$2" new 3 10000; done
