#!/bin/sh
# test_scene.sh - `pdla --scene` as a user meets it. Usage: test_scene.sh PDLA SCENES_DIR
#
# A bad scene gives exit status 2, nothing on stdout, exactly one stderr line
# "pdla: FILE:LINE: reason", and makes no run directory. A good scene runs;
# flags on the command line override its keys (checked in --stats-json); the
# worked examples in runs/scenes run at a tiny target.
set -u
PDLA=${1:?usage: test_scene.sh PDLA SCENES}
SCENES=${2:?usage: test_scene.sh PDLA SCENES}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
case $SCENES in /*) ;; *) SCENES=$(pwd)/$SCENES ;; esac
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-scene.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
mkdir "$tmp/work"
checks=0
fails=0
fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}
run() {
    checks=$((checks + 1))
    (cd "$tmp/work" && exec "$PDLA" "$@") >"$tmp/out" 2>"$tmp/err" </dev/null
    rc=$?
}
# bad NAME WANT TEXT: the scene TEXT must be refused with "pdla: s.scene:WANT".
bad() {
    printf '%b' "$3" >"$tmp/work/s.scene"
    run --scene s.scene
    [ "$rc" -eq 2 ] || fail "$1: exit status $rc, want 2 ($(cat "$tmp/err"))"
    [ -s "$tmp/out" ] && fail "$1: wrote to stdout"
    [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "$1: want one line on stderr: $(cat "$tmp/err")"
    case $(cat "$tmp/err") in
    "pdla: s.scene:$2"*) ;;
    *) fail "$1: stderr '$(cat "$tmp/err")', want 'pdla: s.scene:$2...'" ;;
    esac
    [ -e "$tmp/work/runs" ] && fail "$1: made a run directory"
}
bad "unknown key" "2: unknown key 'colour'" 'dim = 2\ncolour = red\n'
bad "duplicate key" "3: duplicate key 'seed' (first set on line 1)" 'seed = 1\n# x\nseed = 2\n'
bad "missing =" "1: missing '='" 'target 1000\n'
bad "bad value" "2: invalid value '1e6x' for --target" 'dim = 2\ntarget = 1e6x\n'
bad "out of range" "1: eps must be in [2, resolution/2 = 16] units, got 1" 'eps = 1\n'
bad "empty value" "1: missing value for 'dim'" 'dim =\n'
# Run options the scene sets that exclude each other: not a valid run on its
# own either, so the line is named too (they were one line without it)
bad "no-output and out" "3: --no-output and --out exclude each other" 'dim = 2\nno-output = yes\nout = x\n'
bad "checkpoint and no-output" "2: checkpoints need a run directory" 'checkpoint-every = 5\nno-output = yes\n'
bad "resume and force" "2: --resume continues in the checkpoint's run directory" 'resume = d\nforce = yes\n'
# with one of the two on the command line the scene is valid on its own
printf 'target = 100\nout = x\n' >"$tmp/work/o.scene"
run --scene o.scene --no-output
[ "$rc" -eq 2 ] && [ "$(cat "$tmp/err")" = "pdla: --no-output and --out exclude each other" ] ||
    fail "scene out, --no-output: $rc $(cat "$tmp/err")"
run --scene "$tmp/work/none.scene"
[ "$rc" -eq 2 ] && grep -q "^pdla: cannot open scene .*none.scene: No such file" "$tmp/err" ||
    fail "missing scene file: $rc $(cat "$tmp/err")"

# A good scene, and flags overriding it.
printf 'dim = 2\ntarget = 300\nseed = 5\nno-output = yes\nquiet = yes\nstats-json = a.json\n' \
    >"$tmp/work/g.scene"
run --scene g.scene
[ "$rc" -eq 0 ] || fail "good scene: status $rc: $(cat "$tmp/err")"
grep -q '"particles": 300,' "$tmp/work/a.json" || fail "good scene: not 300 particles"
grep -q '"seed": 5,' "$tmp/work/a.json" || fail "good scene: seed not 5"
run --target 200 --scene g.scene --stats-json b.json --seed 9
[ "$rc" -eq 0 ] || fail "override: status $rc: $(cat "$tmp/err")"
grep -q '"particles": 200,' "$tmp/work/b.json" || fail "override: --target did not win"
grep -q '"seed": 9,' "$tmp/work/b.json" || fail "override: --seed did not win"
[ -e "$tmp/work/a.json.2" ] && fail "override: odd file"

# What a scene leaves out: no R_g samples, so no fit (and it says why);
# one thread for --threads 1.
printf 'target = 2000\nrg-per-decade = 0\nno-output = yes\nstats-json = c.json\nthreads = 1\n' \
    >"$tmp/work/c.scene"
run --scene c.scene
[ "$rc" -eq 0 ] || fail "rg off: status $rc: $(cat "$tmp/err")"
grep -q '^D_f  *n/a (R_g sampling off' "$tmp/out" || fail "rg off: summary says $(grep D_f "$tmp/out")"
grep -q '"fit": {"df": null' "$tmp/work/c.json" || fail "rg off: JSON fit not null"
grep -q '"threads": 0,' "$tmp/work/c.json" || fail "threads 1: workers ran"

# The worked examples, shrunk to 500 particles (threads: serial to 200).
for s in "$SCENES"/*.scene; do
    rm -f "$tmp/work/ex.json" # one per example (--stats-json replaces a file only with --force)
    run --scene "$s" --target 500 --serial-until 200 --no-output -q --stats-json ex.json
    [ "$rc" -eq 0 ] || fail "example $s: status $rc: $(cat "$tmp/err")"
    grep -q '"particles": 500,' "$tmp/work/ex.json" || fail "example $s: not 500 particles"
done
echo "$checks runs, $fails failures" >&2
[ "$fails" -eq 0 ]
