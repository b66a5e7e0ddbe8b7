#!/bin/sh
# test_cli.sh - the `pdla` binary as a user meets it. Usage: test_cli.sh PDLA
#
# Bad usage must give exit status 2, nothing on stdout and exactly one line
# on stderr starting with "pdla:", and must not create anything. Good usage:
# --help/--version, tiny real runs into --out and the default runs/ name,
# --force, -q silence, --no-output with --stats-json, the lock counters of a
# threaded run (summary, JSON, cluster.h5), and SIGTERM writing the
# partial cluster before pdla ends by the signal. Everything happens in a
# temporary directory that is removed afterwards.
set -u
PDLA=${1:?usage: test_cli.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-cli.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
mkdir "$tmp/work"
checks=0
fails=0

fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}

# run ARGS...: run pdla in $tmp/work; status in $rc, output in $tmp/out, $tmp/err.
run() {
    checks=$((checks + 1))
    (cd "$tmp/work" && exec "$PDLA" "$@") >"$tmp/out" 2>"$tmp/err" </dev/null
    rc=$?
}

# bad NAME ARGS...: usage error: 2, silent stdout, one "pdla:" line on stderr.
bad() {
    name=$1
    shift
    run "$@"
    [ "$rc" -eq 2 ] || fail "$name: exit status $rc, want 2 ($(cat "$tmp/err"))"
    [ -s "$tmp/out" ] && fail "$name: wrote to stdout"
    lines=$(wc -l <"$tmp/err")
    [ "$lines" -eq 1 ] || fail "$name: $lines lines on stderr, want 1: $(cat "$tmp/err")"
    case $(cat "$tmp/err") in
    "pdla: "*) ;;
    *) fail "$name: stderr does not start with 'pdla: ': $(cat "$tmp/err")" ;;
    esac
}

# good NAME ARGS...: exit status 0.
good() {
    name=$1
    shift
    run "$@"
    [ "$rc" -eq 0 ] || fail "$name: exit status $rc, want 0: $(cat "$tmp/err")"
}

is_hdf5() { head -c 8 "$1" 2>/dev/null | od -An -c | grep -q 'H   D   F'; }

# ---- bad usage ----------------------------------------------------------
bad "unknown flag" --bogus
bad "unknown short flag" -x
bad "missing value" --target
bad "stray argument" stray
bad "--target 12x" --target 12x
bad "--target -5" --target -5
bad "--target 1.5" --target 1.5
bad "--target overflow" --target 99999999999999999999999
bad "--target 0" --target 0
bad "--target empty" --target ''
bad "--dim 4" --dim 4
bad "--resolution 48" --resolution 48
bad "--eps 0" --eps 0
bad "--return bogus" --return bogus
bad "--far-factor nan" --far-factor nan
bad "--kill-ratio inf" --kill-ratio inf
bad "--threads -1" --threads -1
bad "--reference-walkers with --threads" --reference-walkers 4 --threads 2
bad "--reference-walkers -1" --reference-walkers -1
bad "flag with a value" --force=1
bad "--no-output with --out" --no-output --out "$tmp/never"
run --target 12x
grep -q "invalid value '12x' for --target: trailing characters after the number" "$tmp/err" ||
    fail "--target 12x message: $(cat "$tmp/err")"
[ -e "$tmp/work/runs" ] && fail "a refused command made runs/"
[ -e "$tmp/never" ] && fail "a refused command made its --out directory"

# An existing run directory is refused and left untouched.
mkdir "$tmp/exist"
echo keep >"$tmp/exist/marker"
bad "existing --out" --target 50 --out "$tmp/exist"
[ "$(ls -A "$tmp/exist")" = marker ] || fail "existing --out: directory changed: $(ls -A "$tmp/exist")"
[ "$(cat "$tmp/exist/marker")" = keep ] || fail "existing --out: marker changed"

# Paths that cannot be made.
bad "--out under /proc" --target 50 --out /proc/pdla-test-x
bad "--out under /proc, deeper" --target 50 --out /proc/pdla-test-x/y
: >"$tmp/file"
bad "--out under a file" --target 50 --out "$tmp/file/x"
bad "--out is a file, --force" --target 50 --out "$tmp/file" --force
bad "--stats-json unwritable" --target 50 --out "$tmp/sj" --stats-json /proc/pdla-test-x/s.json
[ -e "$tmp/sj" ] && fail "--stats-json unwritable: left the run directory behind"

