#!/bin/bash
# export.sh BUILD - peak RSS and CPU of `pdla export` on 10^7 and 1.5x10^5
# rows (README, "pdla export"), as in runs/formats/NOTES.md: the synthetic
# files of tests/tools/tools_fixture (huge: 2D, 10^7 rows, 80 MB; big: 2D,
# 150000 rows), each export twice, /usr/bin/time's user and sys CPU and
# peak RSS (KB = KiB).
set -eu
B=${1:?usage: export.sh BUILD}
t=$(mktemp -d /tmp/export-rss.XXXXXX)
trap 'rm -rf "$t"' EXIT
"$B/tests/tools/tools_fixture" synth huge "$t/huge.h5"
"$B/tests/tools/tools_fixture" synth big "$t/big.h5"
for round in 1 2; do
    for job in "huge ply" "huge csv" "huge xyz" "big ply"; do
        set -- $job
        /usr/bin/time -o "$t/time" -f "%U user %S sys %M KB" "$B/pdla" export "$t/$1.h5" -o "$t/out.$2"
        echo "round $round: pdla export $1.h5 -o out.$2: $(cat "$t/time"), $(stat -c %s "$t/out.$2") bytes"
        rm -f "$t/out.$2"
    done
done
