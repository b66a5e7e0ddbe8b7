#!/bin/sh
# test_dlca_cli.sh PDLA - `pdla --model dlca`: bad input refused with one
# line and exit 2 before any work; a run writes RUN_DIR/cluster.h5 that
# `pdla info` reads; --force; determinism and the three searches agreeing
# through the CLI; a scene with model = dlca; --help from the table.
set -u
pdla=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# refused ARGS...: exit 2, exactly one stderr line starting "pdla: ", no dir.
refused() {
    "$pdla" --model dlca --out "$tmp/bad" "$@" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    [ $rc -eq 2 ] || fail "$* -> exit $rc, not 2"
    [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$* -> stderr is not one line: $(cat "$tmp/err")"
    grep -q '^pdla: ' "$tmp/err" || fail "$* -> stderr: $(cat "$tmp/err")"
    [ ! -e "$tmp/bad" ] || { fail "$* -> made the run directory"; rm -rf "$tmp/bad"; }
}
refused --dim 1
refused --dim 6
refused --fill 0
refused --fill 1
refused --fill 1.5
refused --box 4x4 --fill 0.01
refused --box 1x64
# A box written axis by axis has --dim lengths, in either order of the two
# options (64x64x64 with --dim 2 ran as 64x64 without a word: its lengths
# looked like the one-length form); one length still means every axis.
for a in "--box 64x64x64 --dim 2" "--dim 2 --box 64x64x64" "--box 64x64 --dim 3" "--box 16x16x16x16x16 --dim 3"; do
    refused $a --until-clusters 5
    grep -q 'box gives [0-9] lengths but dim is [0-9]' "$tmp/err" || fail "$a -> $(cat "$tmp/err")"
done
printf 'model = dlca\ndim = 2\nbox = 64x64x64\nuntil_clusters = 5\n' >"$tmp/box-scene"
refused --scene "$tmp/box-scene"
grep -q 'box gives 3 lengths but dim is 2' "$tmp/err" || fail "3 lengths in a 2D scene -> $(cat "$tmp/err")"
for a in "--box 16 --dim 3" "--dim 3 --box 16x12x8" "--box 16x12"; do
    "$pdla" --model dlca $a --fill 0.1 --until-clusters 5 --no-output -q 2>"$tmp/err" || fail "$a refused: $(cat "$tmp/err")"
done
refused --dim 3 --box 2000
refused --dim 3 --box 2048x1024x1024   # 2^31 sites: a site shares its word with a tag bit (dlca_sim.h)
grep -q 'at most 2^31 - 1' "$tmp/err" || fail "2^31 sites -> $(cat "$tmp/err")"
refused --box 65536x60000
# Over half the machine's memory (1 bit a site, ~32 bytes a monomer: 1024^3 at 90% wants ~29 GiB);
# only where the machine has less than 48 GiB.
memkb=$(awk '/^MemTotal:/ {print $2}' /proc/meminfo 2>/dev/null)
if [ -n "$memkb" ] && [ "$memkb" -lt 50331648 ]; then
    refused --dim 3 --box 1024 --fill 0.9
    grep -q 'more than half of this machine' "$tmp/err" || fail "memory refusal: $(cat "$tmp/err")"
fi
refused --search nearest
refused --until-clusters 0
refused --mobility x
refused --nosuch 3
refused --grid-box 3
refused --dim 2 --box 64x64 --fil 0.01 --until-clusters 10   # abbreviated --fill
refused --checkpoint-every 9999999999   # 0 is "no time trigger" since session 26
refused --checkpoint-every 5x
refused --checkpoint-attempts 0
refused --checkpoint --no-output
# The largest seed is a seed (audit-dlca: 2^64 - 1 rounded to 2^64 as a
# double and was refused as "at most 18446744073709551615"); 2^64 is not.
"$pdla" --model dlca --box 16 --seed 18446744073709551615 --max-attempts 10 --no-output -q 2>"$tmp/err" ||
    fail "--seed 18446744073709551615 refused: $(cat "$tmp/err")"
refused --box 16 --seed 18446744073709551616

d="$tmp/run"
"$pdla" --model dlca --dim 2 --box 64x48 --fill 0.05 --until-clusters 10 --seed 3 --out "$d" --check >"$tmp/out" 2>"$tmp/err" ||
    fail "run: exit $? $(cat "$tmp/err")"
[ -f "$d/cluster.h5" ] || fail "no cluster.h5"
grep -q 'stop: clusters' "$tmp/out" || fail "summary: $(cat "$tmp/out")"
"$pdla" info "$d/cluster.h5" >"$tmp/info" 2>&1 || fail "info: $(cat "$tmp/info")"
grep -q 'model dlca' "$tmp/info" || fail "info does not say model dlca"
grep -Eq '^  n_clusters +10$' "$tmp/info" || fail "info n_clusters: $(grep n_clusters "$tmp/info")"
"$pdla" info --json "$d/cluster.h5" >"$tmp/json" || fail "info --json"
if command -v python3 >/dev/null; then
    python3 -c "import json,sys; j=json.load(open(sys.argv[1])); assert j['model']=='dlca' and j['results']['n_clusters']==10 and j['parameters']['box']==[64,48]" "$tmp/json" ||
        fail "info --json content"
fi
digest() { grep history_digest "$1" | awk '{print $2}'; }
dg=$(digest "$tmp/info")

"$pdla" --model dlca --box 64x48 --fill 0.05 --out "$d" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] || fail "existing run directory without --force was not refused"
for s in lattice boxes allpairs; do
    "$pdla" --model dlca --box 64x48 --fill 0.05 --until-clusters 10 --seed 3 --search $s --out "$d" --force -q ||
        fail "--force --search $s"
    "$pdla" info "$d/cluster.h5" >"$tmp/info2"
    [ "$(digest "$tmp/info2")" = "$dg" ] || fail "--search $s: history digest $(digest "$tmp/info2") != $dg"
