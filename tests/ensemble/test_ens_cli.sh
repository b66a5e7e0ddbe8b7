#!/bin/bash
# test_ens_cli.sh - `pdla ensemble` as a user meets it.
# Usage: test_ens_cli.sh PDLA
#
#  - --threads 1, 2 and 3 give bit-identical per-cluster datasets and
#    statistics (h5diff without tolerance; timings excepted);
#  - --threads 0 (new and resumed) runs one worker per physical core: as
#    many tasks as --threads C, C the cores in /sys;
#  - kill -9 at a random moment, then --resume (with other threads): the
#    finished file equals the uninterrupted one; likewise SIGTERM, which
#    ends pdla by the signal with a line saying how to resume;
#  - bad input (M = 0, N = 0, a seed range past 2^64 - 1, an existing DIR
#    without --force, resume with other growth parameters or of a missing
#    DIR, no --clusters, --bind, checkpoints): one line, exit 2, nothing written.
set -u
PDLA=${1:?usage: test_ens_cli.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
command -v h5diff >/dev/null || { echo "h5diff not installed: skipped"; exit 77; }

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-ens-cli.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
checks=0
fails=0
fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}
run() {
    checks=$((checks + 1))
    "$PDLA" "$@" >"$tmp/out" 2>"$tmp/err" </dev/null
    rc=$?
}
bad() { # bad NAME NEEDLE ARGS...: one line with NEEDLE, exit 2, nothing written
    local name=$1 needle=$2
    shift 2
    local before
    before=$(ls -laR --time-style=+%s . 2>/dev/null | grep -v ' err$\| out$\| \.$\| \.\.$\|^total ' | tr -s ' ')
    run "$@"
    [ "$rc" -eq 2 ] || fail "$name: exit status $rc, want 2 ($(cat err))"
    [ "$(wc -l <err)" -eq 1 ] || fail "$name: stderr: $(cat err)"
    grep -qF -- "$needle" err || fail "$name: message '$(cat err)', want '$needle'"
    local after
    after=$(ls -laR --time-style=+%s . 2>/dev/null | grep -v ' err$\| out$\| \.$\| \.\.$\|^total ' | tr -s ' ')
    [ "$before" = "$after" ] || fail "$name: something was written: $(diff <(echo "$before") <(echo "$after"))"
}
# Every dataset that must not depend on threads, order or interruptions.
DATA="/gyration/N /clusters/rg_diam /clusters/index /clusters/seed /clusters/particles /clusters/walkers
/clusters/jumps /clusters/rg_final_diam /clusters/r_ext_diam /clusters/D_f /clusters/D_f_err
/clusters/prefactor_diam /clusters/fit_n_lo /clusters/fit_n_hi /clusters/fit_points /clusters/positions
/statistics"
same() { # same A B WHAT: the datasets above are bit-identical
    local ds
    for ds in $DATA; do
        checks=$((checks + 1))
        # -c: h5diff exits 0 for datasets of other shapes ("not
        # comparable") and only says so with -c.
        [ -z "$(h5diff -q -c "$1/ensemble.h5" "$2/ensemble.h5" "$ds" "$ds" 2>&1)" ] ||
            fail "$3: $ds differs"
    done
    # The ParaView sidecar (kept positions): the same text.
    checks=$((checks + 1))
    cmp -s "$1/ensemble.xdmf2" "$2/ensemble.xdmf2" || fail "$3: ensemble.xdmf2 differs or is missing"
}
ARGS="--clusters 24 --target 4000 --seed 9 --keep-positions"

# ---- threads ----------------------------------------------------------------
run ensemble $ARGS --threads 1 --out t1 -q
[ "$rc" -eq 0 ] || fail "threads 1: $(cat err)"
for t in 2 3; do
    run ensemble $ARGS --threads $t --out t$t -q
    [ "$rc" -eq 0 ] || fail "threads $t: $(cat err)"
    same t1 t$t "--threads $t vs 1"
done
h5diff -q t1/ensemble.h5 t2/ensemble.h5 /clusters/cpu_seconds /clusters/cpu_seconds >/dev/null 2>&1 &&
    fail "cpu_seconds identical: the comparison cannot see differences"
