#!/usr/bin/env bash
# Session 8 (lead): 2D, 1e4 -> 1e5, on the shared 2-core VM: new seeds
# 2544.. for the serial arm and for 8 and 32 workers (straggler bound on, as
# shipped), in alternating chunks of 20 seeds so the arms advance together;
# binary of main 556bb55. The serial arm's earlier seeds came from session
# 3's binary; serial8-check holds seeds re-grown with this binary to show the
# two serial binaries give the same clusters (same jumps, same R_g digits).
#   nice -n 15 runs/pdla-bias/drive-bias8.sh FIRST LAST
cd "$(dirname "$0")/../.."
export PATH=/usr/bin:$PATH PDLA=${PDLA:-/work/big/bias8bin/pdla}
first=$1 last=$2
for s in 1001 1077 1234 1500 1789 2001 2222 2543; do
    scripts/pdla-bias-ensemble serial8-check "$s" "$s" || exit 1
done
for ((c = first; c <= last; c += 20)); do
    e=$((c + 19 > last ? last : c + 19))
    scripts/pdla-bias-ensemble serial-2d-1e5 "$c" "$e" || exit 1
    scripts/pdla-bias-ensemble t8b-2d-1e5 "$c" "$e" --threads 8 --serial-until 1e4 || exit 1
    scripts/pdla-bias-ensemble t32b-2d-1e5 "$c" "$e" --threads 32 --serial-until 1e4 || exit 1
done
