#!/bin/sh
# test_event_resume.sh PDLA - checkpoint and resume of the event model with
# real signals: a run stopped by SIGINT (checkpoint on), resumed, stopped by
# SIGTERM, resumed again to the end must write the same cluster.h5 (every
# dataset and result, bit for bit: h5diff without tolerance, /Code aside)
# as the run never stopped. Sticking with p = 0.5, so the RNG state counts.
# Also: --resume refuses a changed parameter and a missing checkpoint.
set -u
pdla=$1
command -v h5diff >/dev/null || { echo "h5diff not found: skipped"; exit 77; }
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
args="--model event --dim 2 --particles 20000 --packing 0.2 --seed-radius 1 --stick-p 0.5 --t-max 40 --series-dt 2 --seed 3"

"$pdla" $args --out "$t/A" >"$t/outA" 2>&1 || fail "uninterrupted run: $(cat "$t/outA")"

# Checkpoints every 0.05 s of wall time: the whole run takes about 1 s on a
# quiet machine, and with 0.2 s the first stop could come so late that the
# resumed part ended before its own first checkpoint (and its signal).
# stop_when_running SIGNAL DIR PID: wait until DIR/checkpoint.h5 is newer
# than DIR/stamp (an interval checkpoint: the run is under way), then signal.
stop_when_running() {
    n=0
    while [ -z "$(find "$2" -maxdepth 1 -name checkpoint.h5 -newer "$2/stamp" 2>/dev/null)" ] &&
        [ $n -lt 1200 ]; do
        sleep 0.05
        n=$((n + 1))
    done
    kill -"$1" "$3"
}
interrupted() { h5dump -a /results/stop_reason "$1/cluster.h5" 2>/dev/null | grep -q interrupted; }

mkdir "$t/B" && touch "$t/B/stamp"
"$pdla" $args --checkpoint-every 0.05 --out "$t/B" --force >"$t/outB1" 2>&1 &
pid=$!
stop_when_running INT "$t/B" $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGINT with checkpoints: exit $rc, want 0: $(cat "$t/outB1")"
interrupted "$t/B" || fail "the first part ended before SIGINT came"
[ -e "$t/B/checkpoint.prev.h5" ] || fail "no previous checkpoint kept"
ls -a "$t/B" | grep -q '\.tmp' && fail "a temporary file was left: $(ls -a "$t/B")"

sleep 0.01
touch "$t/B/stamp"
"$pdla" --model event --resume "$t/B" --checkpoint-every 0.05 >"$t/outB2" 2>&1 &
pid=$!
stop_when_running TERM "$t/B" $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGTERM on the resumed run: exit $rc, want 0: $(cat "$t/outB2")"
interrupted "$t/B" || fail "the second part ended before SIGTERM came"

# a user's files whose names only start as the temporary names do (the
# sweep of leftovers matched prefixes: cluster.h5.tmp took cluster.h5.tmpcopy)
# are kept; a killed run's cluster.xdmf2.tmp.PID goes
echo mine >"$t/B/cluster.h5.tmpcopy"
echo mine >"$t/B/cluster.xdmf2.tmpnotes"
echo left >"$t/B/cluster.xdmf2.tmp.77"
"$pdla" --model event --resume "$t/B" >"$t/outB3" 2>&1 || fail "final resume: $(cat "$t/outB3")"
[ -f "$t/B/cluster.h5.tmpcopy" ] && [ -f "$t/B/cluster.xdmf2.tmpnotes" ] ||
    fail "the sweep of leftovers removed a user's file: $(ls -a "$t/B" | tr '\n' ' ')"
