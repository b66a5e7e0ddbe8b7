#!/usr/bin/env bash
# Session 6 driver (3D): serial DLA, reference-2, 2 workers, reference-4 and
# 4 workers (straggler bound on), same seeds, in chunks of 10 seeds so every
# arm runs under the same load; stops after the chunk that takes the
# children's CPU time (user + system) past BUDGET seconds (default 3300).
# Each chunk appends one line "seeds, CPU so far, uptime" to load-bias6-3d.txt.
#   nice -n 10 runs/pdla-bias/drive-bias6-3d.sh FIRST LAST
# /usr/bin first: the pyenv shim that python3 resolves to elsewhere costs
# 0.46 CPU-s per call, a quarter of a 3D run.
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH DIM=3 TARGET=1e5 PDLA=${PDLA:-/tmp/bias6bin/pdla}
first=$1 last=$2 budget=${BUDGET:-3300}
# the children's CPU: `times` run by this shell itself (in a pipeline or a
# $(...) it would run in a subshell, which has no children yet)
tf=$(mktemp)
trap 'rm -f "$tf"' EXIT
secs() { tail -1 "$tf" | awk '{split($1,u,"m"); split($2,s,"m"); printf "%d", u[1]*60+u[2]+s[1]*60+s[2]}'; }
for ((c = first; c <= last; c += 10)); do
    e=$((c + 9 > last ? last : c + 9))
    scripts/pdla-bias-ensemble serial-3d-1e5 $c $e || exit 1
    scripts/pdla-bias-ensemble ref2-3d-1e5 $c $e --reference-walkers 2 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble t2b-3d-1e5 $c $e --threads 2 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble ref4-3d-1e5 $c $e --reference-walkers 4 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble t4b-3d-1e5 $c $e --threads 4 --serial-until 1e4 || exit 1
    times >"$tf"
    used=$(secs)
    echo "$c-$e cpu ${used}s $(uptime)" >>runs/pdla-bias/load-bias6-3d.txt
    [ "$used" -ge "$budget" ] && { echo "budget reached after seed $e"; exit 0; }
done
