#!/bin/sh
# Session 8 (branch evspeed8, 2026-11-25): the commands behind
# speed-session8.txt and the session-8 section of speed.md.
# usage: speed-session8.sh OLD_PDLA NEW_PDLA [ROUNDS]
# 1. bit-identity: tracehash over the six cases, against tracehash-event5.txt
#    (build the tracehash binary against the library being checked first:
#    gcc -O2 -std=c11 -Iinclude -Isrc -Ibuild runs/event/tracehash.c build/libpdla.a \
#        $(pkg-config --libs hdf5) -lhwloc -lpng -lm -lpthread -o /tmp/th
#    sh runs/event/tracehash-cases.sh /tmp/th | diff - runs/event/tracehash-event5.txt)
# 2. callgrind of the event loop (instructions, simulated branch mispredicts), N = 1e4:
# 3. CPU time, old and new interleaved (speed-compare5.sh), 1e4 .. 1e6, 2D and 3D.
old=$1 new=$2 rounds=${3:-2}
here=$(dirname "$0")
for b in "$old" "$new"; do
  for c in "3 2" "2 8"; do
    set -- $c
    nice -n 10 valgrind --tool=callgrind --branch-sim=yes --toggle-collect=ev_loop \
      --callgrind-out-file=/dev/null "$b" --model event --dim $1 --particles 10000 --packing 0.3 \
      --box-walls periodic --seed-radius 0 --start lattice --t-max $2 --series-dt $2 --seed 5 \
      --out /tmp/speed-session8.cg --force 2>&1 | grep -E "Collected" | sed "s|^==[0-9]*==|$(basename "$b") dim $1:|"
  done
done
sh "$here/speed-compare5.sh" "$old" "$new" "$rounds" \
  "3 10000 2 0.3 lattice" "3 100000 0.5 0.3 lattice" "3 1000000 0.15 0.3 lattice" \
  "2 10000 8 0.3 lattice" "2 100000 2 0.3 lattice" "2 1000000 0.6 0.3 lattice"
rm -rf /tmp/speed-session8.cg
