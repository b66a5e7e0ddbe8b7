#!/usr/bin/env bash
# Session 10: session 9's t8n question, interleaved. 8 workers on the 2 CPUs,
# 2D 1e4 -> 1e5, the binary before node9 (497db3a, bin9) and after it
# (bin9n, session 9's t8n binary), alternating in chunks of 10 seeds so both
# arms see the same load. Seeds 5001.. (fresh; arms pair with each other).
export PATH=/usr/bin:$PATH DIM=2 TARGET=1e5
first=$1 last=$2
for ((c = first; c <= last; c += 10)); do
    e=$((c + 9 > last ? last : c + 9))
    PDLA=/work/big/bin9/pdla scripts/pdla-bias-ensemble t8old-2d-1e5 $c $e --threads 8 --serial-until 1e4 || exit 1
    PDLA=/work/big/bin9n/pdla scripts/pdla-bias-ensemble t8node-2d-1e5 $c $e --threads 8 --serial-until 1e4 || exit 1
done
