#!/usr/bin/env bash
# test_layers_selftest.sh SOURCE_DIR: scripts/check-layers must catch each
# kind of layering fault. On a copy of src/, include/ and the header list it
# checks the clean tree passes, then injects one fault at a time and expects
# check-layers to fail naming it: a folder arrow upwards (core -> dla), a
# model using another model (dlca -> event), a library file using the CLI,
# an #include cycle between two headers, the CLI including a library-internal
# header, a public header missing from tests/headers, an unresolvable include,
# a second reader of the monotonic clock, a private copy of the error
# formatter (both shapes the old fail()s had), an HDF5 read outside the
# checked reader.
set -u
src=$1
check="$src/scripts/check-layers"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0

fresh() {
    rm -rf "$tmp/t" && mkdir -p "$tmp/t/tests/headers"
    cp -r "$src/src" "$src/include" "$tmp/t/"
    cp "$src/tests/headers/meson.build" "$tmp/t/tests/headers/"
}

# expect NAME PATTERN: check-layers on the copy fails and prints PATTERN.
expect() {
    local out
    if out=$(python3 "$check" --sources-only "$tmp/t" 2>&1); then
        echo "FAIL $1: check-layers passed"; fail=1
    elif ! grep -q -- "$2" <<<"$out"; then
        echo "FAIL $1: no '$2' in: $out"; fail=1
    else
        echo "ok   $1"
    fi
}

fresh
if ! python3 "$check" --sources-only "$tmp/t"; then echo "FAIL the clean copy"; fail=1; fi

fresh; echo '#include "engine.h"' >>"$tmp/t/src/core/util.c"
expect "core uses dla" "include src/core/util.c -> src/dla/engine.h: folder core may not use folder dla"
fresh; echo '#include "ev_internal.h"' >>"$tmp/t/src/dlca/dlca.c"
expect "model uses model" "src/dlca/dlca.c -> src/event/ev_internal.h: folder dlca may not use folder event"
fresh; echo '#include "../cli/parse.h"' >>"$tmp/t/src/dla/engine.c"
expect "library uses cli" "folder dla may not use folder cli"
fresh; echo '#include "recent.h"' >>"$tmp/t/src/dla/parallel.h"; echo '#include "parallel.h"' >>"$tmp/t/src/dla/recent.h"
expect "header cycle" "#include cycle among src/dla/parallel.h, src/dla/recent.h"
fresh; echo '#include "../core/h5util.h"' >>"$tmp/t/src/cli/info.c"
expect "cli includes src/core" "info.c:.*from outside src/cli/"
fresh; echo '#include "h5util.h"' >>"$tmp/t/src/cli/render.c"
expect "cli include not on its path" "render.c:.*not found on its include path"
fresh; printf '#ifndef X\n#define X\n#endif\n' >"$tmp/t/include/pdla/newmodel.h"
expect "untested public header" "include/pdla/newmodel.h is not in tests/headers/meson.build"
fresh; printf 'static double t(void) { struct timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts); return 0; }\n' >>"$tmp/t/src/dla/grow.c"
expect "a second monotonic clock" "src/dla/grow.c reads CLOCK_MONOTONIC itself"
fresh; printf 'static int fail(char *err, size_t errlen, const char *fmt, ...)\n{\n    return -1;\n}\n' >>"$tmp/t/src/event/ev_sim.c"
expect "a private error formatter" "src/event/ev_sim.c:.*fail() formats an error message itself"
fresh; printf 'static int oops(char *err, size_t errlen, int code, const char *msg)\n{\n    return code;\n}\n' >>"$tmp/t/src/dlca/dlca.c"
expect "a private error formatter (code, message)" "src/dlca/dlca.c:.*oops() formats an error message itself"
fresh; printf 'static int rd(hid_t d, double *v) { return H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v); }\n' >>"$tmp/t/src/dlca/dlca_state.c"
expect "an HDF5 read outside h5check" "src/dlca/dlca_state.c:.*calls H5Dread itself"
fresh; printf 'static int ra(hid_t a, double *v) { return H5Aread(a, H5T_NATIVE_DOUBLE, v); }\n' >>"$tmp/t/src/cli/info.c"
expect "an attribute read outside h5check" "src/cli/info.c:.*calls H5Aread itself"

# The exception lists may only shrink: an entry that matches nothing fails.
fresh; sed -i 's/CLOCK_MONOTONIC/CLOCK_REALTIME/g' "$tmp/t/src/dla/parallel.c"
expect "a stale CLOCK_ALLOWED entry" "CLOCK_ALLOWED entry (src/dla/parallel.c, params3) matches nothing"
fresh; sed 's|^ALLOWED = \[\]$|ALLOWED = [("include", "src/dla/x.c -> src/cli/y.h", "nobody", "stale")]|' "$src/scripts/check-layers" >"$tmp/check-stale"
grep -q '"nobody", "stale"' "$tmp/check-stale" || { echo "FAIL the stale ALLOWED entry was not put in"; fail=1; }
check_real=$check
check="$tmp/check-stale"
expect "a stale ALLOWED entry" "ALLOWED entry (include, src/dla/x.c -> src/cli/y.h, nobody) matches nothing"
check=$check_real

exit $fail