[ ! -e "$t/B/cluster.xdmf2.tmp.77" ] || fail "the sweep of leftovers kept cluster.xdmf2.tmp.77"
rm -f "$t/B/cluster.h5.tmpcopy" "$t/B/cluster.xdmf2.tmpnotes"
grep -q "stopped: time reached at time 40" "$t/outB3" || fail "resumed run did not reach t = 40: $(cat "$t/outB3")"
# A checkpoint under a killed run's temporary name, named by --resume: the
# stale-file sweep removed it before it was read (the resume lost it);
# refused in one line, exit 2, and the file kept.
cp "$t/B/checkpoint.h5" "$t/B/.checkpoint.h5.tmp.77"
"$pdla" --model event --resume "$t/B/.checkpoint.h5.tmp.77" >"$t/outT" 2>"$t/errT"
rc=$?
[ $rc -eq 2 ] && [ "$(wc -l <"$t/errT")" -eq 1 ] && grep -q "unfinished temporary file" "$t/errT" ||
    fail "resume from a temporary name: exit $rc, want 2 and one line: $(cat "$t/errT")"
[ -e "$t/B/.checkpoint.h5.tmp.77" ] || fail "resume from a temporary name removed the file"
rm -f "$t/B/.checkpoint.h5.tmp.77"
# same A B: h5diff -c and nothing printed (without -c h5diff exits 0 for
# datasets of other shapes, say 5 series rows against 6; with -c it says so)
same() { h5diff -c --exclude-path /Code "$1" "$2" >"$t/diff" 2>&1 && [ ! -s "$t/diff" ]; }
same "$t/A/cluster.h5" "$t/B/cluster.h5" ||
    fail "resumed cluster.h5 differs from the uninterrupted one: $(head -20 "$t/diff")"
# the event counts of the two runs agree too
grep "^stuck" "$t/outA" >"$t/sa"
grep "^stuck" "$t/outB3" >"$t/sb"
cmp -s "$t/sa" "$t/sb" || fail "summaries differ: $(cat "$t/sa" "$t/sb")"

# A damaged checkpoint.h5: the resume falls back to checkpoint.prev.h5, sets
# the damaged file aside (checkpoint.damaged.h5) and keeps the good previous
# one as checkpoint.prev.h5 through its own next write (until session 17 that
# write moved the damaged file over it: a crash before the new file was in
# place then left no whole checkpoint), and the run equals one never stopped.
fargs="--model event --dim 2 --particles 3000 --packing 0.2 --seed-radius 1 --series-dt 1 --seed 4"
"$pdla" $fargs --t-max 12 --out "$t/E" >"$t/outE" 2>&1 || fail "reference run to t 12: $(cat "$t/outE")"
"$pdla" $fargs --t-max 4 --checkpoint --out "$t/F" >"$t/outF" 2>&1 || fail "run to t 4: $(cat "$t/outF")"
"$pdla" --model event --resume "$t/F" --t-max 8 >"$t/outF" 2>&1 || fail "resume to t 8: $(cat "$t/outF")"
cp "$t/F/checkpoint.prev.h5" "$t/good.h5"
head -c 5000 "$t/F/checkpoint.h5" >"$t/bad.h5" && cp "$t/bad.h5" "$t/F/checkpoint.h5"
"$pdla" --model event --resume "$t/F" --t-max 12 >"$t/outF" 2>&1 || fail "resume past a damaged checkpoint: $(cat "$t/outF")"
grep -q "resuming from the previous checkpoint" "$t/outF" || fail "no fallback said: $(cat "$t/outF")"
cmp -s "$t/good.h5" "$t/F/checkpoint.prev.h5" || fail "the good previous checkpoint was not kept as checkpoint.prev.h5"
cmp -s "$t/bad.h5" "$t/F/checkpoint.damaged.h5" || fail "the damaged checkpoint was not kept as checkpoint.damaged.h5"
same "$t/E/cluster.h5" "$t/F/cluster.h5" ||
    fail "run resumed from the previous checkpoint differs from the one never stopped: $(head -5 "$t/diff")"
