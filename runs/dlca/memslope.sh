#!/bin/sh
# peak RSS (VmHWM via /usr/bin/time %M) of pdla --model dlca, binaries interleaved; prints raw KiB.
# usage: memslope.sh BIN... ; OUTPUT=1 writes cluster.h5 instead of --no-output
for a in "--dim 3 --box 128 --fill 0.01" "--dim 3 --box 256 --fill 0.01" "--dim 2 --box 512 --fill 0.05" "--dim 2 --box 1024 --fill 0.05"; do
  for b in "$@"; do
    if [ -n "$OUTPUT" ]; then o="--out ${W:-/tmp/dlca-memout} --force -q"; else o="--no-output"; fi
    printf '%s | %s | ' "$b" "$a"
    /usr/bin/time -f "maxrss_kb %M user_s %U" nice -n 10 $b --model dlca $a --until-clusters 100 --seed 1 $o 2>&1 | grep maxrss
  done
done
