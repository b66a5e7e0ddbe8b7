#!/bin/sh
# series-dt-timing.sh [PDLA] - the single-run timings of README's
# --series-dt paragraph (not a test): tiny series intervals against the
# default, the process's user CPU from /usr/bin/time. Default options
# otherwise (2D, default packing and seed). Output: series-dt-timing.txt.
set -eu
pdla=${1:-build/pdla}
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
one() { # LABEL ARGS...
    label=$1
    shift
    /usr/bin/time -f "TIME %U" "$pdla" --model event "$@" --out "$t/r" --force >"$t/out" 2>&1
    printf '%-34s %-44s events %-9s user %s s\n' "$label" "$*" \
        "$(sed -n 's/.*events \([0-9]*\),.*/\1/p' "$t/out")" "$(sed -n 's/^TIME //p' "$t/out")"
}
echo "# made by: runs/event/series-dt-timing.sh $pdla ($(git rev-parse --short HEAD 2>/dev/null || echo ?), $(date -u '+%Y-%m-%d %H:%M') UTC, load $(cut -d' ' -f1-3 /proc/loadavg))"
one "1e4 disks, t 1, dt 1e-9" --particles 10000 --t-max 1 --series-dt 1e-9
one "100 disks, t 1, dt 1e-300" --particles 100 --t-max 1 --series-dt 1e-300
one "1e4 disks, t 300, dt 1e-9" --particles 10000 --t-max 300 --series-dt 1e-9
one "1e4 disks, t 300, dt 1" --particles 10000 --t-max 300 --series-dt 1
one "1e5 disks, t 3, dt 1e-9" --particles 100000 --t-max 3 --series-dt 1e-9
one "1e5 disks, t 3, dt 1" --particles 100000 --t-max 3 --series-dt 1