# ---- --threads 0: one worker per physical core (README, Ensembles) ------------
# The workers counted from outside (the most tasks /proc/PID/task shows
# while the ensemble grows: the main thread and one per cluster grown at
# once), against --threads C with C the physical cores of the CPUs this
# process may use ((package, core) pairs in /sys, as test_bind.py counts
# them), for a new ensemble and a resume that extends it.
tasks() { # tasks ARGS...: the ensemble run in the background; its most tasks in $max, exit status in $rc
    checks=$((checks + 1))
    "$PDLA" "$@" >"$tmp/out" 2>"$tmp/err" </dev/null &
    local pid=$! n
    max=0
    while kill -0 "$pid" 2>/dev/null; do
        n=$(ls "/proc/$pid/task" 2>/dev/null | wc -l)
        [ "$n" -gt "$max" ] && max=$n
        sleep 0.01
    done
    wait "$pid"
    rc=$?
}
cores=$(/usr/bin/python3 -c '
import os
seen = set()
for c in os.sched_getaffinity(0):
    t = "/sys/devices/system/cpu/cpu%d/topology/" % c
    with open(t + "physical_package_id") as fp, open(t + "core_id") as fc:
        seen.add((fp.read().strip(), fc.read().strip()))
print(len(seen))' 2>/dev/null)
if [ -z "$cores" ] || [ ! -d /proc/self/task ]; then
    echo "skipping the --threads 0 worker count: no CPU topology in /sys or no /proc"
else
    # each worker starts on a cluster of its own at once (2 per core and 2
    # more), and each cluster grows for a tenth of a second or more
    TZ_ARGS="--clusters $((2 * cores + 2)) --target 3000 --seed 4"
    tasks ensemble $TZ_ARGS --threads 1 --out z1 -q
    one=$max
    [ "$rc" -eq 0 ] && [ "$one" -ge 2 ] || fail "--threads 1: exit $rc, $one tasks: $(cat err)"
    tasks ensemble $TZ_ARGS --threads "$cores" --out zc -q
    [ "$rc" -eq 0 ] && [ "$max" -eq $((one + cores - 1)) ] ||
        fail "--threads $cores: exit $rc, $max tasks, want $((one + cores - 1)) (--threads 1: $one): $(cat err)"
    tasks ensemble $TZ_ARGS --threads 0 --out z0 -q
    [ "$rc" -eq 0 ] && [ "$max" -eq $((one + cores - 1)) ] ||
        fail "--threads 0: exit $rc, $max tasks, want $((one + cores - 1)) ($cores physical cores): $(cat err)"
    [ -z "$(h5diff -q -c z1/ensemble.h5 z0/ensemble.h5 /statistics /statistics 2>&1)" ] ||
        fail "--threads 0: other statistics than --threads 1"
    tasks ensemble --resume z0 --clusters $((4 * cores + 4)) --threads 0 -q
    [ "$rc" -eq 0 ] && [ "$max" -eq $((one + cores - 1)) ] ||
        fail "--resume --threads 0: exit $rc, $max tasks, want $((one + cores - 1)): $(cat err)"
fi
# A different seed must change the data (the comparison can fail).
run ensemble --clusters 24 --target 4000 --seed 10 --keep-positions --threads 2 --out s10 -q
h5diff -q t1/ensemble.h5 s10/ensemble.h5 /clusters/rg_diam /clusters/rg_diam >/dev/null 2>&1 &&
    fail "seed 10 gave seed 9's ensemble"

# ---- pdla analyze of an ensemble file ---------------------------------------------
run analyze t1/ensemble.h5
[ "$rc" -eq 0 ] || fail "analyze: $(cat err)"
grep -q "^ensemble .*24 clusters of 4000 particles, 2D, seeds 9..32" out || fail "analyze: $(head -1 out)"
grep -Eq "^D_f +1\.[5-9][0-9]*, 95% interval \[1\.[0-9]+, 1\.[0-9]+\]" out || fail "analyze: no D_f line: $(cat out)"
grep -q "^correction fit" out || fail "analyze: no correction fit line"
[ "$(grep -c '^  N ' out)" -ge 10 ] || fail "analyze: fewer than 10 local slopes"
run analyze t1/ensemble.h5 --json
[ "$rc" -eq 0 ] || fail "analyze --json: $(cat err)"
/usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["clusters"]==24 and d["D_f_lo"]<=d["D_f"]<=d["D_f_hi"], d' out ||
    fail "analyze --json: $(cat out)"
bad "analyze, cluster option" "only --json applies" analyze t1/ensemble.h5 --centre mass

# ---- kill -9 at a random moment, then resume ------------------------------------
partial=0
size() { stat -c %s "$1" 2>/dev/null || echo 0; }
for attempt in 1 2 3 4 5 6; do
    rm -rf k
    "$PDLA" ensemble $ARGS --threads 2 --out k -q </dev/null >/dev/null 2>&1 &
    pid=$!
    # Wait for the first record (a record holds 4000 x 2 x 4 bytes of
    # positions; the header is under 2 kB), then kill after a random
    # 0..150 ms more: clusters of 4000 take a few ms to tens of ms each.
    for _ in $(seq 1 1000); do
        [ "$(size k/clusters.journal)" -gt 20000 ] && break
        kill -0 $pid 2>/dev/null || break
        sleep 0.01
    done
    sleep "0.$(printf '%03d' $((RANDOM % 150)))"
    kill -9 $pid 2>/dev/null
    wait $pid 2>/dev/null
    [ -f k/ensemble.h5 ] && continue # finished before the kill: try again
    [ -f k/clusters.journal ] || continue # killed before the journal existed
    run ensemble --resume k --threads 3
    [ "$rc" -eq 0 ] || { fail "resume after kill -9: $(cat err)"; continue; }
    got=$(sed -n 's/.*: \([0-9]*\) of 24 clusters recorded/\1/p' err)
    echo "kill -9 attempt $attempt: $got of 24 clusters had been recorded"
    [ -n "$got" ] && [ "$got" -gt 0 ] && [ "$got" -lt 24 ] && partial=$((partial + 1))
    same t1 k "resumed after kill -9 (attempt $attempt)"
    [ "$partial" -ge 2 ] && break
done
[ "$partial" -ge 1 ] || fail "no kill -9 landed between the first and the last cluster"

# ---- SIGTERM ------------------------------------------------------------------------
termed=0
for attempt in 1 2 3 4; do
    rm -rf g
    "$PDLA" ensemble $ARGS --threads 2 --out g -q </dev/null >/dev/null 2>gerr &
    pid=$!
    for _ in $(seq 1 1000); do
        [ "$(size g/clusters.journal)" -gt 20000 ] && break
        kill -0 $pid 2>/dev/null || break
        sleep 0.01
    done
    kill -TERM $pid
    wait $pid
    grc=$?
    [ -f g/ensemble.h5 ] && continue
    termed=1
    checks=$((checks + 1))
    [ "$grc" -eq 143 ] || fail "SIGTERM: exit status $grc, want 143"
    grep -q "resume with pdla ensemble --resume g" gerr || fail "SIGTERM: $(cat gerr)"
    run ensemble --resume g -q
    [ "$rc" -eq 0 ] || fail "resume after SIGTERM: $(cat err)"
    same t1 g "resumed after SIGTERM"
    break
done
[ "$termed" -eq 1 ] || fail "no SIGTERM landed before the end of the ensemble"

# A complete ensemble resumes to the same file (nothing to grow).
run ensemble --resume t1 -q
[ "$rc" -eq 0 ] || fail "resume of a complete ensemble: $(cat err)"
same t2 t1 "resume of a complete ensemble"

# ---- extend: --resume DIR --clusters M2 > M --------------------------------------------
# 10 clusters, extended to 24 (with other threads), equals the 24 grown at once.
run ensemble --clusters 10 --target 4000 --seed 9 --keep-positions --threads 2 --out x -q
[ "$rc" -eq 0 ] || fail "10 clusters: $(cat err)"
run ensemble --resume x --clusters 24 --threads 3
[ "$rc" -eq 0 ] || fail "extend to 24: $(cat err)"
grep -q "resuming x: 10 of 24 clusters recorded (extended)" err || fail "extend: $(cat err)"
same t1 x "10 clusters extended to 24"
h5dump -a /ensemble/clusters x/ensemble.h5 | grep -q "(0): 24$" || fail "extend: /ensemble clusters is not 24"
# The extension is crash-safe: kill -9 at a random moment (before or after
# the journal is rewritten for 24), then the same command again.
rm -rf y
run ensemble --clusters 6 --target 4000 --seed 9 --keep-positions --out y -q
"$PDLA" ensemble --resume y --clusters 24 --threads 2 -q </dev/null >/dev/null 2>&1 &
pid=$!
sleep "0.$(printf '%03d' $((RANDOM % 300)))"
kill -9 $pid 2>/dev/null
wait $pid 2>/dev/null
run ensemble --resume y --clusters 24 -q
[ "$rc" -eq 0 ] || fail "resume of a killed extension: $(cat err)"
same t1 y "extension killed, then resumed"
run ensemble --clusters 2 --target 100 --seed 18446744073709551610 --out big -q
[ "$rc" -eq 0 ] || fail "ensemble at the top of the seed range: $(cat err)"
bad "extend past the seed range" "cannot extend to --clusters 9" ensemble --resume big --clusters 9

# ---- bad input --------------------------------------------------------------------------
bad "M = 0" "--clusters: must be at least 1" ensemble --clusters 0 --target 100 --out b1
bad "N = 0" "target" ensemble --clusters 2 --target 0 --out b1
bad "seed overflow" "seed range overflows" ensemble --clusters 3 --target 100 --seed 18446744073709551614 --out b1
bad "no --clusters" "--clusters M is required" ensemble --target 100 --out b1
bad "no --out" "--out DIR is required" ensemble --clusters 2 --target 100
bad "existing dir" "already exists" ensemble --clusters 2 --target 100 --out t1
bad "resume, other target" "--target 4000, asked 5000" ensemble --resume t1 --target 5000
bad "resume, other dim" "--dim" ensemble --resume t1 --dim 3
bad "resume, fewer clusters" "--clusters 24, asked 23 (an ensemble can be extended, not shrunk)" ensemble --resume t1 --clusters 23
bad "resume, missing dir" "cannot resume" ensemble --resume nowhere
mkdir -p b0 # an existing directory without a journal (b0 was never made before: the line tested a missing one again)
bad "resume, no journal" "clusters.journal" ensemble --resume b0
rmdir b0
bad "stats-json" "--stats-json does not apply to an ensemble" ensemble --clusters 2 --target 100 --stats-json s.json --out b1
bad "no-output" "--no-output" ensemble --clusters 2 --target 100 --no-output --out b1
bad "bind" "--bind" ensemble --clusters 2 --target 100 --bind core --out b1
bad "checkpoints" "checkpoints do not apply" ensemble --clusters 2 --target 100 --checkpoint-every 10 --out b1
bad "checkpoint-every 0 on resume" "checkpoints do not apply" ensemble --resume t1 --checkpoint-every 0
bad "unknown option" "unknown" ensemble --clusters 2 --target 100 --clusterz 3 --out b1
bad "threads without a value" "--threads needs a value" ensemble --clusters 2 --target 100 --out b1 --threads
bad "threads out of range" "threads" ensemble --clusters 2 --target 100 --out b1 --threads -3
# --threads is the clusters grown at once, not a cluster's workers: it goes
# with --reference-walkers (refused as "2 worker threads" until session 26),
# and clusters 1 and 2 are those of --threads 1.
for t in 1 2; do
    run ensemble --clusters 2 --target 1000 --reference-walkers 3 --serial-until 300 --keep-positions --threads $t \
        --out rw$t -q
    [ "$rc" -eq 0 ] || fail "--reference-walkers 3 with --threads $t: exit $rc: $(cat err)"
done
h5diff -q rw1/ensemble.h5 rw2/ensemble.h5 /clusters/positions /clusters/positions >/dev/null ||
    fail "--reference-walkers 3: --threads 2 grew other clusters than --threads 1"
# A scene's `threads` key means the same (it went to the growth options,
# refused beside reference-walkers, until session 27); the command line's
# --threads overrides it.
printf 'threads = 2\nreference-walkers = 3\nserial-until = 300\ntarget = 1000\n' > rw.scene
run ensemble --scene rw.scene --clusters 2 --keep-positions --out rws -q
[ "$rc" -eq 0 ] || fail "scene threads = 2 with reference-walkers = 3: exit $rc: $(cat err)"
h5diff -q rw1/ensemble.h5 rws/ensemble.h5 /clusters/positions /clusters/positions >/dev/null ||
    fail "scene threads = 2: other clusters than --threads 1"
printf 'threads = 2000\ntarget = 1000\n' > big.scene
bad "scene threads out of range" "threads must be in" ensemble --scene big.scene --clusters 2 --out b1
run ensemble --scene big.scene --threads 2 --clusters 2 --out rwo -q
[ "$rc" -eq 0 ] || fail "--threads 2 over a scene's threads = 2000: exit $rc: $(cat err)"
# --force replaces an ensemble.
run ensemble --clusters 3 --target 500 --out t1 --force -q
[ "$rc" -eq 0 ] || fail "--force: $(cat err)"
h5dump -a /ensemble/clusters t1/ensemble.h5 | grep -q "(0): 3$" || fail "--force: the old ensemble is still there"

echo "$checks checks, $fails failed"
[ "$fails" -eq 0 ]
