#!/bin/bash
# test_out_input.sh PDLA - a tool never writes its output over its own input.
#
# `pdla export` and `pdla render` of a DLA, a DLCA and an event-model file,
# and `pdla analyze --csv` (whose CSV could be named like the input), with
# -o the input itself, the input by another path (./DIR/../DIR/cluster.h5),
# or the file a symlinked input points at, all with --force: exit 2, one
# line "... is the input file ...", the input byte for byte as it was, no
# temporary file left. An -o that is a symlink to the input is a name of
# its own (the rename replaces the link, not the file): written, exit 0,
# the input unchanged.
set -u
PDLA=${1:?usage: test_out_input.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-out-input.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
checks=0
fails=0
fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}

"$PDLA" -q --target 200 --seed 3 --out dla || fail "grow DLA"
"$PDLA" --model dlca --dim 2 --box 32 --fill 0.05 --seed 1 --out dlca -q >/dev/null || fail "grow DLCA"
"$PDLA" --model event --dim 2 --particles 50 --packing 0.05 --seed 3 --max-stuck 5 --out event --quiet ||
    fail "grow event"

# refused NAME INPUT ARGS...: exit 2, one line naming the input, INPUT intact.
refused() {
    local name=$1 input=$2
    shift 2
    checks=$((checks + 1))
    cp "$input" keep.h5
    "$PDLA" "$@" >out 2>err </dev/null
    local rc=$?
    [ "$rc" -eq 2 ] || fail "$name: exit status $rc, want 2 ($(cat err))"
    [ "$(wc -l <err)" -eq 1 ] && grep -q "is the input file" err || fail "$name: stderr: $(cat err)"
    if ! cmp -s "$input" keep.h5; then
        fail "$name: the input was changed"
        rm -f "$input" && cp keep.h5 "$input" # for the next case
    fi
    [ -z "$(find . -name '*.tmp.*')" ] || fail "$name: left $(find . -name '*.tmp.*')"
}

for m in dla dlca event; do
    in=$m/cluster.h5
    refused "$m export -o input" "$in" export "$in" --format csv -o "$in" --force
    refused "$m render -o input" "$in" render "$in" -o "$in" --force
    refused "$m export -o input by another path" "$in" export "$in" --format ply -o "./$m/../$m/cluster.h5" --force
    refused "$m render -o input by another path" "$in" render "$in" -o "./$m/../$m/cluster.h5" --force --size 64
    ln -s cluster.h5 "$m/link.h5"
    refused "$m export of a link, -o its target" "$in" export "$m/link.h5" --format xyz -o "$in" --force
    refused "$m render of a link, -o its target" "$in" render "$m/link.h5" -o "$in" --force
done
# analyze --csv DIR writes DIR/rg.csv and DIR/mass_radius.csv: an input named so
mkdir a
cp dla/cluster.h5 a/rg.csv
refused "analyze --csv over the input" a/rg.csv analyze a/rg.csv --csv a --force

# -o a symlink to the input: its own name, replaced; the input stays
checks=$((checks + 1))
cp dla/cluster.h5 keep.h5
ln -s cluster.h5 dla/out.csv
"$PDLA" export dla/cluster.h5 --format csv -o dla/out.csv --force >out 2>err </dev/null ||
    fail "export -o a symlink to the input: exit $?: $(cat err)"
[ -f dla/out.csv ] && [ ! -L dla/out.csv ] && head -1 dla/out.csv | grep -q '^x,y' ||
    fail "export -o a symlink to the input: dla/out.csv is not the CSV"
cmp -s dla/cluster.h5 keep.h5 || fail "export -o a symlink to the input changed the input"

echo "$checks checks, $fails failed"
[ "$fails" -eq 0 ]
