#!/bin/sh
# peak RSS (KiB) and user CPU of pdla --model dlca --no-output, before/after binaries interleaved.
# usage: runs/dlca/mem.sh [BEFORE AFTER]   (default ./pdla-before ./pdla-after)
before=${1:-./pdla-before} after=${2:-./pdla-after}
for a in "--dim 2 --box 512x512 --fill 0.05 --until-clusters 100" "--dim 2 --box 1024x1024 --fill 0.05 --until-clusters 100" "--dim 3 --box 64x64x64 --fill 0.05 --until-clusters 100" "--dim 3 --box 128x128x128 --fill 0.05 --until-clusters 100" "--dim 2 --box 2048x2048 --fill 0.05 --until-clusters 100" "--dim 2 --box 2048x2048 --fill 0.05 --max-attempts 200000" "--dim 2 --box 1024x1024 --fill 0.01 --mobility -0.5 --until-clusters 100"; do
  for b in "$before" "$after"; do
    printf '%s %s: ' "$b" "$a"
    /usr/bin/time -f "maxrss_kb %M user_s %U" nice -n 10 "$b" --model dlca $a --seed 1 --no-output 2>&1 | awk '/model memory/{mm=$(NF-1)} /N =/{n=$9} /stop:/{st=$2} /attempts [0-9]/{at=$2} /maxrss/{print "stop", st, "attempts", at, "model_B_per_monomer", mm, $0}'
  done
done
