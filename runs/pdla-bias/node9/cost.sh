#!/usr/bin/env bash
# Session 9 (node9): CPU cost of doing the frontier's node work inside the
# bucket mutex. Interleaved old (main 497db3a) / new (this branch) release
# binaries, same seed, process CPU time (user + sys) and the mutex counters
# of --stats-json.
#   runs/pdla-bias/node9/cost.sh OLD_PDLA NEW_PDLA REPEATS > cost.tsv
old=$1 new=$2 reps=$3
printf 'case\tbinary\trep\tuser_s\tsys_s\tmax_rss_kb\trg_diam\trelaunches\ttaken(n,b,g)\tcontended\thold_ns\twait_ns\tlong_holds\tworker_cpu_s\n'
one() {
    local case=$1 tag=$2 bin=$3 rep=$4; shift 4
    local j; j=$(mktemp)
    local t; t=$( { /usr/bin/time -f '%U\t%S\t%M' nice -n 10 "$bin" "$@" --no-output -q --stats-json "$j" >/dev/null; } 2>&1 | tail -1)
    local s; s=$(/usr/bin/python3 -c "
import json,sys; d=json.load(open('$j'))
print('\t'.join(str(x) for x in (d['rg_diam'], d['relaunches'], d['mutex_taken'], d['mutex_contended'],
      [round(h / t) if t else 0 for h, t in zip(d['mutex_hold_ns'], d['mutex_taken'])], d['mutex_wait_ns'], d['mutex_long_holds'], d['worker_cpu_seconds'])))")
    printf '%s\t%s\t%s\t%s\t%s\n' "$case" "$tag" "$rep" "$t" "$s"
    rm -f "$j"
}
for ((r = 1; r <= reps; r++)); do
    for pair in "old $old" "new $new"; do
        set -- $pair
        one 2d-1e6 "$1" "$2" "$r" --dim 2 --target 1e6 --threads 2 --serial-until 1e4 --seed 1
        one 3d-1e5 "$1" "$2" "$r" --dim 3 --target 1e5 --threads 2 --serial-until 1e4 --seed 1
    done
done
