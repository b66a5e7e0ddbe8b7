#!/bin/bash
# pair.sh DIM N SEEDS...: main (/tmp/bin_main, 4eac629) and this build (/tmp/bin_new)
# at the same time, one pair per seed, alternating which starts first.
# One line per run: label,seed,dim,N,user s,peak RSS KiB,jumps/particle,ns/jump,R_g.
m=$(dirname "$0")/../ab_measure.py
dim=$1 n=$2
shift 2
r=0
for s in "$@"; do
  r=$((r + 1))
  if [ $((r % 2)) = 1 ]; then
    python3 "$m" /tmp/bin_main main "$dim" "$n" "$s" & python3 "$m" /tmp/bin_new new "$dim" "$n" "$s" & wait
  else
    python3 "$m" /tmp/bin_new new "$dim" "$n" "$s" & python3 "$m" /tmp/bin_main main "$dim" "$n" "$s" & wait
  fi
done