done
[ ! -e "$d/.cluster.h5.new" ] || fail "temporary file left behind"

# Checkpoint half way, resume to the end: the same history as one run.
c="$tmp/ck"
"$pdla" --model dlca --box 64x48 --fill 0.05 --until-clusters 40 --seed 3 --out "$c" --checkpoint -q ||
    fail "--checkpoint run"
[ -f "$c/checkpoint.h5" ] || fail "no checkpoint.h5"
# a user's files whose names only start as the temporary names do: the
# sweep of leftovers took cluster.h5.tmpcopy (it matched the prefix
# cluster.h5.tmp); kept, as a killed run's cluster.h5.tmp.PID is not
echo mine >"$c/cluster.h5.tmpcopy"
echo mine >"$c/cluster.xdmf2.tmpnotes"
echo left >"$c/cluster.xdmf2.tmp.77"
"$pdla" --model dlca --resume "$c/checkpoint.h5" --until-clusters 10 -q || fail "--resume"
[ -f "$c/cluster.h5.tmpcopy" ] && [ -f "$c/cluster.xdmf2.tmpnotes" ] ||
    fail "the sweep of leftovers removed a user's file: $(ls -a "$c" | tr '\n' ' ')"
[ ! -e "$c/cluster.xdmf2.tmp.77" ] || fail "the sweep of leftovers kept cluster.xdmf2.tmp.77"
rm -f "$c/cluster.h5.tmpcopy" "$c/cluster.xdmf2.tmpnotes"
"$pdla" info "$c/cluster.h5" >"$tmp/info3"
[ "$(digest "$tmp/info3")" = "$dg" ] || fail "resumed: history digest $(digest "$tmp/info3") != $dg"
"$pdla" --model dlca --resume "$c/checkpoint.h5" --seed 5 >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "--resume with --seed: $(cat "$tmp/err")"
"$pdla" --model dlca --resume "$d/cluster.h5" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "--resume from a cluster.h5: $(cat "$tmp/err")"
# a checkpoint under a temporary name (a killed run's .checkpoint.h5.new):
# loaded, then removed by the sweep of leftovers; refused, kept
cp "$c/checkpoint.h5" "$c/.checkpoint.h5.new"
"$pdla" --model dlca --resume "$c/.checkpoint.h5.new" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] && grep -q "unfinished temporary file" "$tmp/err" ||
    fail "--resume from a temporary name: $(cat "$tmp/err")"
[ -f "$c/.checkpoint.h5.new" ] || fail "--resume from a temporary name removed it"
rm -f "$c/.checkpoint.h5.new"
# Resumed without --dim, --box's lengths are held against the checkpoint's
# dimension, not the default 2 (a 3D run's own --box was refused).
c3="$tmp/ck3"
"$pdla" --model dlca --dim 3 --box 16x16x12 --fill 0.05 --until-clusters 40 --seed 3 --out "$c3" --checkpoint -q ||
    fail "3D --checkpoint run"
