#!/bin/sh
# test_tools.sh - `pdla info`, `pdla render`, `pdla analyze` as a user meets
# them. Usage: test_tools.sh PDLA TOOLS_FIXTURE [PLOT_CLUSTER]
#
# Clusters are grown with fixed seeds (2D 3000, 3D 2000, 2D 1e5 particles);
# synthetic files of known dimension come from tools_fixture. Checks:
# info text and JSON (python3 -m json.tool); analyze's mass-radius D_f on a
# filled disc (2), a line (1), a filled ball (3) within 0.005..0.03, on one 2D
# cluster of 1e5 in [1.60, 1.80], its M(r) equal to a brute-force count, and
# the same for any slab size; render's PNG read back with libpng (size, not
# empty), byte-identical on a repeat and for a slab smaller than the file;
# 10^7 rows render and analyze under ulimit -v 40 MB (not under ASan);
# --arrival keeps the cluster and stores arrival order; scripts/plot-cluster
# writes its two PNGs (skipped without h5py/matplotlib); every bad input
# exits 2 with one line on stderr and leaves existing outputs alone.
set -u
PDLA=${1:?usage: test_tools.sh PDLA FIXTURE}
FIX=${2:?usage: test_tools.sh PDLA FIXTURE}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
case $FIX in /*) ;; *) FIX=$(pwd)/$FIX ;; esac
PLOT=${3:-}
case $PLOT in /* | '') ;; *) PLOT=$(pwd)/$PLOT ;; esac
PY=python3
[ -x /usr/bin/python3 ] && PY=/usr/bin/python3

tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-tools.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
checks=0
fails=0

fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}

# run ARGS...: status in $rc, output in out, err.
run() {
    checks=$((checks + 1))
    "$PDLA" "$@" >out 2>err </dev/null
    rc=$?
}

good() {
    name=$1
    shift
    run "$@"
    [ "$rc" -eq 0 ] || fail "$name: exit status $rc: $(cat err)"
}

# bad NAME ARGS...: exit 2, nothing on stdout, one "pdla CMD: " line on stderr.
bad() {
    name=$1
    shift
    run "$@"
    [ "$rc" -eq 2 ] || fail "$name: exit status $rc, want 2 ($(cat err))"
    [ -s out ] && fail "$name: wrote to stdout"
    lines=$(wc -l <err)
    [ "$lines" -eq 1 ] || fail "$name: $lines lines on stderr, want 1: $(cat err)"
    case $(cat err) in
    "pdla $1: "*) ;;
    *) fail "$name: stderr does not start with 'pdla $1: ': $(cat err)" ;;
    esac
}

# json_in FILE KEY LO HI: FILE's JSON number KEY lies in [LO, HI].
json_in() {
    checks=$((checks + 1))
    $PY -c "import json,sys; v=json.load(open('$1'))['$2']; sys.exit(0 if v is not None and $3 <= v <= $4 else 1)" ||
        fail "$1: $2 = $($PY -c "import json; print(json.load(open('$1'))['$2'])") not in [$3, $4]"
}

json_ok() {
    checks=$((checks + 1))
    $PY -m json.tool "$1" >/dev/null || fail "$1 is not valid JSON"
}

grow() {
    "$PDLA" -q --seed "$2" --out "$1" "$@" >/dev/null 2>err || fail "growing $1: $(cat err)"
}

# ---- fixtures -----------------------------------------------------------
"$PDLA" -q --dim 2 --target 3000 --seed 5 --out c2 || fail "grow c2"
"$PDLA" -q --dim 2 --target 3000 --seed 5 --arrival --out c2a || fail "grow c2a"
"$PDLA" -q --dim 3 --target 2000 --seed 7 --out c3 || fail "grow c3"
"$PDLA" -q --dim 2 --target 1e5 --seed 1 --out big2 || fail "grow big2"
for k in disc line ball big foreign otherformat wrongdims mismatch rank1; do
    "$FIX" synth $k $k.h5 || fail "synth $k"
done
echo "not an HDF5 file" >text.h5

# ---- help ---------------------------------------------------------------
for t in info render analyze; do
    good "$t --help" $t --help
    grep -q "Usage: pdla $t" out || fail "$t --help has no usage line"
done
good "pdla --help" --help
grep -q "info|render|analyze|export" out || fail "pdla --help does not mention the subcommands"
grep -q "model dlca|event" out || fail "pdla --help does not mention the other models"

# ---- info ---------------------------------------------------------------
good "info 2D" info c2/cluster.h5
grep -q "^particles    3000 in 2D, positions in tree order" out || fail "info: $(head -3 out)"
grep -q "^D_f " out || fail "info: no D_f line"
grep -q "^provenance   pdla" out || fail "info: no provenance"
good "info json" info --json c3/cluster.h5
cp out info3.json
json_ok info3.json
json_in info3.json particles 2000 2000
json_in info3.json dim 3 3
good "info arrival" info --json c2a/cluster.h5
cp out info2a.json
json_ok info2a.json
checks=$((checks + 1))
grep -q '"order": "arrival"' info2a.json || fail "--arrival file not in arrival order"
grep -q '"record_arrival": 1' info2a.json || fail "--arrival not in /parameters"
checks=$((checks + 1))
"$FIX" same c2a/cluster.h5 c2/cluster.h5 || fail "--arrival: not the same cluster, or not seed first"
# Arrival order from worker threads too (recorded under the gyration mutex).
"$PDLA" -q --dim 2 --target 5000 --seed 9 --threads 2 --serial-until 1000 --arrival --out t2a ||
    fail "grow t2a"
good "info threaded arrival" info t2a/cluster.h5
grep -q "^particles    5000 in 2D, positions in arrival order" out || fail "t2a: $(head -3 out)"
good "render threaded arrival" render t2a/cluster.h5 -o t2a.png --size 64 --color arrival
# README: info prints "every attribute of /parameters, /results and /Code as
# stored": the JSON groups hold exactly h5py's attributes with their values
# (the mutex counters, arrays of 3, as arrays: they were left out), and the
# text lists each name with its value(s)
if $PY -c "import h5py, numpy" 2>/dev/null; then
    for c in c2 t2a; do
        good "info json $c" info --json $c/cluster.h5
        cp out info-$c.json
        good "info text $c" info $c/cluster.h5
        cp out info-$c.txt
        checks=$((checks + 1))
        $PY - $c/cluster.h5 info-$c.json info-$c.txt <<'EOF' || fail "info attributes of $c (above)"
import json, sys, h5py, numpy as np
f, j, text = h5py.File(sys.argv[1], "r"), json.load(open(sys.argv[2])), open(sys.argv[3]).read()
bad = []
def same(h, v):
    if isinstance(h, bytes):
        return v == h.decode()
    h = np.asarray(h).ravel().tolist()
    v = v if isinstance(v, list) else [v]
    return len(h) == len(v) and all(a == b or (isinstance(a, float) and abs(a - b) <= 1e-15 * abs(a)) for a, b in zip(h, v))
for g in ("parameters", "results", "Code"):
    a = dict(f[g].attrs)
    if set(a) != set(j[g]):
        bad.append("%s: names only in the file %s, only in the JSON %s" % (g, sorted(set(a) - set(j[g])), sorted(set(j[g]) - set(a))))
    bad += ["%s %s: file %r, JSON %r" % (g, k, a[k], j[g][k]) for k in a if k in j[g] and not same(a[k], j[g][k])]
    section = text.split("[%s]\n" % g)[1].split("\n\n")[0]
    names = [line.split()[0] for line in section.splitlines() if line.strip()]
    if sorted(names) != sorted(a):
        bad.append("text [%s]: %s, want %s" % (g, names, sorted(a)))
m = np.asarray(f["results"].attrs["mutex_taken"]).tolist()
if ("  %-20s %s\n" % ("mutex_taken", " ".join(map(str, m)))) not in text:
    bad.append("text: no 'mutex_taken %s' line" % m)
if bad:
    print("FAIL: info: " + "; ".join(bad[:4]))
    sys.exit(1)
EOF
    done
fi
good "info synthetic" info --json disc.h5
cp out infod.json
json_ok infod.json

# ---- analyze ------------------------------------------------------------
good "analyze text" analyze c2/cluster.h5
grep -q "^D_f (R_g) " out && grep -q "^D_f (M(r)) " out || fail "analyze: $(cat out)"
good "analyze json" analyze --json big2/cluster.h5 --csv csv_big
cp out big.json
json_ok big.json
json_in big.json mr_D_f 1.60 1.80
json_in big.json rg_D_f 1.60 1.85
json_in big.json mr_fit_points 10 1000
checks=$((checks + 1))
"$FIX" mr big2/cluster.h5 csv_big/mass_radius.csv >/dev/null || fail "M(r) of big2 differs from brute force"
head -1 csv_big/rg.csv | grep -q '^N,rg_diam,in_fit$' || fail "rg.csv header"
good "analyze slab" analyze --json --slab-rows 1000 big2/cluster.h5 --csv csv_slab
checks=$((checks + 1))
cmp -s csv_big/mass_radius.csv csv_slab/mass_radius.csv || fail "M(r) depends on the slab size"
# The same cluster in tree and in arrival order has the same M(r).
good "analyze c2" analyze c2/cluster.h5 --csv m_tree
good "analyze c2a" analyze c2a/cluster.h5 --csv m_arr
checks=$((checks + 1))
cmp -s m_tree/mass_radius.csv m_arr/mass_radius.csv || fail "--arrival changed the cluster"
# README: M(r) at r = 10^(i/K) diameters (--per-decade K, default 20), fitted
# over r in [--fit-min (default 5), --fit-max (default 0.3) x R_ext]: the CSV's
# radii and in_fit rows, and the JSON's fit range, by default and when given.
grid_ok() { # CSV JSON K LO FRAC
    checks=$((checks + 1))
    "$PY" - "$@" <<'EOF' || fail "analyze M(r) grid or fit range ($*)"
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
j, k, lo, frac = json.load(open(sys.argv[2])), int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
hi = frac * j["r_ext_diam"]
assert len(rows) > 2 * k, len(rows)
for i, r in enumerate(rows):
    x = float(r["r_diam"])
    assert abs(x / 10 ** (i / k) - 1) < 1e-12, (i, x)
    assert r["in_fit"] == ("1" if lo <= x <= hi else "0"), (i, x, r["in_fit"], lo, hi)
fit = [r for r in rows if r["in_fit"] == "1"]
assert len(fit) == j["mr_fit_points"] >= 3, (len(fit), j["mr_fit_points"])
assert j["mr_fit_r_lo_diam"] == lo and abs(j["mr_fit_r_hi_diam"] / hi - 1) < 1e-12, j
EOF
}
good "analyze c2 json" analyze --json c2/cluster.h5
cp out c2.json
grid_ok m_tree/mass_radius.csv c2.json 20 5 0.3
good "analyze K=10" analyze --json c2/cluster.h5 --per-decade 10 --fit-min 8 --fit-max 0.5 --csv m_k10
cp out c2k10.json
grid_ok m_k10/mass_radius.csv c2k10.json 10 8 0.5
bad "analyze per-decade 1" analyze c2/cluster.h5 --per-decade 1
bad "analyze fit-min 0" analyze c2/cluster.h5 --fit-min 0
for k in disc:1.99:2.01 line:0.995:1.005 ball:2.97:3.03; do
    shape=${k%%:*}
    rest=${k#*:}
    good "analyze $shape" analyze --json $shape.h5 --csv csv_$shape
    cp out $shape.json
    json_in $shape.json mr_D_f "${rest%:*}" "${rest#*:}"
done
checks=$((checks + 1))
"$FIX" mr disc.h5 csv_disc/mass_radius.csv >/dev/null || fail "M(r) of the disc differs from brute force"
good "analyze centre mass" analyze --centre mass --json disc.h5
cp out discm.json
json_in discm.json mr_D_f 1.99 2.01

# ---- render -------------------------------------------------------------
good "render 2D" render c2/cluster.h5 -o r1.png --size 300
checks=$((checks + 1))
"$FIX" png r1.png 300 300 >/dev/null || fail "r1.png is not a 300x300 picture with content"
good "render again" render c2/cluster.h5 -o r2.png --size 300
checks=$((checks + 1))
cmp -s r1.png r2.png || fail "render is not deterministic"
good "render big slab" render big.h5 -o b1.png --size 256 --color radius
good "render big small slab" render big.h5 -o b2.png --size 256 --color radius --slab-rows 1000
checks=$((checks + 1))
cmp -s b1.png b2.png || fail "render depends on the slab size"
"$FIX" png b2.png 256 256 >/dev/null || fail "b2.png"
good "render 3D" render c3/cluster.h5 -o r3.png --size 200 --axis x
"$FIX" png r3.png 200 200 >/dev/null || fail "r3.png"
good "render 3D depth" render c3/cluster.h5 -o r3d.png --size 200 --color depth
"$FIX" png r3d.png 200 200 >/dev/null || fail "r3d.png"
good "render arrival" render c2a/cluster.h5 -o ra.png --size 128 --color arrival
"$FIX" png ra.png 128 128 >/dev/null || fail "ra.png"
good "render zoomed discs" render c2/cluster.h5 -o rz.png --size 400 --zoom 4
"$FIX" png rz.png 400 400 >/dev/null || fail "rz.png"
# The R_g sample grid (README, What it computes): N_0 = 1, then
# N_k = round(10^(k/K)) or N_(k-1) + 1 where that is not larger, up to the
# cluster's N (K = --rg-per-decade, default 100: every N up to 238, then 240,
# 245, 251, ...); c2 (3000 particles, default) and a run with K = 7.
"$PDLA" -q --dim 2 --target 500 --seed 2 --rg-per-decade 7 --out k7 || fail "grow k7"
if $PY -c "import h5py" 2>/dev/null; then
    checks=$((checks + 1))
    $PY - <<'EOF' || fail "R_g sample grid (above)"
import sys, h5py
bad = 0
for h5, k_per, n in (("c2/cluster.h5", 100, 3000), ("k7/cluster.h5", 7, 500)):
    got = [int(x) for x in h5py.File(h5, "r")["gyration/N"][:]]
    want, k = [1], 1
    while True:
        x = max(round(10 ** (k / k_per)), want[-1] + 1)
        if x > n:
            break
        want.append(x)
        k += 1
    if got != want:
        print("FAIL: %s /gyration/N %s ..., want %s ..." % (h5, got[:12], want[:12]))
        bad += 1
c2 = [int(x) for x in h5py.File("c2/cluster.h5", "r")["gyration/N"][:]]
if c2[:238] != list(range(1, 239)) or c2[238:241] != [240, 245, 251]:
    print("FAIL: c2 /gyration/N %s" % c2[230:245])
    bad += 1
sys.exit(1 if bad else 0)
EOF
else
    echo "skipping the R_g grid check (no h5py)"
fi

# Where render puts the particles (README: 2D as they are, x right and y up;
# 3D projected along --axis, default z; --zoom F magnifies F times around
# the seed): every particle's centre pixel is lit and every lit pixel lies
# within its disc (D/2 in pixels, plus 1.5 for the anti-aliased rim) of a
# particle's centre. The whole cluster spans the picture centred on its
# bounding box (half width: half the longer side plus D); zoomed, the seed is
# the centre and the half width is F times smaller.
if $PY -c "import h5py, numpy, PIL" 2>/dev/null; then
    good "render 3D default axis" render c3/cluster.h5 -o geo-c3-.png --size 256
    for ax in x y z; do good "render 3D --axis $ax" render c3/cluster.h5 -o geo-c3-$ax.png --size 256 --axis $ax; done
    good "render 2D" render c2/cluster.h5 -o geo-c2-.png --size 256
    good "render 2D zoom 3" render c2/cluster.h5 -o geo-c2-3.png --size 256 --zoom 3
    good "render 3D zoom 2" render c3/cluster.h5 -o geo-c3-z2.png --size 256 --axis y --zoom 2
    checks=$((checks + 1))
    $PY - <<'EOF' || fail "render geometry (above)"
import sys, h5py, numpy as np
from PIL import Image
def check(h5, png, axis, zoom):
    p = h5py.File(h5, "r")["cluster/positions"][:].astype(float)
    D = 32.0
    u, v = {"x": (1, 2), "y": (0, 2), "z": (0, 1)}[axis] if p.shape[1] == 3 else (0, 1)
    im = np.asarray(Image.open(png).convert("RGB")).astype(int)
    S = im.shape[0]
    lit = np.any(im != im[0, 0], axis=2)
    lo, hi = p.min(0), p.max(0)
    half = 0.5 * max(hi[u] - lo[u], hi[v] - lo[v]) + D
    cu, cv = (0.5 * (lo[u] + hi[u]), 0.5 * (lo[v] + hi[v])) if zoom == 1 else (0.0, 0.0)
    half /= zoom
    s = 0.5 * S / half
    px = (p[:, u] - cu) * s + 0.5 * S
    py = 0.5 * S - (p[:, v] - cv) * s
    near = np.zeros_like(lit)
    r = 0.5 * D * s + 1.5
    yy, xx = np.mgrid[0:S, 0:S] + 0.5
    inside = (px >= 0) & (px < S) & (py >= 0) & (py < S)
    for x, y in zip(px, py):
        a, b = int(max(0, x - r - 1)), int(min(S, x + r + 2))
        c, d = int(max(0, y - r - 1)), int(min(S, y + r + 2))
        if a < b and c < d:
            near[c:d, a:b] |= (xx[c:d, a:b] - x) ** 2 + (yy[c:d, a:b] - y) ** 2 <= r * r
    unlit = [(x, y) for x, y in zip(px[inside], py[inside]) if not lit[int(y), int(x)]]
    stray = np.count_nonzero(lit & ~near)
    if unlit or stray or not inside.any():
        print("FAIL: %s (axis %s, zoom %g): %d particle centres unlit (first %s), %d lit pixels off every particle, %d in view"
              % (png, axis, zoom, len(unlit), unlit[:1], stray, np.count_nonzero(inside)))
        return 1
    return 0
bad = sum(check(*c) for c in (("c3/cluster.h5", "geo-c3-.png", "z", 1), ("c3/cluster.h5", "geo-c3-x.png", "x", 1),
                              ("c3/cluster.h5", "geo-c3-y.png", "y", 1), ("c3/cluster.h5", "geo-c3-z.png", "z", 1),
                              ("c2/cluster.h5", "geo-c2-.png", "z", 1), ("c2/cluster.h5", "geo-c2-3.png", "z", 3),
                              ("c3/cluster.h5", "geo-c3-z2.png", "y", 2)))
sys.exit(1 if bad else 0)
EOF
    # README: --color radius colours by the distance from the seed and
    # --color arrival by arrival order, in the inferno map, whose brightness
    # rises: at each particle's centre pixel (discs of about 5 pixels) the
    # brightness never falls (beyond 1 of 255) along that order, from dark to
    # bright
    good "render radius colours" render c2a/cluster.h5 -o col-r.png --size 1024 --color radius
    good "render arrival colours" render c2a/cluster.h5 -o col-a.png --size 1024 --color arrival
    checks=$((checks + 1))
    $PY - <<'EOF' || fail "render colour order (above)"
import sys, h5py, numpy as np
from PIL import Image
p = h5py.File("c2a/cluster.h5", "r")["cluster/positions"][:].astype(float)
S, D = 1024, 32.0
lo, hi = p.min(0), p.max(0)
s = 0.5 * S / (0.5 * max(hi - lo) + D)
px = ((p[:, 0] - 0.5 * (lo[0] + hi[0])) * s + 0.5 * S).astype(int)
py = (0.5 * S - (p[:, 1] - 0.5 * (lo[1] + hi[1])) * s).astype(int)
bad = 0
for png, key in (("col-r.png", np.hypot(p[:, 0], p[:, 1])), ("col-a.png", np.arange(len(p)))):
    im = np.asarray(Image.open(png).convert("RGB")).astype(float)
    lum = (im[py, px] @ [0.299, 0.587, 0.114])[np.argsort(key, kind="stable")]
    drops = np.count_nonzero(np.diff(lum) < -1)
    if drops or lum[0] > 40 or lum[-1] < 200:
        print("FAIL: %s: brightness falls %d times along the order, first %.0f, last %.0f" % (png, drops, lum[0], lum[-1]))
        bad += 1
sys.exit(1 if bad else 0)
EOF
else
    echo "skipping the render geometry check (no h5py, numpy or PIL)"
fi
# README: --size default 1024, --color default density, --axis default z
good "render defaults" render c3/cluster.h5 -o def.png
"$FIX" png def.png 1024 1024 >/dev/null || fail "render without --size: not 1024 x 1024"
good "render defaults given" render c3/cluster.h5 -o defg.png --size 1024 --color density --axis z
checks=$((checks + 1))
cmp -s def.png defg.png || fail "render's defaults are not --size 1024 --color density --axis z"
good "render --force" render c2/cluster.h5 -o r1.png --size 64 --force
"$FIX" png r1.png 64 64 >/dev/null || fail "--force did not replace r1.png"

# Bounded memory: 10^7 rows (80 MB of positions) render and analyze within
# 40 MB of address space (ulimit -v; 30 MB is what a tiny file needs).
# Skipped under AddressSanitizer, which reserves terabytes of address space.
if ldd "$PDLA" 2>/dev/null | grep -q libasan; then
    echo "skipping the ulimit -v check under AddressSanitizer"
else
    "$FIX" synth huge huge.h5 || fail "synth huge"
    checks=$((checks + 1))
    (ulimit -v 40000 && exec "$PDLA" render huge.h5 -o huge.png --size 256) 2>err ||
        fail "render of 10^7 rows in 40 MB: $(cat err)"
    "$FIX" png huge.png 256 256 >/dev/null || fail "huge.png"
    checks=$((checks + 1))
    (ulimit -v 40000 && exec "$PDLA" analyze huge.h5 >out) 2>err ||
        fail "analyze of 10^7 rows in 40 MB: $(cat err)"
    rm -f huge.h5
fi

# ---- scripts/plot-cluster -----------------------------------------------
if [ -z "$PLOT" ] || ! /usr/bin/python3 -c "import h5py, matplotlib, numpy" 2>/dev/null; then
    echo "skipping plot-cluster (no script given, or no h5py/matplotlib/numpy)"
else
    checks=$((checks + 1))
    /usr/bin/python3 "$PLOT" c2/cluster.h5 -o plots --pdla "$PDLA" >/dev/null 2>err ||
        fail "plot-cluster: $(cat err)"
    for p in rg mass_radius; do
        head -c 8 plots/$p.png 2>/dev/null | grep -q PNG || fail "plot-cluster wrote no plots/$p.png"
    done
    checks=$((checks + 1))
    /usr/bin/python3 "$PLOT" c2/cluster.h5 -o plots --pdla "$PDLA" >/dev/null 2>err &&
        fail "plot-cluster overwrote its plots without --force"
fi

# ---- bad input ----------------------------------------------------------
for t in info render analyze; do
    o=
    [ $t = render ] && o="-o new.png"
    bad "$t missing file" $t missing.h5 $o
    bad "$t text file" $t text.h5 $o
    bad "$t directory" $t c2 $o
    for k in foreign otherformat wrongdims mismatch rank1; do
        bad "$t $k" $t $k.h5 $o
    done
    bad "$t unknown flag" $t --bogus c2/cluster.h5 $o
    bad "$t no file" $t $o
    bad "$t two files" $t c2/cluster.h5 c3/cluster.h5 $o
done
checks=$((checks + 1))
[ -e new.png ] && fail "a failed render left new.png"
cp r2.png keep.png
bad "render existing" render c2/cluster.h5 -o r2.png --size 64
checks=$((checks + 1))
cmp -s r2.png keep.png || fail "render overwrote r2.png without --force"
bad "render unwritable" render c2/cluster.h5 -o /nonexistent-dir/x.png
bad "render no -o" render c2/cluster.h5
bad "render bad size" render c2/cluster.h5 -o x.png --size 5
bad "render bad color" render c2/cluster.h5 -o x.png --color plaid
bad "render arrival on tree order" render c2/cluster.h5 -o x.png --color arrival
bad "render depth in 2D" render c2/cluster.h5 -o x.png --color depth
checks=$((checks + 1))
[ -e x.png ] && fail "a refused render left x.png"
cp csv_disc/mass_radius.csv keep.csv
bad "analyze existing csv" analyze disc.h5 --csv csv_disc
checks=$((checks + 1))
cmp -s csv_disc/mass_radius.csv keep.csv || fail "analyze overwrote its CSV without --force"
good "analyze csv --force" analyze disc.h5 --csv csv_disc --force
bad "analyze csv on a file" analyze disc.h5 --csv text.h5
bad "analyze bad centre" analyze disc.h5 --centre middle
bad "analyze bad fit-max" analyze disc.h5 --fit-max 2
# Damaged files: a truncated one cannot be opened (2); a flipped chunk fails
# its Fletcher32 checksum while streaming (1); one line, no picture.
head -c 200000 big2/cluster.h5 >trunc.h5
for t in info analyze render; do
    o=
    [ $t = render ] && o="-o dmg.png"
    bad "$t truncated" $t trunc.h5 $o
done
cp big2/cluster.h5 corrupt.h5
printf 'UUUUUUUU' | dd of=corrupt.h5 bs=1 seek=300000 conv=notrunc 2>/dev/null
for t in analyze render; do
    o=
    [ $t = render ] && o="-o dmg.png"
    run $t corrupt.h5 $o
    [ "$rc" -eq 1 ] || fail "$t corrupt: exit status $rc, want 1"
    [ "$(wc -l <err)" -eq 1 ] || fail "$t corrupt: $(cat err)"
    grep -q "cannot read rows" err || fail "$t corrupt: $(cat err)"
done
checks=$((checks + 1))
[ -e dmg.png ] && fail "a failed render left dmg.png"
# Nothing of the HDF5 error stack reaches the terminal (bad() counts lines),
# and the messages say what is wrong.
run info foreign.h5
grep -q 'not a pdla cluster file (no format = "pdla-cluster" attribute)' err || fail "foreign: $(cat err)"
run info text.h5
grep -q 'is not an HDF5 file' err || fail "text: $(cat err)"
run info wrongdims.h5
grep -q 'has 4 columns' err || fail "wrongdims: $(cat err)"
run info missing.h5
grep -q 'No such file' err || fail "missing: $(cat err)"

echo "$checks checks, $fails failed"
[ "$fails" -eq 0 ]
