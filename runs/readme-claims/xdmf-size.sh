#!/bin/bash
# xdmf-size.sh BUILD - the size of DIR/ensemble.xdmf2 a cluster (README,
# "ParaView" under the ensemble section). Real ensembles of 100 clusters of
# 1000 (2D and 3D, with and without --arrival), then the same writer
# (xdmf_write_ensemble, through tests/formats/xdmf_tool, which the test
# formats-xdmf-memory runs) for 10^6 clusters, whose row numbers have more
# digits; xdmf_tool's file is first compared with pdla's byte for byte.
set -eu
B=${1:?usage: xdmf-size.sh BUILD}
PDLA=$B/pdla TOOL=$B/tests/formats/xdmf_tool
t=$(mktemp -d /tmp/xdmf-size.XXXXXX)
trap 'rm -rf "$t"' EXIT
for dim in 2 3; do
    for arr in 0 1; do
        a=; [ $arr = 1 ] && a=--arrival
        "$PDLA" ensemble --clusters 100 --target 1000 --dim $dim --keep-positions $a --seed 1 --out "$t/e" -q
        s=$(stat -c %s "$t/e/ensemble.xdmf2")
        "$TOOL" ensemble "$t/x.xdmf2" ensemble.h5 /clusters/positions 100 1000 $dim 32 $arr >/dev/null
        cmp -s "$t/e/ensemble.xdmf2" "$t/x.xdmf2" && same=yes || same=NO
        echo "pdla ensemble ${dim}D arrival=$arr, 100 clusters of 1000: $s bytes, $(echo "scale=2; $s / 100000" | bc) kB a cluster (xdmf_tool's file the same: $same)"
        rm -rf "$t/e" "$t/x.xdmf2"
    done
done
# The smallest text (2D without arrival) and the largest (3D with).
for n in 1000 1000000; do
    for da in "2 0" "3 1"; do
        set -- $da
        "$TOOL" ensemble "$t/x.xdmf2" ensemble.h5 /clusters/positions 1000000 $n $1 32 $2 >/dev/null
        s=$(stat -c %s "$t/x.xdmf2")
        echo "xdmf_tool ${1}D arrival=$2, 10^6 clusters of $n: $s bytes, $(echo "scale=2; $s / 1000000000" | bc) kB a cluster"
        rm -f "$t/x.xdmf2"
    done
done