# (--until-clusters 35: more than the 31 monomers the default fill gives
# that box, which the resume's options were once held against)
"$pdla" --model dlca --resume "$c3" --box 16x16x12 --until-clusters 35 -q 2>"$tmp/err" ||
    fail "3D --resume with its own --box: $(cat "$tmp/err")"
c4="$tmp/ck4"
"$pdla" --model dlca --dim 4 --box 8x8x8x6 --fill 0.05 --until-clusters 30 --seed 3 --out "$c4" --checkpoint -q ||
    fail "4D --checkpoint run"
"$pdla" --model dlca --resume "$c4" --box 8x8x8x6 --until-clusters 20 -q 2>"$tmp/err" ||
    fail "4D --resume with its own --box: $(cat "$tmp/err")"
for b in 16x16; do
    "$pdla" --model dlca --resume "$c3" --box $b >/dev/null 2>"$tmp/err"
    [ $? -eq 2 ] && grep -q "box gives [0-9] lengths but the checkpoint is 3D" "$tmp/err" ||
        fail "3D --resume with --box $b: $(cat "$tmp/err")"
done
"$pdla" --model dlca --resume "$c3" --box 16x16x12x4 >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "3D --resume with 4 box lengths: $(cat "$tmp/err")"

# A real signal: SIGTERM after the first interval checkpoint (every 50000
# attempts) of a long run (to 1 cluster: tens of millions of attempts). With
# checkpoints on, pdla writes one and exits 0; resumed (from the run
# directory) to a fixed attempt count past the stop, it must give the
# history of one uninterrupted run to that count, bit for bit (digest).
attempts_of() { "$pdla" info "$1" | awk '$1 == "attempts" {print $2}'; }
long="--box 1024x1024 --fill 0.02 --until-clusters 1 --max-attempts 50M --seed 7"
k="$tmp/kill"
# shellcheck disable=SC2086
"$pdla" --model dlca $long --out "$k" --checkpoint-attempts 50000 -q 2>"$tmp/kerr" &
pid=$!
i=0
while [ ! -f "$k/checkpoint.h5" ] && [ $i -lt 1200 ]; do sleep 0.05; i=$((i + 1)); done
kill -TERM $pid
wait $pid
krc=$?
[ $krc -eq 0 ] || fail "SIGTERM with checkpoints: exit $krc, not 0 ($(cat "$tmp/kerr"))"
grep -q 'stopped by signal after [0-9]* attempts; checkpoint .*resume with' "$tmp/kerr" ||
    fail "SIGTERM: stderr $(cat "$tmp/kerr")"
ka=$(attempts_of "$k/cluster.h5")
[ -n "$ka" ] && [ "$ka" -ge 50000 ] || fail "SIGTERM: partial cluster.h5 says $ka attempts"
x=$((ka + 100000))
"$pdla" --model dlca --resume "$k" --max-attempts $x -q || fail "resume after SIGTERM"
# shellcheck disable=SC2086
"$pdla" --model dlca $long --max-attempts $x --out "$tmp/ref" -q || fail "uninterrupted reference run"
"$pdla" info "$k/cluster.h5" >"$tmp/ik"
"$pdla" info "$tmp/ref/cluster.h5" >"$tmp/ir"
[ "$(attempts_of "$k/cluster.h5")" = "$x" ] || fail "resumed run ended at $(attempts_of "$k/cluster.h5"), not $x"
[ "$(digest "$tmp/ik")" = "$(digest "$tmp/ir")" ] ||
    fail "killed + resumed: history digest $(digest "$tmp/ik") != uninterrupted $(digest "$tmp/ir")"
for key in n_clusters largest t merges; do
    [ "$(grep -E "^  $key " "$tmp/ik")" = "$(grep -E "^  $key " "$tmp/ir")" ] || fail "killed + resumed: $key differs"
done

# RUN_DIR/STOP: checkpoint and exit 0 (looked for every 0.1 s at most), the
# file removed; --checkpoint-every writes by wall time.
k2="$tmp/stopfile"
# shellcheck disable=SC2086
"$pdla" --model dlca $long --out "$k2" --checkpoint-every 0.2s -q 2>"$tmp/kerr2" &
pid=$!
i=0
while [ ! -f "$k2/checkpoint.h5" ] && [ $i -lt 1200 ]; do sleep 0.05; i=$((i + 1)); done
[ -f "$k2/checkpoint.h5" ] || fail "--checkpoint-every 0.2s wrote no checkpoint"
touch "$k2/STOP"
wait $pid
krc=$?
[ $krc -eq 0 ] && grep -q 'stopped by RUN_DIR/STOP' "$tmp/kerr2" || fail "STOP file: exit $krc, $(cat "$tmp/kerr2")"
[ ! -e "$k2/STOP" ] || fail "the honoured STOP file was left behind"

