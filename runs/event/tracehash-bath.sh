#!/bin/sh
# tracehash-bath.sh OLD NEW - all-sticky histories against main: every
# traced event (time, pair, kind) hashed by tracehash.c built on two
# libraries, OLD (main 999a772, before bath kinds) and NEW (this branch).
# The cases of tracehash-cases.sh, then two-species runs with sticking,
# STICKY omitted (both) and STICKY 1 written out (NEW only: OLD refuses
# it); every line of a case must be the same. Build a binary with
#   cc -O2 -std=c11 -D_GNU_SOURCE -Iinclude runs/event/tracehash.c build/libpdla.a \
#      $(pkg-config --libs hdf5 hwloc) -lm -lpthread -o TH
# in a checkout of each commit. README "A bath that never sticks".
set -eu
old=$1 new=$2
for b in "$old" "$new"; do
    echo "## $b: tracehash-cases.sh"
    sh runs/event/tracehash-cases.sh "$b"
done
two() { # two BIN SPECIES1 SPECIES2
    "$1" dim 2 species "$2" packing 0.1 box-walls elastic seed-radius 1 seed 4
    "$1" dim 3 species "$3" packing 0.1 box-walls elastic seed-radius 1 stick-p 0.5 seed 6
}
echo "## $old: two species, STICKY omitted"
two "$old" 1500:0.5:1,1500:0.4:2 1000:0.5:1,800:0.35:3
echo "## $new: two species, STICKY omitted"
two "$new" 1500:0.5:1,1500:0.4:2 1000:0.5:1,800:0.35:3
echo "## $new: two species, STICKY 1 written out"
two "$new" 1500:0.5:1:1,1500:0.4:2:1 1000:0.5:1:1,800:0.35:3:1
