#!/bin/bash
# test_ckpt_cli.sh - checkpoints and resume as a user of `pdla` meets them.
# Usage: test_ckpt_cli.sh PDLA [N]
#
#  - a serial run to N and a run to N/2 resumed to N give the same
#    /cluster/positions and /gyration (2D and 3D), compared with h5dump;
#  - SIGTERM and RUN_DIR/STOP write a checkpoint and exit 0; the run resumes
#    with more threads and a raised target;
#  - a second pdla in the same run directory is refused (exit 2);
#  - bad checkpoints (foreign HDF5, not HDF5, damaged, changed physics, a
#    lower target, --out with --resume) are refused with one line, exit 2,
#    and nothing in the directory changes;
#  - a checkpoint that cannot be written (ulimit -f) gives one line, exit 1,
#    and the previous checkpoint is intact.
set -u
PDLA=${1:?usage: test_ckpt_cli.sh PDLA [N]}
N=${2:-6000}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
command -v h5dump >/dev/null || { echo "h5dump not installed: skipped"; exit 77; }

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-ckpt-cli.XXXXXX") || exit 1
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
# bad NAME STATUS NEEDLE ARGS...: refused with one line holding NEEDLE.
bad() {
    local name=$1 want=$2 needle=$3
    shift 3
    run "$@"
    [ "$rc" -eq "$want" ] || fail "$name: exit status $rc, want $want ($(cat "$tmp/err"))"
    [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$name: stderr: $(cat "$tmp/err")"
    grep -qF -- "$needle" "$tmp/err" || fail "$name: message '$(cat "$tmp/err")', want '$needle'"
}
data() { # the particle data and R_g series of a cluster.h5, as text
    h5dump -d /cluster/positions -d /gyration/N -d /gyration/rg_diam "$1" | sed 1d
}
listing() { (cd "$1" && ls -la --time-style=+%s . && md5sum -- *); }

# ---- bit-identical serial resume ------------------------------------------
for dim in 2 3; do
    half=$((N / 2))
    run --dim $dim --target $N --out straight$dim -q
    [ "$rc" -eq 0 ] || fail "straight $dim: $(cat err)"
    run --dim $dim --target $half --out split$dim -q --checkpoint
    [ "$rc" -eq 0 ] || fail "first half $dim: $(cat err)"
    [ -f split$dim/checkpoint.h5 ] || fail "no checkpoint at the end of a run"
    run --resume split$dim --target $N -q
    [ "$rc" -eq 0 ] || fail "resume $dim: $(cat err)"
    [ "$(data straight$dim/cluster.h5)" = "$(data split$dim/cluster.h5)" ] ||
        fail "${dim}D: resumed cluster differs from the straight run"
    # periodic checkpoints in between do not change the run either
    run --dim $dim --target $N --out periodic$dim -q --checkpoint-particles 1000
    [ "$(data straight$dim/cluster.h5)" = "$(data periodic$dim/cluster.h5)" ] ||
        fail "${dim}D: a run with periodic checkpoints differs"
    [ -f periodic$dim/checkpoint.2.h5 ] || fail "generations: $(ls periodic$dim)"
done

# ---- SIGTERM, STOP, threads -------------------------------------------------
checks=$((checks + 1))
"$PDLA" --target 1e9 --out sig -q --checkpoint 2>err </dev/null &
pid=$!
i=0
while [ ! -d sig ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGTERM with checkpoints: status $rc: $(cat err)"
grep -q "^pdla: stopped by signal after [0-9]* particles; checkpoint sig/checkpoint.h5 (resume with pdla --resume sig); partial cluster written to sig/cluster.h5$" err ||
    fail "SIGTERM message: $(cat err)"
n1=$(sed -n 's/^particles *\([0-9]*\) .*/\1/p' sig/summary.txt)

# A second SIGTERM while the first is handled ends pdla at once (README):
# the handler is installed with SA_RESETHAND. The run is sent the
# first; once /proc shows it delivered (no longer pending) the run is
# stopped while it writes its (compressed) checkpoint, its handler must be
# gone (SigCgt bit 14: SIGTERM is 15), and the second must end it by
# SIGTERM (143), not let it finish with 0.
checks=$((checks + 1))
"$PDLA" --target 1e9 --out sig2 -q --checkpoint --checkpoint-compress 2>err </dev/null &
pid=$!
i=0
while [ ! -d sig2 ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
sleep 1
caught() {
    local m
    m=$(sed -n 's/^SigCgt:\t*//p' /proc/$pid/status 2>/dev/null)
    [ -n "$m" ] && [ $((0x$m >> 14 & 1)) -eq 1 ]
}
if ! caught; then
    fail "second signal: SIGTERM not caught before the first"
    kill -KILL $pid
fi
pending() { # SIGTERM sent but not yet delivered (ShdPnd bit 14)
    local m
    m=$(sed -n 's/^ShdPnd:\t*//p' /proc/$pid/status 2>/dev/null)
    [ -n "$m" ] && [ $((0x$m >> 14 & 1)) -eq 1 ]
}
kill -TERM $pid
# delivered when pdla next gets the CPU: wait (up to 10 s) until it is not
# pending, however loaded the machine; then the handler must be gone
i=0
while pending && [ $i -lt 200 ]; do sleep 0.05; i=$((i + 1)); done
kill -STOP $pid 2>/dev/null
if kill -0 $pid 2>/dev/null && pending; then
    kill -CONT $pid
    wait $pid
    echo "second signal: the first was not delivered within 10 s; not judged"
elif kill -0 $pid 2>/dev/null; then
    caught && fail "second signal: SIGTERM still caught once the first was delivered"
    kill -TERM $pid; kill -CONT $pid
    wait $pid
    rc=$?
    [ $rc -eq 143 ] || fail "second signal: status $rc, want 143 (ended by SIGTERM): $(cat err)"
else
    wait $pid
    echo "second signal: pdla had already ended (status $?); not judged"
fi

checks=$((checks + 1))
"$PDLA" --resume sig -q --threads 3 --serial-until 100 --checkpoint-every 0.2s 2>err </dev/null &
pid=$!
sleep 1.5
touch sig/STOP
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "STOP: status $rc: $(cat err)"
grep -q "^pdla: stopped by sig/STOP after" err || fail "STOP message: $(cat err)"
[ -e sig/STOP ] && fail "STOP file left after it was honoured"
grep -q "^threads  *3 after" sig/summary.txt || fail "resume with 3 threads: $(cat sig/summary.txt)"
grep -q "^resumed from  *sig/checkpoint.h5 (generation 1, $n1 particles" sig/summary.txt ||
    fail "resumed line: $(grep resumed sig/summary.txt)"
grep -Eq "^checkpoints +([2-9]|[1-9][0-9]+) written" sig/summary.txt || fail "periodic: $(grep checkpoints sig/summary.txt)"
for a in pause_seconds previous_write_seconds; do # README: each checkpoint's root attributes
    h5dump -a /$a sig/checkpoint.h5 2>/dev/null | grep -Eq '\(0\): [0-9.e+-]+$' || fail "checkpoint attribute $a missing"
done
# README: the first checkpoint a resumed run writes has previous_write_seconds
# 0, the earlier write's time is not carried over. periodic2's last checkpoint
# (not its first write) has a time above 0; a bare resume 500 particles on
# (its schedule, every 1000, does not come again) writes only its final one.
prevw() { h5dump -a /previous_write_seconds "$1" 2>/dev/null | sed -n 's/^ *(0): *\([0-9.e+-]*\)$/\1/p'; }
p1=$(prevw periodic2/checkpoint.h5)
awk -v v="$p1" 'BEGIN { exit !(v > 0) }' || fail "previous_write_seconds of a later write: '$p1', want > 0"
run --resume periodic2 --target $((N + 500)) -q
[ "$rc" -eq 0 ] || fail "resume periodic2: $(cat err)"
[ "$(prevw periodic2/checkpoint.h5)" = 0 ] ||
    fail "first checkpoint of a resumed run: previous_write_seconds '$(prevw periodic2/checkpoint.h5)', want 0"
[ "$(prevw periodic2/checkpoint.1.h5)" = "$p1" ] || fail "generations after the resume: $(ls periodic2)"
n2=$(sed -n 's/^particles *\([0-9]*\) .*/\1/p' sig/summary.txt)
[ "$n2" -gt "$n1" ] || fail "no growth after resume ($n1 -> $n2)"
run --resume sig -q --target $((n2 + 500)) --threads 2
[ "$rc" -eq 0 ] || fail "finish: $(cat err)"
grep -q "^particles  *$((n2 + 500)) of $((n2 + 500))$" sig/summary.txt || fail "raised target: $(grep particles sig/summary.txt)"

# ---- the lock ---------------------------------------------------------------
# The second writer comes once the first holds the lock: when a checkpoint
# newer than the stamp appears (only the lock holder writes one), not after
# a fixed sleep - on a loaded machine the first pdla could still be starting
# after 0.5 s, the second then took the lock and grew to 1e9 (a hang). The
# second's target is finite, so a broken lock fails (exit 0) instead of hanging.
touch stamp
"$PDLA" --resume sig -q --target 1e9 --checkpoint-every 0.05s 2>/dev/null </dev/null &
pid=$!
i=0
while [ -z "$(find sig -maxdepth 1 -name checkpoint.h5 -newer stamp 2>/dev/null)" ] && [ $i -lt 1200 ] &&
    kill -0 $pid 2>/dev/null; do
    sleep 0.05
    i=$((i + 1))
done
if [ -n "$(find sig -maxdepth 1 -name checkpoint.h5 -newer stamp 2>/dev/null)" ]; then
    bad "second writer" 2 "run directory 'sig' is in use by another pdla process" --resume sig \
        --target $((n2 + 100000))
else
    checks=$((checks + 1))
    fail "lock: the first writer wrote no checkpoint in 60 s"
fi
kill -TERM $pid
wait $pid

# ---- option errors ----------------------------------------------------------------
bad "duration unit" 2 "invalid value '10x' for --checkpoint-every: unknown unit (use s, m or h)" --checkpoint-every 10x --out o1
bad "duration too long" 2 "must be 0 (none) to 1e9 seconds" --checkpoint-every 9999999999s --out o2
bad "particles zero" 2 "must be at least 1" --checkpoint-particles 0 --out o3
bad "no output" 2 "--no-output excludes them" --no-output --checkpoint
[ -e o1 ] || [ -e o2 ] || [ -e o3 ] && fail "a refused command made a run directory"

# ---- refusals change nothing ---------------------------------------------------
before=$(listing sig)
bad "changed eps" 2 "eps is 2 in the checkpoint, 3 asked" --resume sig --eps 3
bad "changed seed" 2 "seed is 1 in the checkpoint, 5 asked" --resume sig --seed 5
bad "lower target" 2 "below the" --resume sig --target 10
bad "resume and out" 2 "--out and --force do not apply" --resume sig --out x
bad "foreign hdf5" 2 "sig/cluster.h5: an HDF5 file but not a pdla checkpoint (format 'pdla-cluster')" --resume sig/cluster.h5
bad "not hdf5" 2 "sig/summary.txt: not an HDF5 file" --resume sig/summary.txt
bad "missing" 2 "cannot resume from 'nothere'" --resume nothere
[ "$before" = "$(listing sig)" ] || fail "a refused resume changed the run directory"
mkdir dmg
cp split2/checkpoint.h5 dmg/checkpoint.h5
size=$(stat -c %s dmg/checkpoint.h5)
truncate -s $((size / 2)) dmg/checkpoint.h5
bad "truncated" 2 "dmg/checkpoint.h5: damaged checkpoint (truncated)" --resume dmg
cp split2/checkpoint.h5 dmg/checkpoint.1.h5
run --resume dmg -q
[ "$rc" -eq 0 ] || fail "fall-back: $(cat err)"
grep -q "^pdla: note: skipped dmg/checkpoint.h5: damaged checkpoint (truncated); resuming from dmg/checkpoint.1.h5" err ||
    fail "fall-back note: $(cat err)"

# ---- a checkpoint that cannot be written ------------------------------------------
cp sig/checkpoint.h5 before.h5
n3=$(sed -n 's/^particles *\([0-9]*\) .*/\1/p' sig/summary.txt) # after the lock test's run
checks=$((checks + 1))
# --checkpoint-every 0: the final checkpoint alone (sig's recorded schedule,
# every 0.2 s, would be kept by a bare --resume, and warn at each failure)
(trap '' XFSZ; ulimit -f 200; exec "$PDLA" --resume sig -q --target $((n3 + 100000)) --checkpoint-every 0) >out 2>err </dev/null
rc=$?
[ $rc -eq 1 ] || fail "ulimit -f: status $rc: $(cat err)"
[ "$(wc -l <err)" -eq 1 ] || fail "ulimit -f: stderr: $(cat err)"
grep -q "^pdla: checkpoint failed: cannot write sig/checkpoint.h5: the file size limit (ulimit -f)" err ||
    fail "ulimit -f message: $(cat err)"
cmp -s before.h5 sig/checkpoint.h5 || fail "ulimit -f: the previous checkpoint changed"

echo "$checks commands, $fails failures"
[ "$fails" -eq 0 ]