# A second damaged checkpoint.h5 in the same directory: its fallback keeps
# it as checkpoint.damaged.2.h5 beside the first, which stays byte for byte
# (the numbering of the DLA recovery, pdla_rundir_set_aside; until session
# 32 the second fallback renamed its damaged file over checkpoint.damaged.h5
# and the first was lost), and says where it went.
head -c 7000 "$t/F/checkpoint.h5" >"$t/bad2.h5" && cp "$t/bad2.h5" "$t/F/checkpoint.h5"
"$pdla" --model event --resume "$t/F" --t-max 14 >"$t/outF2" 2>&1 || fail "second resume past a damaged checkpoint: $(cat "$t/outF2")"
grep -q "resuming from the previous checkpoint" "$t/outF2" || fail "no second fallback said: $(cat "$t/outF2")"
grep -q "note: $t/F/checkpoint.h5 set aside as $t/F/checkpoint.damaged.2.h5" "$t/outF2" ||
    fail "the second set-aside not said: $(cat "$t/outF2")"
cmp -s "$t/bad.h5" "$t/F/checkpoint.damaged.h5" || fail "the first damaged checkpoint was not kept by the second fallback"
cmp -s "$t/bad2.h5" "$t/F/checkpoint.damaged.2.h5" || fail "the second damaged checkpoint was not kept as checkpoint.damaged.2.h5"
# Nothing to fall back on: checkpoint.h5 and checkpoint.prev.h5 both
# damaged, or one damaged and the other missing. The one line names both
# files and both reasons (it gave only checkpoint.h5's: past a
# missing checkpoint.h5 it said "No such file or directory" and not why the
# checkpoint.prev.h5 there failed), exit 2, and the folder as it was.
# no_fallback CUR PREV WHY1 WHY2: the files (of $t, "" for none) as
# checkpoint.h5 and checkpoint.prev.h5 of $t/P, and the two reasons.
no_fallback() {
    rm -rf "$t/P" "$t/P.0" && mkdir "$t/P"
    [ -z "$1" ] || cp "$t/$1" "$t/P/checkpoint.h5"
    [ -z "$2" ] || cp "$t/$2" "$t/P/checkpoint.prev.h5"
    cp -r "$t/P" "$t/P.0"
    "$pdla" --model event --resume "$t/P" --t-max 14 >/dev/null 2>"$t/err"
    rc=$?
    want="pdla: cannot resume: checkpoint $t/P/checkpoint.h5: $3; checkpoint $t/P/checkpoint.prev.h5: $4"
    [ $rc -eq 2 ] && [ "$(cat "$t/err")" = "$want" ] ||
        fail "checkpoint.h5 ${1:-missing}, checkpoint.prev.h5 ${2:-missing}: exit $rc, want 2 and '$want': $(cat "$t/err")"
    diff -r "$t/P.0" "$t/P" >/dev/null || fail "a resume with nothing to fall back on changed the folder: $(ls "$t/P")"
}
nf="not an HDF5 file (or damaged)"
no_fallback bad.h5 bad2.h5 "$nf" "$nf"
no_fallback bad.h5 "" "$nf" "No such file or directory"
no_fallback "" bad2.h5 "No such file or directory" "$nf"

# A checkpoint FILE named in the run directory: the names its writes move
# on ahead of it (checkpoint.h5 ahead of checkpoint.prev.h5, both ahead of
# a file under another name) are loaded first. A valid one refuses the
# resume with one line, exit 2, nothing touched; a damaged one goes aside
# as after a directory's fallback, and checkpoint.prev.h5 named is kept
# through the writes. Until session 31 the folder was left as it was: the
# first write removed the checkpoint.prev.h5 named and kept the damaged
# checkpoint.h5 in its place; a valid newer checkpoint.h5 was pushed out.
"$pdla" $fargs --t-max 4 --checkpoint --out "$t/G" >"$t/outG" 2>&1 || fail "run to t 4: $(cat "$t/outG")"
"$pdla" --model event --resume "$t/G" --t-max 8 >"$t/outG" 2>&1 || fail "resume to t 8: $(cat "$t/outG")"
cp -r "$t/G" "$t/H"
"$pdla" --model event --resume "$t/H/checkpoint.prev.h5" --t-max 12 >/dev/null 2>"$t/err"
rc=$?
[ $rc -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] &&
    grep -q "^pdla: cannot resume: $t/H/checkpoint.prev.h5: $t/H/checkpoint.h5 is a newer valid checkpoint" "$t/err" ||
    fail "checkpoint.prev.h5 named behind a valid checkpoint.h5: exit $rc: $(cat "$t/err")"
