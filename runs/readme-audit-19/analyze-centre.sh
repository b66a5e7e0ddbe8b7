#!/bin/sh
# analyze-centre.sh [PDLA] - README's "seeds 3..7 at 10^5: D_f of the mass
# M(r) from the seed and from the centre of mass" (pdla analyze, defaults
# otherwise). Output: analyze-centre.txt.
set -eu
pdla=${1:-build/pdla}
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
echo "# made by: runs/readme-audit-19/analyze-centre.sh $pdla ($(git rev-parse --short HEAD 2>/dev/null || echo ?), $(date -u '+%Y-%m-%d %H:%M') UTC)"
for s in 3 4 5 6 7; do
    "$pdla" --dim 2 --target 1e5 --seed $s --out "$t/c$s" -q
    a=$("$pdla" analyze "$t/c$s/cluster.h5" --json)
    b=$("$pdla" analyze "$t/c$s/cluster.h5" --centre mass --json)
    printf 'seed %s  M(r) D_f from the seed %s  from the centre of mass %s\n' $s \
        "$(echo "$a" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["mr_D_f"])')" \
        "$(echo "$b" | python3 -c 'import json,sys; print("%.3f" % json.load(sys.stdin)["mr_D_f"])')"
done