# Without checkpoints a signal ends pdla by that signal, the state written.
k3="$tmp/int"
# shellcheck disable=SC2086
"$pdla" --model dlca $long --out "$k3" -q 2>/dev/null &
pid=$!
i=0
while [ ! -d "$k3" ] && [ $i -lt 1200 ]; do sleep 0.05; i=$((i + 1)); done
sleep 0.2
kill -INT $pid
wait $pid
krc=$?
[ $krc -eq 130 ] || fail "SIGINT without checkpoints: exit $krc, not 130"
[ -f "$k3/cluster.h5" ] && [ ! -e "$k3/checkpoint.h5" ] || fail "SIGINT without checkpoints: files $(ls "$k3")"

cat >"$tmp/scene" <<EOS
# a DLCA scene
model = dlca
dim = 3
box = 16x12x10
fill = 0.02
until_clusters = 5
seed = 4
out = $tmp/scene-run
EOS
"$pdla" --scene "$tmp/scene" -q || fail "scene run"
"$pdla" info "$tmp/scene-run/cluster.h5" | grep -Eq '^  dim +3$' || fail "scene: dim is not 3"
printf 'model = dlca\nbox = 32x32\nfill = 0.05\nuntil_clusters = 3\ncheckpoint_attempts = 100\nout = %s\n' \
    "$tmp/scene-ck" >"$tmp/scene2"
"$pdla" --scene "$tmp/scene2" -q || fail "scene with checkpoint_attempts"
[ -f "$tmp/scene-ck/checkpoint.h5" ] || fail "scene: checkpoint_attempts wrote no checkpoint"
printf 'model = dlca\ncheckpoint_every = 9999999999\n' >"$tmp/bad-scene2"
"$pdla" --scene "$tmp/bad-scene2" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q ':2: ' "$tmp/err" || fail "bad checkpoint_every in a scene: $(cat "$tmp/err")"
printf 'model = dlca\nfill = 2\n' >"$tmp/bad-scene"
"$pdla" --scene "$tmp/bad-scene" >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] && grep -q ':2: ' "$tmp/err" || fail "bad scene: $(cat "$tmp/err")"

# A run that reached a stop (--max-attempts) and is resumed to go on: the
# same history and monomers as the run straight to the end, with one series
# row more, the one of the first stop (README, DLCA checkpoints).
"$pdla" --model dlca --box 64x48 --fill 0.05 --until-clusters 10 --seed 3 --out "$tmp/straight" -q || fail "straight run"
half=$(( $(attempts_of "$tmp/straight/cluster.h5") / 2 ))
"$pdla" --model dlca --box 64x48 --fill 0.05 --until-clusters 10 --seed 3 --max-attempts $half --checkpoint \
    --out "$tmp/ext" -q || fail "run to $half attempts"
"$pdla" --model dlca --resume "$tmp/ext" --max-attempts 0 -q || fail "extended run"
"$pdla" info "$tmp/straight/cluster.h5" >"$tmp/i1"
"$pdla" info "$tmp/ext/cluster.h5" >"$tmp/i2"
[ -n "$(digest "$tmp/i1")" ] && [ "$(digest "$tmp/i1")" = "$(digest "$tmp/i2")" ] || fail "extended run: another history"
[ -z "$(h5diff -c "$tmp/straight/cluster.h5" "$tmp/ext/cluster.h5" /monomers /monomers 2>&1)" ] ||
    fail "extended run: other monomers"
r1=$(sed -n 's/.*model dlca, \([0-9]*\) series rows.*/\1/p' "$tmp/i1")
r2=$(sed -n 's/.*model dlca, \([0-9]*\) series rows.*/\1/p' "$tmp/i2")
[ -n "$r1" ] && [ "$r2" = "$((r1 + 1))" ] || fail "extended run: $r2 series rows, the straight run $r1"
# ... and its other rows are the straight run's, value for value: the stop
# row once reset the 1% row schedule, and the rows after the stop came at
# other attempts (another N_c, largest) than the straight run's: seen with
# more than 100 clusters at the stop, where 1% is more than one cluster.
"$pdla" --model dlca --box 128 --fill 0.05 --seed 11 --until-time 60 --out "$tmp/sA" -q || fail "straight run to t 60"
"$pdla" --model dlca --box 128 --fill 0.05 --seed 11 --until-time 30 --checkpoint --out "$tmp/sB" -q ||
    fail "run to t 30"
