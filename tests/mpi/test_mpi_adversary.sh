#!/bin/bash
# test_mpi_adversary.sh - `mpirun -n 3 pdla ensemble` killed in the ways a
# cluster kills jobs, then resumed with another rank count; the result must
# be the single-process ensemble, bit for bit (h5diff -c, timings excepted).
# Usage: test_mpi_adversary.sh PDLA
#
#  - kill -9 of rank 0 (the writer) at a random moment after its first
#    journaled cluster, then `mpirun -n 2 --resume`;
#  - kill -9 of rank 2 likewise, then a resume in one process;
#  - kill -9 of mpirun itself (the ranks are orphaned: they must end, the
#    directory's lock must not stay held), then `mpirun -n 3 --resume`;
#  - SIGTERM to mpirun (a scheduler's time limit): it reaches every rank,
#    mpirun exits non-zero, then `mpirun -n 2 --resume`;
#  - a resume under mpirun while another resume holds the directory: the
#    second is refused with one line, exit 2.
# In each case no temporary file may survive the resume, and the journal
# must never hold a cluster twice (counted from its records).
# Exit 77 (skipped) without mpirun or h5diff.
set -u
here=$(cd "$(dirname "$0")" && pwd)
PDLA=${1:?usage: test_mpi_adversary.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
command -v mpirun >/dev/null || { echo "mpirun not installed (apt-get install openmpi-bin): skipped"; exit 77; }
command -v h5diff >/dev/null || { echo "h5diff not installed: skipped"; exit 77; }

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-mpi-adv.XXXXXX") || exit 1
cleanup() {
    [ -n "${mp:-}" ] && kill -9 "$mp" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
cd "$tmp" || exit 1
. "$here/mpi_common.sh"
same() { # same A B WHAT: the datasets are bit-identical, no temporaries left
    same_data "$@" || return
    checks=$((checks + 1))
    ls "$2" | grep -q '\.tmp\.' && fail "$3: temporaries left: $(ls "$2")"
}
# Records in the journal and distinct cluster indices among them: equal
# (a cluster acknowledged twice would be two records of one index).
once() { # once DIR WHAT
    checks=$((checks + 1))
    /usr/bin/python3 - "$1/clusters.journal" "$2" <<'EOF' || fail "$2: a cluster is recorded twice"
import struct, sys
raw = open(sys.argv[1], "rb").read()
off = 24 + struct.unpack_from("<I", raw, 12)[0]
seen = []
while off + 24 <= len(raw) and raw[off:off + 8] == b"PDLAREC2":  # magic, length, fingerprint, record, sum
    n = struct.unpack_from("<Q", raw, off + 8)[0]
    if off + 32 + n > len(raw):
        break
    seen.append(struct.unpack_from("<Q", raw, off + 24)[0])
    off += 32 + n
sys.exit(0 if len(seen) == len(set(seen)) else 1)
EOF
}
size() { stat -c %s "$1" 2>/dev/null || echo 0; }
# The pid of rank R of the pdla processes under mpirun (their environment).
rank_pid() {
    local p
    for p in $(pgrep -f "pdla ensemble .*--out $2"); do
        tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$1" && { echo "$p"; return; }
    done
}
# Start mpirun -n 3 on DIR in the background ($mp), wait for its first
# record (a record holds 3000 x 2 x 4 bytes of positions) and a random
# 0-100 ms more.
launch() { # launch DIR
    rm -rf "$1"
    "${MPIRUN[@]}" -n 3 "$PDLA" ensemble $ARGS --threads 1 --out "$1" -q </dev/null >"$1.out" 2>&1 &
    mp=$!
    local i
    for i in $(seq 1 3000); do
        [ "$(size "$1/clusters.journal")" -gt 30000 ] && break
        kill -0 "$mp" 2>/dev/null || break
        sleep 0.01
    done
    sleep "0.$(printf '%03d' $((RANDOM % 100)))"
}
ARGS="--clusters 48 --target 3000 --seed 31 --keep-positions"
"$PDLA" ensemble $ARGS --threads 2 --out ref -q || fail "the single-process reference failed"

resumed() { # resumed DIR WHAT RANKS: resume (RANKS 1: no mpirun), compare
    local rc
    if [ "$3" -eq 1 ]; then
        "$PDLA" ensemble --resume "$1" --threads 2 -q </dev/null >/dev/null 2>"$1.err"
    else
        "${MPIRUN[@]}" -n "$3" "$PDLA" ensemble --resume "$1" --threads 1 -q </dev/null >/dev/null 2>"$1.err"
    fi
    rc=$?
    checks=$((checks + 1))
    [ "$rc" -eq 0 ] || fail "$2: resume on $3 ranks: exit $rc: $(head -3 "$1.err")"
    same ref "$1" "$2"
    once "$1" "$2"
}

# ---- kill -9 of rank 0, of rank 2 -------------------------------------------------
for r in 0 2; do
    launch k$r
    pid=$(rank_pid $r k$r)
    if [ -z "$pid" ]; then
        echo "rank $r had ended before the kill (the run was over): resumed anyway"
    else
        kill -9 "$pid"
    fi
    wait "$mp"
    echo "kill -9 of rank $r: mpirun exit $?; $(ls k$r | tr '\n' ' ')"
    mp=
    if [ $r -eq 0 ]; then
        resumed k$r "kill -9 of rank 0" 2
    else
        resumed k$r "kill -9 of rank 2" 1
    fi
done

# The ranks on DIR must end within 30 s of mpirun (an orphan holding the
# directory's lock would refuse every resume).
ended() { # ended DIR WHAT
    local _
    checks=$((checks + 1))
    for _ in $(seq 1 300); do
        pgrep -f "pdla ensemble .*--out $1" >/dev/null || return 0
        sleep 0.1
    done
    fail "$2: ranks still running 30 s after mpirun ended: $(pgrep -af "pdla ensemble .*--out $1")"
}

# ---- kill -9 of mpirun: orphaned ranks end and release the directory ------------------
launch km
kill -9 "$mp"
wait "$mp" 2>/dev/null
mp=
ended km "kill -9 of mpirun"
resumed km "kill -9 of mpirun" 3

# ---- SIGTERM to mpirun ---------------------------------------------------------------
launch kt
kill -TERM "$mp"
wait "$mp"
trc=$?
mp=
ended kt "SIGTERM to mpirun"
echo "SIGTERM to mpirun: exit $trc; $(ls kt | tr '\n' ' ')"
checks=$((checks + 1))
if [ -f kt/ensemble.h5 ]; then
    echo "SIGTERM to mpirun: the ensemble had finished"
else
    [ "$trc" -ne 0 ] || fail "SIGTERM to mpirun: exit 0 without ensemble.h5"
fi
resumed kt "SIGTERM to mpirun" 2

# ---- a second resume while one holds the directory -------------------------------------
launch kl
kill -9 "$mp"
wait "$mp" 2>/dev/null
mp=
ended kl "kill -9 of mpirun"
# Hold the directory's lock as a live pdla would (flock on the directory).
flock -n kl "${MPIRUN[@]}" -n 2 "$PDLA" ensemble --resume kl --threads 1 </dev/null >kl.out 2>kl.err
lrc=$?
checks=$((checks + 1))
[ "$lrc" -eq 2 ] || fail "resume of a locked directory under mpirun: exit $lrc, want 2 ($(cat kl.err))"
[ "$(grep -c 'pdla ensemble' kl.err)" -eq 1 ] && grep -q "in use by another pdla process" kl.err ||
    fail "resume of a locked directory under mpirun: $(cat kl.err)"
resumed kl "after a refused resume" 2

echo "$checks checks, $fails failed"
[ "$fails" -eq 0 ]
