#!/usr/bin/env bash
# Session 9 (lead): is the residual of 8 oversubscribed workers (-0.12% vs
# serial DLA at 2D 1e5, session 8) made by time slicing (walkers descheduled
# mid-walk) or by true concurrency (two walkers running at once on 2 cores)?
# The same workers all pinned to ONE core (taskset -c 1): only time slicing
# remains, no two walkers ever run at the same time. Arms: 8 and 2 workers on
# one core, paired seed by seed with serial-2d-1e5 (same serial law, session 8).
# Binary: release build of main 497db3a; /work/big/bin9/pdla-core1 is
#   exec taskset -c 1 /work/big/bin9/pdla "$@"
#   nice -n 15 runs/pdla-bias/drive-bias9-onecore.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH PDLA=${PDLA:-/work/big/bin9/pdla-core1}
first=$1 last=$2
for ((c = first; c <= last; c += 20)); do
    e=$((c + 19 > last ? last : c + 19))
    scripts/pdla-bias-ensemble t8one-2d-1e5 "$c" "$e" --threads 8 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble t2one-2d-1e5 "$c" "$e" --threads 2 --serial-until 1e4 || exit 1
done
