#!/bin/bash
# test_mpi.sh - `mpirun pdla ensemble` (include/pdla/ensemble_mpi.h) against
# the single-process ensemble, with real OpenMPI ranks on one machine.
# Usage: test_mpi.sh PDLA
#
#  - mpirun -n 2 (2 threads each) and -n 4 (1 thread each): per-cluster
#    datasets and statistics bit-identical to one process (h5diff, no
#    tolerance; timings excepted), the single process run by this script;
#  - more ranks than clusters (-n 4, 3 clusters): idle ranks end cleanly,
#    same result;
#  - bad input under mpirun: exit 2, one line from pdla (rank 0 only);
#  - kill -9 of rank 1 mid-run: mpirun ends the job, the journal keeps the
#    acknowledged clusters, and `mpirun -n 2 pdla ensemble --resume DIR`
#    completes an ensemble equal to the uninterrupted one;
#  - SIGTERM to rank 0 alone: the other ranks finish their clusters, rank 0
#    says how to resume; the resumed ensemble is equal again.
# Exit 77 (skipped) without mpirun or h5diff.
set -u
here=$(cd "$(dirname "$0")" && pwd)
PDLA=${1:?usage: test_mpi.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
command -v mpirun >/dev/null || { echo "mpirun not installed (apt-get install openmpi-bin): skipped"; exit 77; }
command -v h5diff >/dev/null || { echo "h5diff not installed: skipped"; exit 77; }

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-mpi.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
. "$here/mpi_common.sh"
same() { # same A B WHAT: the datasets are bit-identical, and the sidecars
    same_data "$@" || return
    # The ParaView sidecar (kept positions): the same text.
    checks=$((checks + 1))
    cmp -s "$1/ensemble.xdmf2" "$2/ensemble.xdmf2" || fail "$3: ensemble.xdmf2 differs or is missing"
}
mpi() { # mpi N ARGS...: mpirun -n N pdla ARGS, status in rc, output in out/err
    local n=$1
    shift
    checks=$((checks + 1))
    "${MPIRUN[@]}" -n "$n" "$PDLA" "$@" >out 2>err </dev/null
    rc=$?
}
# --help says how to launch across machines in a build with MPI.
checks=$((checks + 1))
"$PDLA" ensemble --help 2>&1 | grep -q "mpirun -n R pdla ensemble" || fail "ensemble --help does not name mpirun"
# rank_pid JOB R: pid of rank R of the job started as JOB (timeout, whose
# child is mpirun, whose children are the ranks), from the ranks' environment.
rank_pid() {
    local m p
    for m in $(pgrep -P "$1"); do
        for p in $(pgrep -P "$m"); do
            { tr '\0' '\n' <"/proc/$p/environ"; } 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$2" &&
                { echo "$p"; return 0; }
        done
    done
    return 1
}
ARGS="--clusters 12 --target 2000 --seed 5 --keep-positions"
"$PDLA" ensemble $ARGS --threads 2 --out s -q || fail "single process ensemble"

# ---- ranks x threads == one process -------------------------------------------
mpi 2 ensemble $ARGS --threads 2 --out m2
[ "$rc" -eq 0 ] || fail "mpirun -n 2: status $rc: $(cat err)"
grep -q "^ensemble: 12 clusters" out || fail "mpirun -n 2: rank 0's summary missing: $(cat out)"
[ "$(grep -c '^ensemble:' out)" -eq 1 ] || fail "mpirun -n 2: more than one rank printed the summary"
same s m2 "mpirun -n 2 --threads 2"
mpi 4 ensemble $ARGS --threads 1 --out m4 -q
[ "$rc" -eq 0 ] || fail "mpirun -n 4: status $rc: $(cat err)"
same s m4 "mpirun -n 4 --threads 1"
# The comparison can fail: another seed differs.
h5diff -q s/ensemble.h5 m4/ensemble.h5 /clusters/cpu_seconds /clusters/cpu_seconds >/dev/null 2>&1 &&
    fail "cpu_seconds identical: the comparison cannot see differences"

# ---- more ranks than clusters ------------------------------------------------------
"$PDLA" ensemble --clusters 3 --target 2000 --seed 7 --keep-positions --out s3 -q || fail "single process, 3 clusters"
mpi 4 ensemble --clusters 3 --target 2000 --seed 7 --keep-positions --threads 1 --out r3 -q
[ "$rc" -eq 0 ] || fail "4 ranks, 3 clusters: status $rc: $(cat err)"
same s3 r3 "4 ranks, 3 clusters"

# ---- extend under mpirun: 5 clusters (one process) to 12 on 2 ranks == 12 at once ----
"$PDLA" ensemble --clusters 5 --target 2000 --seed 5 --keep-positions --out x5 -q || fail "single process, 5 clusters"
mpi 2 ensemble --resume x5 --clusters 12 --threads 1 -q
[ "$rc" -eq 0 ] || fail "mpirun -n 2, extend 5 to 12: status $rc: $(cat err)"
same s x5 "5 clusters extended to 12 on 2 ranks"

# ---- bad input: rank 0 alone says it, exit 2 --------------------------------------------
for bad in "--clusters 0 --target 100 --out b1|--clusters: must be at least 1" \
           "--clusters 2 --target 100 --out s|already exists" \
           "--resume s --target 5000|--target 2000, asked 5000"; do
    mpi 2 ensemble ${bad%|*}
    [ "$rc" -eq 2 ] || fail "mpirun, bad input '${bad%|*}': status $rc, want 2"
    [ "$(grep -c '^pdla ensemble:' err)" -eq 1 ] || fail "mpirun, bad input '${bad%|*}': $(cat err)"
    grep -qF -- "${bad#*|}" err || fail "mpirun, bad input '${bad%|*}': $(cat err)"
done
[ -e b1 ] && fail "bad input wrote b1"

# ---- a rank killed (kill -9), then resume ------------------------------------------
# Bigger clusters so that a kill lands mid-run; the reference uninterrupted.
KARGS="--clusters 12 --target 10000 --seed 11 --keep-positions"
"$PDLA" ensemble $KARGS --threads 2 --out kref -q || fail "single process, kill reference"
# records begun in DIR's journal (each starts with the magic PDLAREC2)
records() { grep -ao PDLAREC2 "$1/clusters.journal" 2>/dev/null | wc -l; }
recorded() { sed -n 's/.*resuming [^:]*: \([0-9]*\) of 12 clusters recorded.*/\1/p' err; }
killed=0
for attempt in 1 2 3; do
    rm -rf k
    checks=$((checks + 1))
    "${MPIRUN[@]}" -n 3 "$PDLA" ensemble $KARGS --threads 1 --out k -q </dev/null >kout 2>kerr &
    job=$!
    pid=
    # Wait for the journal's first record, then kill.
    for _ in $(seq 1 600); do
        [ -z "$pid" ] && pid=$(rank_pid $job 1)
        [ -n "$pid" ] && [ "$(records k)" -ge 1 ] && break
        kill -0 $job 2>/dev/null || break
        sleep 0.05
    done
    [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null
    wait $job
    jrc=$?
    [ -f k/ensemble.h5 ] && continue # finished before the kill
    [ -n "$pid" ] || { fail "kill -9: rank 1 not found"; break; }
    [ "$jrc" -ne 0 ] || fail "kill -9 of rank 1: mpirun exit status 0"
    mpi 2 ensemble --resume k --threads 1
    [ "$rc" -eq 0 ] || { fail "resume after kill -9: $(cat err)"; break; }
    got=$(recorded)
    echo "kill -9 of rank 1, attempt $attempt: $got of 12 clusters had been recorded"
    [ -n "$got" ] && [ "$got" -lt 12 ] && killed=1
    same kref k "resumed after kill -9 of rank 1"
    [ "$killed" -eq 1 ] && break
done
[ "$killed" -eq 1 ] || fail "no kill -9 landed before the last cluster"

# ---- SIGTERM to rank 0 alone ----------------------------------------------------
for attempt in 1 2 3; do
    rm -rf g
    checks=$((checks + 1))
    "${MPIRUN[@]}" -n 3 "$PDLA" ensemble $KARGS --threads 1 --out g -q </dev/null >gout 2>gerr &
    job=$!
    pid=
    for _ in $(seq 1 600); do
        [ -z "$pid" ] && pid=$(rank_pid $job 0)
        [ -n "$pid" ] && [ "$(records g)" -ge 1 ] && break
        kill -0 $job 2>/dev/null || break
        sleep 0.05
    done
    [ -n "$pid" ] && kill -TERM "$pid" 2>/dev/null
    wait $job
    [ -f g/ensemble.h5 ] && continue
    grep -q "resume with pdla ensemble --resume g" gerr || fail "SIGTERM to rank 0: $(cat gerr)"
    mpi 2 ensemble --resume g --threads 1
    [ "$rc" -eq 0 ] || fail "resume after SIGTERM: $(cat err)"
    echo "SIGTERM to rank 0, attempt $attempt: $(recorded) of 12 clusters had been recorded"
    same kref g "resumed after SIGTERM to rank 0"
    break
done

echo "$checks checks, $fails failed"
[ "$fails" -eq 0 ]