# ---- --help, --version ----------------------------------------------------
good "--help" --help
grep -q '^Usage: pdla' "$tmp/out" || fail "--help: no usage line"
grep -q -- '--target N' "$tmp/out" || fail "--help: no --target"
[ -s "$tmp/err" ] && fail "--help: wrote to stderr"
good "-h" -h
good "--version" --version
grep -q '^pdla [0-9]' "$tmp/out" || fail "--version: $(cat "$tmp/out")"
[ -s "$tmp/err" ] && fail "--version: wrote to stderr"

# ---- tiny real runs -------------------------------------------------------
good "run 200" --target 200 --out "$tmp/r"
[ -s "$tmp/r/cluster.h5" ] || fail "run 200: no cluster.h5"
is_hdf5 "$tmp/r/cluster.h5" || fail "run 200: cluster.h5 is not HDF5"
[ -s "$tmp/r/summary.txt" ] || fail "run 200: no summary.txt"
grep -q '^command .*--target 200' "$tmp/r/summary.txt" || fail "run 200: summary.txt lacks the command"
grep -q '^particles  *200 of 200$' "$tmp/r/summary.txt" || fail "run 200: summary.txt particles"
grep -q "^output  *$tmp/r/cluster.h5" "$tmp/out" || fail "run 200: summary on stdout lacks the output"
for key in 'R_g' 'R_ext' 'D_f' 'jumps/particle' 'ns/jump' 'peak RSS' 'tree memory' 'wall time'; do
    grep -q "^$key " "$tmp/out" || fail "run 200: summary lacks '$key'"
done
[ -s "$tmp/err" ] && fail "run 200: stderr not empty without a terminal: $(cat "$tmp/err")"

# The same directory again: refused without --force, the file untouched.
cp "$tmp/r/cluster.h5" "$tmp/r.h5"
bad "run again without --force" --target 200 --out "$tmp/r"
cmp -s "$tmp/r.h5" "$tmp/r/cluster.h5" || fail "refused rerun changed cluster.h5"
good "run again with --force" --target 300 --out "$tmp/r" --force -q
grep -q '^particles  *300 of 300$' "$tmp/r/summary.txt" || fail "--force: summary.txt not replaced"
[ "$(ls -A "$tmp/r" | sort | tr '\n' ' ')" = "cluster.h5 cluster.xdmf2 summary.txt " ] ||
    fail "--force: unexpected files: $(ls -A "$tmp/r")"

good "-q" -q --target 200 --out "$tmp/q"
[ -s "$tmp/err" ] && fail "-q: stderr not empty: $(cat "$tmp/err")"
[ -s "$tmp/out" ] && fail "-q: stdout not empty"
[ -s "$tmp/q/cluster.h5" ] || fail "-q: no cluster.h5"

good "3D run" -q --dim 3 --target 100 --out "$tmp/r3/"
[ -s "$tmp/r3/cluster.h5" ] || fail "3D run: no cluster.h5"
good "--out with new parents" -q --target 20 --out "$tmp/a/b/c"
[ -s "$tmp/a/b/c/cluster.h5" ] || fail "--out a/b/c: no cluster.h5"

# Default run directory: runs/run-YYYYmmdd-HHMMSS-2d-50, a second run in the
# same second gets another name.
good "default name" -q --target 50
good "default name again" -q --target 50
n=$(ls -d "$tmp"/work/runs/run-[0-9]*-[0-9]*-2d-50* 2>/dev/null | wc -l)
[ "$n" -eq 2 ] || fail "default name: $n directories: $(ls "$tmp/work/runs" 2>&1)"
for d in "$tmp"/work/runs/run-*; do
    [ -s "$d/cluster.h5" ] || fail "default name: no $d/cluster.h5"
done
rm -rf "$tmp/work/runs"

# --no-output: nothing but the JSON asked for.
good "--no-output" -q --no-output --target 300 --stats-json "$tmp/s.json"
[ -e "$tmp/work/runs" ] && fail "--no-output made runs/"
grep -q '"particles": 300,' "$tmp/s.json" || fail "--stats-json: no particle count"
for key in jumps grow_seconds node_visits particle_checks tree_bytes rg_diam; do
    grep -q "\"$key\": " "$tmp/s.json" || fail "--stats-json: no $key"
done
if command -v python3 >/dev/null 2>&1; then
    python3 -c 'import json, sys; json.load(open(sys.argv[1]))' "$tmp/s.json" ||
        fail "--stats-json: not valid JSON"
fi
good "--no-output summary" --no-output --target 100
grep -q '^output  *none$' "$tmp/out" || fail "--no-output: summary output line"