"$pdla" --model dlca --resume "$tmp/sB" --until-time 60 -q || fail "resumed to t 60"
if /usr/bin/python3 -c 'import h5py' 2>/dev/null; then
    /usr/bin/python3 - "$tmp/sA/cluster.h5" "$tmp/sB/cluster.h5" <<'PY' || fail "extended run: its series rows are not the straight run's and the stop's"
import sys, h5py, numpy as np
a, b = (h5py.File(p, 'r')['series'] for p in sys.argv[1:3])
keep = b['t'][:] < 30
keep[np.argmax(~keep) + 1:] = True  # all but the row of the first stop, the first at t >= 30
assert keep.sum() == len(a['attempts']) == len(b['attempts']) - 1
for k in a:
    assert np.array_equal(a[k][:], b[k][:][keep]), k
PY
fi

# cluster.h5 that could not be written: exit 1, one line naming what the
# close was, and the summary does not say "wrote" (it did before); the same
# run with room says it. SIGXFSZ ignored so that the write fails with EFBIG.
for l in 1 4; do
    rm -rf "$tmp/full"
    (trap '' XFSZ; ulimit -f $l; "$pdla" --model dlca --box 32x32 --fill 0.05 --until-clusters 3 --out "$tmp/full" \
        >"$tmp/out" 2>"$tmp/err")
    rc=$?
    [ $rc -eq 1 ] && [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "full disk ($l blocks): exit $rc, $(cat "$tmp/err")"
    grep -q 'could not close \|could not write\|could not create' "$tmp/err" ||
        fail "full disk ($l blocks): $(cat "$tmp/err")"
    # a failed close names what it closed ("could not close t" said nothing)
    ! grep -q 'could not close [a-z_]* (' "$tmp/err" || grep -q 'could not close \(dataset\|attribute\|group\|file\|an\?\) ' "$tmp/err" ||
        fail "full disk ($l blocks): the close names no kind: $(cat "$tmp/err")"
    ! grep -q '^wrote' "$tmp/out" || fail "full disk ($l blocks): the summary says $(grep '^wrote' "$tmp/out")"
    [ ! -e "$tmp/full/cluster.h5" ] || fail "full disk ($l blocks): a cluster.h5 is there"
done
rm -rf "$tmp/full"
"$pdla" --model dlca --box 32x32 --fill 0.05 --until-clusters 3 --out "$tmp/full" >"$tmp/out" 2>"$tmp/err" ||
    fail "room: $(cat "$tmp/err")"
grep -q "^wrote $tmp/full/cluster.h5\$" "$tmp/out" || fail "room: no 'wrote' line: $(cat "$tmp/out")"

"$pdla" --model dlca --help >"$tmp/help" || fail "--help"
for o in dim box fill count mobility sticking drift until-clusters until-time max-attempts seed search grid-box \
    checkpoint checkpoint-every checkpoint-attempts resume start snapshot-every; do
    grep -q -- "--$o " "$tmp/help" || fail "--help lacks --$o"
done

# Leading blanks or a sign in --box, and a real below a double's smallest
# normal, are refused (strtoull skipped the blank: ' 64' ran as 64; 5e-324
# was "not a number", now "out of range").
refused --box ' 64'
refused --box '+64'
refused --until-time 5e-324
grep -q 'out of range' "$tmp/err" || fail "--until-time 5e-324: $(cat "$tmp/err")"
# --resume with --count 0 when the run took N from --fill (the checkpoint
# stores 0), or with the run's own N, is no change; another N is.
f0="$tmp/fill0"
"$pdla" --model dlca --box 64 --fill 0.05 --until-time 5 --checkpoint --out "$f0" -q || fail "fill run"
"$pdla" --model dlca --resume "$f0" --count 0 --until-time 8 -q 2>"$tmp/err" || fail "--resume --count 0: $(cat "$tmp/err")"
"$pdla" --model dlca --resume "$f0" --count 205 --until-time 10 -q 2>"$tmp/err" || fail "--resume --count N: $(cat "$tmp/err")"
"$pdla" --model dlca --resume "$f0" --count 7 --until-time 12 >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] || fail "--resume --count 7 was taken"

[ $fails -eq 0 ] && echo "dlca cli: all passed"
exit $((fails != 0))
