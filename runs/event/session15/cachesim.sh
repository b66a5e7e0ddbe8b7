#!/bin/sh
# cachesim.sh CKDIR T_MAX LABEL:BINARY ... - simulated cache misses of the
# event loop (callgrind --cache-sim, deterministic, unlike the VM's timings):
# each binary resumes a copy of the run directory CKDIR (a checkpoint of a
# gas already mixed, so the cost of placement is not simulated) to T_MAX;
# only ev_loop is counted. D1 48 KiB 12-way, LL 32 MiB 16-way (env LL=bytes: another size; the AMD EPYC
# VM's L1d and L3 slice), 64-byte lines. Prints per binary: label, collisions,
# instructions, D1 misses, LL misses (data), each per collision.
ck=$1 tm=$2; shift 2
for v in "$@"; do
    lab=${v%%:*} bin=${v#*:}
    d=${TMPDIR:-/tmp}/cachesim.$$.$lab
    rm -rf "$d"; cp -r "$ck" "$d"
    out=$(valgrind --tool=callgrind --cache-sim=yes --D1=49152,12,64 --LL=${LL:-33554432},16,64 \
          --toggle-collect=ev_loop --callgrind-out-file="$d.cg" "$bin" --model event --resume "$d" \
          --t-max "$tm" --no-progress 2>&1)
    coll=$(echo "$out" | sed -n 's/.*events \([0-9]*\), collisions \([0-9]*\),.*/\2/p' | head -1)
    ir=$(echo "$out" | sed -n 's/.*I *refs: *\([0-9,]*\).*/\1/p' | tr -d ,)
    d1=$(echo "$out" | sed -n 's/.*D1  misses: *\([0-9,]*\).*/\1/p' | tr -d ,)
    ll=$(echo "$out" | sed -n 's/.*LLd misses: *\([0-9,]*\).*/\1/p' | tr -d ,)
    echo "$lab coll $coll Ir/coll $(awk -v a=$ir -v c=$coll 'BEGIN{printf "%.1f", a/c}') D1miss/coll $(awk -v a=$d1 -v c=$coll 'BEGIN{printf "%.2f", a/c}') LLmiss/coll $(awk -v a=$ll -v c=$coll 'BEGIN{printf "%.2f", a/c}')"
    rm -rf "$d" "$d.cg"
done
