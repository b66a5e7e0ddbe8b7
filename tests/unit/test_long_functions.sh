#!/usr/bin/env bash
# test_long_functions.sh SOURCE_DIR: no function of src/ over 80 lines
# unless scripts/long-functions.allow lists it with a reason, and no stale
# entry in that list (scripts/long-functions --check). First it checks that
# the check can fail: on a scratch tree, an unlisted 81-line function and an
# entry for a function that is short now must both be reported.
set -u
src=$1
lf="$src/scripts/long-functions"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
mkdir -p "$tmp/src/m"
{
    echo "int long_one(int x)"; echo "{"
    for i in $(seq 1 78); do echo "    x += $i;"; done
    echo "}"
    echo "int short_one(int x)"; echo "{"; echo "    return x;"; echo "}"
} >"$tmp/src/m/a.c"
echo "short_one src/m/a.c was long once" >"$tmp/allow"
out=$(python3 "$lf" --check "$tmp/allow" 80 "$tmp/src")
if [ $? -eq 0 ] || ! grep -q "a.c:1 long_one is 81 lines" <<<"$out" ||
   ! grep -q "short_one in src/m/a.c is no longer over 80" <<<"$out"; then
    echo "FAIL: the check missed a fault: $out"; fail=1
fi
echo "long_one src/m/a.c a reason" >"$tmp/allow"
if ! python3 "$lf" --check "$tmp/allow" 80 "$tmp/src" >/dev/null; then
    echo "FAIL: a listed long function was refused"; fail=1
fi
python3 "$lf" --check "$src/scripts/long-functions.allow" 80 "$src/src" || fail=1
exit $fail