diff -r "$t/G" "$t/H" >/dev/null || fail "a refused resume of checkpoint.prev.h5 changed the directory"
cp "$t/G/checkpoint.prev.h5" "$t/good3.h5"
head -c 5000 "$t/G/checkpoint.h5" >"$t/bad3.h5" && cp "$t/bad3.h5" "$t/G/checkpoint.h5"
"$pdla" --model event --resume "$t/G/checkpoint.prev.h5" --t-max 12 >"$t/outG" 2>&1 ||
    fail "checkpoint.prev.h5 named past a damaged checkpoint.h5: $(cat "$t/outG")"
grep -q "note: $t/G/checkpoint.h5 set aside as $t/G/checkpoint.damaged.h5" "$t/outG" || fail "no set-aside said: $(cat "$t/outG")"
cmp -s "$t/good3.h5" "$t/G/checkpoint.prev.h5" || fail "the checkpoint.prev.h5 named was not kept through the write"
cmp -s "$t/bad3.h5" "$t/G/checkpoint.damaged.h5" || fail "the damaged checkpoint.h5 was not kept as checkpoint.damaged.h5"
same "$t/E/cluster.h5" "$t/G/cluster.h5" ||
    fail "run resumed from checkpoint.prev.h5 named differs from the one never stopped: $(head -5 "$t/diff")"
# a copy under another name: the valid checkpoint.prev.h5 beside it refuses;
# with only a damaged checkpoint.h5 there, that goes aside and the copy stays
mkdir "$t/J" && cp "$t/good3.h5" "$t/J/save.h5" && cp "$t/good3.h5" "$t/J/checkpoint.prev.h5" && cp "$t/bad3.h5" "$t/J/checkpoint.h5"
"$pdla" --model event --resume "$t/J/save.h5" --t-max 12 >/dev/null 2>"$t/err"
rc=$?
[ $rc -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] && grep -q "$t/J/checkpoint.prev.h5 is a valid checkpoint" "$t/err" ||
    fail "save.h5 named beside a valid checkpoint.prev.h5: exit $rc: $(cat "$t/err")"
rm "$t/J/checkpoint.prev.h5"
"$pdla" --model event --resume "$t/J/save.h5" --t-max 12 >"$t/outJ" 2>&1 || fail "save.h5 named: $(cat "$t/outJ")"
cmp -s "$t/bad3.h5" "$t/J/checkpoint.damaged.h5" && cmp -s "$t/good3.h5" "$t/J/save.h5" ||
    fail "save.h5 named: the damaged checkpoint.h5 not kept aside, or the file named changed: $(ls "$t/J")"
# A resume refused for what it asks (a changed parameter, a stop already
# passed) past a damaged checkpoint.h5 is one line, exit 2, and leaves the
# folder as it was, as the DLA command's: the set-aside and the promotion of
# checkpoint.prev.h5 wait until the resume is accepted. Until session 31
# they came first, with their two notes (found by the review).
mkdir "$t/R" && cp "$t/bad3.h5" "$t/R/checkpoint.h5" && cp "$t/good3.h5" "$t/R/checkpoint.prev.h5" &&
    cp "$t/good3.h5" "$t/R/save.h5" && cp -r "$t/R" "$t/R.0"
for r in "$t/R" "$t/R/checkpoint.prev.h5" "$t/R/save.h5"; do
    for ask in "--packing 0.3" "--t-max 1"; do
        [ "$r" = "$t/R/save.h5" ] && rm -f "$t/R.0/checkpoint.prev.h5"
        rm -rf "$t/R" && cp -r "$t/R.0" "$t/R"
        "$pdla" --model event --resume "$r" $ask >/dev/null 2>"$t/err"
        rc=$?
        [ $rc -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] ||
            fail "--resume $r $ask past a damaged checkpoint.h5: exit $rc, want 2 and one line: $(cat "$t/err")"
        diff -r "$t/R.0" "$t/R" >/dev/null || fail "--resume $r $ask, refused, changed the directory: $(ls "$t/R")"
    done