# ---- reference walkers: deterministic, summary, JSON, /parameters --------
good "reference walkers" --reference-walkers 4 --serial-until 200 --target 2000 --out "$tmp/ref" \
    --stats-json "$tmp/ref1.json"
grep -q '^reference  *4 walkers in turn (one thread) after 200 serial particles$' "$tmp/out" ||
    fail "reference walkers: summary line"
grep -q '"reference_walkers": 4' "$tmp/ref1.json" || fail "reference walkers: JSON parameter"
# the lag (issue 11): 1800 particles, 4 walkers in flight -> a mean near 3
grep -q '"lag_n": 1800,' "$tmp/ref1.json" || fail "reference walkers: JSON lag_n"
grep -Eq '^lag  *mean (2\.[5-9]|3\.00)[0-9]* particles stuck while a walker flew' "$tmp/out" ||
    fail "reference walkers: summary lag line (mean about 3)"
good "reference walkers again" --reference-walkers 4 --serial-until 200 --target 2000 --no-output \
    --stats-json "$tmp/ref2.json"
[ "$(grep '"rg_diam"' "$tmp/ref1.json")" = "$(grep '"rg_diam"' "$tmp/ref2.json")" ] ||
    fail "reference walkers: same seed, different R_g"
if command -v h5dump >/dev/null 2>&1; then
    checks=$((checks + 1))
    h5dump -a /parameters/reference_walkers "$tmp/ref/cluster.h5" 2>/dev/null | grep -q '(0): 4' ||
        fail "reference walkers: /parameters/reference_walkers"
fi

# ---- threads: the lock counters reach the summary, the JSON and the file ---
good "threads" --threads 2 --serial-until 200 --target 3000 --out "$tmp/thr" --stats-json "$tmp/thr.json"
grep -q '^mutex waits  *node [0-9.]*% of [0-9]*, bucket [0-9.]*% of [0-9]*, gyration [0-9.]*% of 2800$' \
    "$tmp/out" || fail "threads: summary mutex line: $(grep mutex "$tmp/out")"
# the straggler bound (issue 11): its count reaches the summary and the JSON;
# the reference runs no worker, so it never relaunches
grep -Eq '^relaunched  *[0-9]+ walkers left behind by more than 8 x 2 particles$' "$tmp/out" ||
    fail "threads: summary relaunched line"
grep -Eq '"relaunches": [0-9]+,' "$tmp/thr.json" || fail "threads: JSON relaunches"
grep -q '"relaunches": 0,' "$tmp/ref1.json" || fail "reference walkers: JSON relaunches not 0"
if command -v python3 >/dev/null 2>&1 && python3 -c 'import h5py' 2>/dev/null; then
    checks=$((checks + 1))
    python3 - "$tmp/thr.json" "$tmp/thr/cluster.h5" <<'PY' || fail "threads: mutex counters in JSON / cluster.h5"
import json, sys, h5py
s = json.load(open(sys.argv[1]))
taken, waits = s["mutex_taken"], s["mutex_contended"]
assert len(taken) == 3 and len(waits) == 3 and taken[2] == 2800, (taken, waits)
assert all(0 <= w <= t for w, t in zip(waits, taken)), (taken, waits)
with h5py.File(sys.argv[2], "r") as f:
    r = f["/results"].attrs
    assert list(r["mutex_taken"]) == taken and list(r["mutex_contended"]) == waits
PY
fi

# ---- SIGTERM: the partial cluster is written, then pdla ends by the signal --
checks=$((checks + 1))
(cd "$tmp/work" && exec "$PDLA" --target 1e9 --out "$tmp/sig" -q) >"$tmp/out" 2>"$tmp/err" </dev/null &
pid=$!
i=0
# The directory exists once the handlers are installed; let it grow a bit.
while [ ! -d "$tmp/sig" ] && [ $i -lt 100 ]; do
    sleep 0.1
    i=$((i + 1))
done
sleep 0.5
kill -TERM "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 143 ] || fail "SIGTERM: status $rc, want 143 (terminated by SIGTERM)"
grep -q "^pdla: stopped by signal after [0-9]* particles; partial cluster written to $tmp/sig/cluster.h5$" \
    "$tmp/err" || fail "SIGTERM: message: $(cat "$tmp/err")"
[ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "SIGTERM: stderr: $(cat "$tmp/err")"
is_hdf5 "$tmp/sig/cluster.h5" || fail "SIGTERM: no partial cluster.h5"
grep -q '^particles .*(stopped early)$' "$tmp/sig/summary.txt" || fail "SIGTERM: summary.txt"

echo "$checks commands, $fails failures"
[ "$fails" -eq 0 ]
