#!/bin/bash
# m12-smaps.sh BIN OUT: run 2D 1e7 seed 1, keep the last smaps snapshot (Rss per mapping)
"$1" --dim 2 --target 1e7 --seed 1 --no-output -q &
pid=$!
while kill -0 $pid 2>/dev/null; do
  awk '/^[0-9a-f]+-[0-9a-f]+ /{name=$0} /^Rss:/{print $2, name}' /proc/$pid/smaps > $2.tmp 2>/dev/null && mv $2.tmp $2
  sleep 1
done
