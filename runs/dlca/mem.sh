#!/bin/sh
# peak RSS (KB) of pdla --model dlca --no-output, before/after binaries interleaved
for a in "--dim 2 --box 512x512 --fill 0.05" "--dim 2 --box 1024x1024 --fill 0.05" "--dim 3 --box 64x64x64 --fill 0.05" "--dim 3 --box 128x128x128 --fill 0.05" "--dim 2 --box 2048x2048 --fill 0.05 --max-attempts 200000"; do
  for b in before after; do
    printf '%s %s: ' "$b" "$a"
    /usr/bin/time -f "maxrss_kb %M user_s %U" nice -n 10 ./pdla-$b --model dlca $a --until-clusters 100 --seed 1 --no-output 2>&1 | awk '/N =/{n=$0} /stop:/{st=$2} /maxrss/{print n, st, $0}'
  done
done