done
# Another model's valid checkpoint where the event writes go (a DLA
# run's checkpoint.h5, which has no model attribute, or a DLCA run's): not a
# damaged event checkpoint to set aside but a run to keep, refused with one
# line, exit 2, the directory untouched, as the DLA and DLCA commands refuse
# an event checkpoint there. Until session 31 it went aside as
# checkpoint.damaged.h5 and the event run's cluster.h5 replaced that run's
# (found by the review: an event checkpoint copied into a DLCA run folder).
"$pdla" --dim 2 --target 300 --checkpoint --out "$t/KL" >/dev/null 2>&1 || fail "DLA run with a checkpoint"
"$pdla" --model dlca --max-attempts 2000 --checkpoint --out "$t/KC" >/dev/null 2>&1 || fail "DLCA run with a checkpoint"
for k in KL KC; do
    mv "$t/$k" "$t/$k.0"
    # each case from the run's own directory: name, its folder as it must stay
    for case in save.h5:save.h5 checkpoint.prev.h5:checkpoint.prev.h5 checkpoint.prev.h5:; do
        cp -r "$t/$k.0" "$t/$k.1" && cp "$t/good3.h5" "$t/$k.1/${case%%:*}" && rm -rf "$t/$k" && cp -r "$t/$k.1" "$t/$k"
        r="$t/$k/${case#*:}" && r=${r%/}
        "$pdla" --model event --resume "$r" --t-max 12 >/dev/null 2>"$t/err"
        rc=$?
        [ $rc -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] && grep -qE "$t/$k/checkpoint.h5 is (another model's|a DLA checkpoint)" "$t/err" ||
            fail "--resume $r beside a $k checkpoint.h5: exit $rc: $(cat "$t/err")"
        diff -r "$t/$k.1" "$t/$k" >/dev/null || fail "--resume $r beside a $k checkpoint.h5 changed the directory: $(ls "$t/$k")"
        rm -rf "$t/$k.1"
    done
done

# --resume refuses other parameters, and a directory without a checkpoint
"$pdla" --model event --resume "$t/B" --packing 0.3 >/dev/null 2>"$t/err"
[ $? -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] || fail "changed parameter on --resume: $(cat "$t/err")"
"$pdla" --model event --resume "$t/A" >/dev/null 2>"$t/err"
[ $? -eq 2 ] && [ "$(wc -l <"$t/err")" -eq 1 ] || fail "resume without checkpoint: $(cat "$t/err")"

# Without checkpoints a signal ends pdla by that signal (130/143, as the DLA
# and DLCA commands), after cluster.h5 is written with stop_reason
# "interrupted". A gas that never sticks and a far t-max: the run cannot end
# on its own before the signal.
for sig in TERM INT; do
    d="$t/C$sig"
    "$pdla" --model event --dim 2 --particles 20000 --packing 0.2 --stick-p 0 --t-max 1e9 --seed 5 \
        --out "$d" >"$t/outC" 2>&1 &
    pid=$!
    # Wait until pdla catches SIGINT and SIGTERM (SigCgt bits 1 and 14): a
    # background job of sh starts with SIGINT ignored, and a signal sent
    # before the handlers would be lost or fatal.
    n=0
    while [ $n -lt 1200 ]; do
        m=$(awk '/^SigCgt/ {print $2}' /proc/$pid/status 2>/dev/null)
        [ -n "$m" ] && [ $((0x$m & 0x4002)) -eq $((0x4002)) ] && break
        sleep 0.05
        n=$((n + 1))
    done
    sleep 0.1
    kill -"$sig" $pid
    wait $pid
    rc=$?
    want=143; [ $sig = INT ] && want=130
    [ $rc -eq $want ] || fail "SIG$sig without checkpoints: exit $rc, want $want: $(cat "$t/outC")"
    interrupted "$d" || fail "SIG$sig without checkpoints: cluster.h5 not written as interrupted"
done

[ $fails -eq 0 ] && echo "event resume: all passed"
exit $((fails > 0))
