#!/usr/bin/python3
"""test_check_dlca.py PDLA - `pdla check` of DLCA files (cluster.h5 and
checkpoint.h5; src/dlca/dlca_check*.c, src/cli/check_dlca.c).

Pass (exit 0, "result       pass", every check's line): grown 2D, 3D, 4D
and 5D files; --search boxes and allpairs; --mobility, --drift and
--sticking < 1; stops by clusters (2D), time (3D), attempts (5D) and
spanning (2D and a 4D box of side 6), each asserted; --snapshot-every; a --start text file and a --start
cluster.h5; a run resumed from its checkpoint; a run stopped by SIGINT
(stop "running"); checkpoints (model dlca-checkpoint), with snapshots.
--json gives one object with every check's count.

Fail (exit 1, the report naming the check, one line on stderr), each on a
copy of a passing file changed in one way: a monomer moved onto another's
site (shared); a leaf monomer moved to an empty site away from everything
(pieces); a lone monomer moved next to another cluster (touch); a
position outside the box (box); a /monomers/site that is not its
position's (site); two clusters' numbers swapped (numbering); /results
n_clusters + 1 and weight_average_size one ulp up (results); a
/clusters/size + 1 (size); a /clusters/rg one ulp up (rg); the series' last
row's largest - 1 (series); the stop 'clusters' made 'time' (stop), a
spanning stop made 'clusters' and a clusters stop made 'spanning'
(spanning); a lone monomer moved next to another cluster in snapshot 0
(snapshots) and a snapshot count above the snapshots held (snapshots);
every monomer on one site, 13000 monomers: reading stops at 10000 failures.
A snapshot's /snapshots/<i>/position that is not the coordinates of its
sites (a row moved one site, in a cluster.h5 and in a checkpoint; two rows
swapped; every row of every snapshot moved, one failure a row) or not as
pdla writes it (removed, float64, 3 columns, declared and not stored, one
gzip'ed chunk of 2^22 rows, 2^40 rows declared) fails (snapshots), the
first failure naming the snapshot and the dataset, under 200 MB.
A checkpoint the loader refuses (merges forged) fails with the loader's
line; one whose series row's mean size is one ulp off, which the loader
takes (it checks a range), fails the series check.

Refused (exit 2, one line on stderr, nothing on stdout): /monomers/cluster,
/clusters and /series/largest missing; /monomers/position declaring 2^40
rows the file does not store; a box of 100000 x 100000 (over the model's
axis limit, before any bitmap); format_version 2. A forged box of
16384 x 16384 (within the limits: a 32 MiB bitmap) fails in bounded memory
(peak RSS under 200 MB). /results missing fails (exit 1, results).
104858 monomers in a 1024^2 box peak under 80 bytes a monomer (and the
box's bit a site) above a small file's check (release builds; under ASan
within 200 MB).

test_check_dlca.py PDLA --shim FAULTSHIM (test tools-check-dlca-memory):
under FAULT_PHYS_PAGES=4, a 16 KiB machine, a cluster.h5 and a checkpoint
are refused before the check allocates (exit 1, one line).
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally, child_peak_rss, forged_copy as forged, run_text as run, shim_preload  # noqa: E402

T = Tally()
PDLA = sys.argv[1]
KINDS = ["box", "site", "shared", "numbering", "pieces", "touch", "spanning", "size", "rg", "results", "stop",
         "series", "snapshots"]


def grow(tmp, name, args, ckpt=False):
    out = os.path.join(tmp, name)
    rc, _, err = run([PDLA, "--model", "dlca", *args, "--out", out, "-q"] + (["--checkpoint"] if ckpt else []))
    T.check(rc == 0, "grow %s: rc %d %s" % (name, rc, err))
    return out


def check(path, want_rc, kinds=(), what=""):
    """pdla check PATH: the exit status, and for a failure the kinds named
    FAILED in the report (and only those when kinds is given exactly)."""
    rc, out, err = run([PDLA, "check", path])
    T.check(rc == want_rc, "%s: rc %d, want %d\n%s%s" % (what, rc, want_rc, out, err))
    if want_rc == 0:
        T.check(out.endswith("result       pass\n") and err == "", "%s: report %r %r" % (what, out, err))
        T.check(all(("\n%-12s " % k) in out for k in KINDS), "%s: a check's line is missing\n%s" % (what, out))
    if want_rc == 1 and kinds:
        failed = [k for k in KINDS if ("\n%-12s " % k) in out and out.split("\n%-12s " % k)[1].split("\n")[0]
                  .split(" ")[1:2] == ["FAILED;"]]
        for k in kinds:
            T.check(k in failed, "%s: %s not named in the report (failed: %s)\n%s" % (what, k, failed, out))
        T.check(err.count("\n") == 1 and "fails the check" in err and kinds[0] in err,
                "%s: stderr %r" % (what, err))
    if want_rc == 2:
        T.check(out == "" and err.count("\n") == 1 and err.startswith("pdla check: "),
                "%s: want one line on stderr, got %r / %r" % (what, out, err))
    return out, err


def passing(tmp):
    runs = {}
    runs["2d"] = grow(tmp, "2d", ["--dim", "2", "--box", "64", "--fill", "0.05", "--until-clusters", "60",
                                  "--seed", "1"], ckpt=True)
    runs["span"] = grow(tmp, "span", ["--dim", "2", "--box", "32", "--fill", "0.3", "--seed", "1"], ckpt=True)
    runs["3d"] = grow(tmp, "3d", ["--dim", "3", "--box", "16", "--fill", "0.08", "--search", "boxes", "--seed", "2"])
    runs["3dr"] = grow(tmp, "3dr", ["--dim", "3", "--box", "12x16x20", "--fill", "0.05", "--mobility", "-0.5",
                                    "--until-time", "40", "--seed", "3"])
    runs["4d"] = grow(tmp, "4d", ["--dim", "4", "--box", "6", "--fill", "0.1", "--seed", "4"])
    runs["5d"] = grow(tmp, "5d", ["--dim", "5", "--box", "8", "--fill", "0.02", "--search", "allpairs",
                                  "--max-attempts", "200", "--seed", "5"])
    runs["soft"] = grow(tmp, "soft", ["--dim", "2", "--box", "64", "--fill", "0.08", "--sticking", "0.6",
                                      "--drift", "0.2", "--mobility", "0.5", "--until-clusters", "20", "--seed", "6"])
    runs["snap"] = grow(tmp, "snap", ["--dim", "2", "--box", "64", "--fill", "0.05", "--snapshot-every", "3",
                                      "--until-clusters", "30", "--seed", "7"], ckpt=True)
    txt = os.path.join(tmp, "start.txt")
    with open(txt, "w") as f:
        f.write("# a start file\n0 0\n1 0\n5 5\n10 3\n31 31\n0 31\n")
    runs["start"] = grow(tmp, "start", ["--dim", "2", "--box", "32", "--start", txt, "--seed", "8"])
    runs["starth5"] = grow(tmp, "starth5", ["--dim", "2", "--box", "64x80", "--until-clusters", "5", "--start",
                                            os.path.join(runs["2d"], "cluster.h5")])
    runs["resumed"] = grow(tmp, "resumed", ["--dim", "2", "--box", "128", "--fill", "0.03", "--max-attempts", "5000",
                                            "--seed", "9"], ckpt=True)
    rc, _, err = run([PDLA, "--model", "dlca", "--resume", runs["resumed"], "--max-attempts", "20000", "-q"])
    T.check(rc == 0, "resume: %s" % err)
    stops = {"2d": "clusters", "span": "spanning", "3dr": "time", "4d": "spanning", "5d": "attempts"}
    for name, d in sorted(runs.items()):
        o, _ = check(os.path.join(d, "cluster.h5"), 0, (), "grown " + name)
        T.check(name not in stops or "; stop %s\n" % stops[name] in o, "grown %s: not the stop %s\n%s"
                % (name, stops.get(name), o))
        if os.path.exists(os.path.join(d, "checkpoint.h5")):
            check(os.path.join(d, "checkpoint.h5"), 0, (), "checkpoint " + name)
    return runs


def signal_stop(tmp):
    """A run stopped by SIGINT writes stop 'running' and a checkpoint."""
    out = os.path.join(tmp, "sig")
    p = subprocess.Popen([PDLA, "--model", "dlca", "--dim", "2", "--box", "1024", "--fill", "0.03", "--out", out,
                          "-q", "--checkpoint"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(0.3)  # the run takes minutes to one cluster
    p.send_signal(signal.SIGINT)
    p.wait(timeout=60)
    o, _ = check(os.path.join(out, "cluster.h5"), 0, (), "stopped by SIGINT")
    T.check("stop running" in o, "SIGINT run: %s" % o)
    check(os.path.join(out, "checkpoint.h5"), 0, (), "checkpoint of a SIGINT stop")


def json_report(runs):
    rc, out, err = run([PDLA, "check", "--json", os.path.join(runs["span"], "cluster.h5")])
    try:
        j = json.loads(out)
    except ValueError:
        j = {}
    T.check(rc == 0 and j.get("pass") is True and j.get("stop") == "spanning" and j.get("spanning_clusters", 0) >= 1
            and j.get("rg_bounded", 0) >= 1 and sorted(j.get("failures", {})) == sorted(KINDS)
            and all(v == {"count": 0, "first": None} for v in j["failures"].values()),
            "json of a spanning run: %d %r %r" % (rc, out, err))


# ---- forging helpers ----------------------------------------------------------

def arrays(f):
    L = [int(v) for v in f["parameters"].attrs["box"]]
    pos = f["monomers/position"][:].astype(np.int64)
    cl = f["monomers/cluster"][:]
    return L, pos, cl


def site_of(L, x):
    k, s = 0, 1
    for a, v in enumerate(x):
        k += (int(v) % L[a]) * s
        s *= L[a]
    return k


def neighbours(L, x):
    for a in range(len(L)):
        for sg in (1, -1):
            y = list(x)
            y[a] = (y[a] + sg) % L[a]
            yield tuple(y)


def occupancy(pos):
    return {tuple(int(v) for v in p): i for i, p in enumerate(pos)}


def put(f, L, pos, i, x):
    """Monomer i to site x, position and site both."""
    p = f["monomers/position"]
    row = p[i]
    row[:] = x
    p[i] = row
    s = f["monomers/site"]
    s[i] = site_of(L, x)


def all_sites(L):
    return [tuple(int(v) for v in np.unravel_index(k, L[::-1])[::-1]) for k in range(int(np.prod(L)))]


def move_apart(f):
    """A leaf monomer of the largest cluster to a site with no neighbour."""
    L, pos, cl = arrays(f)
    occ = occupancy(pos)
    big = np.bincount(cl).argmax()
    for i in np.nonzero(cl == big)[0]:
        own = [occ[y] for y in neighbours(L, tuple(pos[i])) if y in occ]
        if len(own) == 1 and i != np.nonzero(cl == big)[0][0]:
            break
    for x in all_sites(L):
        if x not in occ and not any(y in occ for y in neighbours(L, x)):
            put(f, L, pos, int(i), x)
            return
    raise RuntimeError("no free site")


def lone_next_to(L, pos, cl, sizes, site_of_row=None):
    """(i, x): a lone monomer i and an empty site x beside one monomer of
    another cluster, its other neighbours empty."""
    occ = occupancy(pos)
    lone = [i for i in range(len(cl)) if sizes[cl[i]] == 1]
    for i in lone:
        for j in range(len(cl)):
            if cl[j] == cl[i]:
                continue
            for x in neighbours(L, tuple(pos[j])):
                if x in occ:
                    continue
                near = [occ[y] for y in neighbours(L, x) if y in occ and occ[y] != i]
                if near == [j]:
                    return i, x
    raise RuntimeError("no lone monomer to move")


def make_touch(f):
    L, pos, cl = arrays(f)
    i, x = lone_next_to(L, pos, cl, np.bincount(cl))
    put(f, L, pos, i, x)


def move_onto(f):
    L, pos, cl = arrays(f)
    big = np.bincount(cl).argmax()
    i = int(np.nonzero(cl == big)[0][1])
    j = int(np.nonzero(cl != big)[0][0])
    put(f, L, pos, i, tuple(pos[j]))


def outside(f):
    p = f["monomers/position"]
    row = p[3]
    row[0] = f["parameters"].attrs["box"][0]
    p[3] = row


def bump(ds, i, fn):
    v = ds[...]
    v[i] = fn(v[i])
    ds[...] = v


def swap_numbers(f):
    cl = f["monomers/cluster"][:]
    a, b = cl == 0, cl == 1
    cl[a], cl[b] = 1, 0
    f["monomers/cluster"][...] = cl


def set_attr(group, name, value):
    group.attrs.modify(name, value)


def snapshot_touch(f):
    """A lone monomer moved next to another cluster in snapshot 0: its site
    and its position both, so that only the touch is wrong."""
    L = [int(v) for v in f["parameters"].attrs["box"]]
    g = f["snapshots/0"]
    sites = g["site"][:]
    cl = g["cluster"][:]
    pos = np.array([[(int(k) // int(np.prod(L[:a]))) % L[a] for a in range(len(L))] for k in sites])
    i, x = lone_next_to(L, pos, cl, np.bincount(cl))
    sites[i] = site_of(L, x)
    g["site"][...] = sites
    p = g["position"][:]
    p[i] = x
    g["position"][...] = p


def forgeries(runs, tmp):
    c2 = os.path.join(runs["2d"], "cluster.h5")
    ulp_up = np.nextafter
    cases = [
        (c2, "shared", move_onto, ["shared"]),
        (c2, "apart", move_apart, ["pieces"]),
        (c2, "touch", make_touch, ["touch"]),
        (c2, "outside", outside, ["box"]),
        (c2, "site", lambda f: bump(f["monomers/site"], 5, lambda v: v ^ 1), ["site"]),
        (c2, "numbering", swap_numbers, ["numbering"]),
        (c2, "nclusters", lambda f: set_attr(f["results"], "n_clusters", np.uint64(61)), ["results"]),
        (c2, "weight", lambda f: set_attr(f["results"], "weight_average_size",
                                          ulp_up(f["results"].attrs["weight_average_size"], 1e300)), ["results"]),
        (c2, "size", lambda f: bump(f["clusters/size"], 2, lambda v: v + 1), ["size"]),
        (c2, "rg", lambda f: bump(f["clusters/rg"], 0, lambda v: ulp_up(v, 1e300)), ["rg"]),
        (c2, "series", lambda f: bump(f["series/largest"], -1, lambda v: v - 1), ["series"]),
        (c2, "stop", lambda f: set_attr(f["results"], "stop", "time"), ["stop"]),
        (c2, "claim", lambda f: set_attr(f["results"], "stop", "spanning"), ["spanning"]),
        (os.path.join(runs["span"], "cluster.h5"), "unclaimed", lambda f: set_attr(f["results"], "stop", "clusters"),
         ["spanning"]),
        (os.path.join(runs["snap"], "cluster.h5"), "snaptouch", snapshot_touch, ["snapshots"]),
        (os.path.join(runs["snap"], "cluster.h5"), "snapcount",
         lambda f: set_attr(f["snapshots"], "count", np.uint64(f["snapshots"].attrs["count"] + 1)), ["snapshots"]),
        (os.path.join(runs["soft"], "cluster.h5"), "softapart", move_apart, ["pieces"]),
    ]
    for src, name, fn, kinds in cases:
        check(forged(src, tmp, name, fn), 1, kinds, "forged " + name)


def first_of(out, kind):
    """The report's line of kind, without its name."""
    lines = [ln for ln in out.split("\n") if ln.startswith("%-12s " % kind)]
    return lines[0][13:] if lines else ""


def shift_row(snap, row, axis=0):
    """Snapshot snap's position row moved one site along axis (inside the
    box): the site is left as it was."""
    def fn(f):
        L = [int(v) for v in f["parameters"].attrs["box"]]
        p = f["snapshots/%d/position" % snap][:]
        p[row, axis] = (p[row, axis] + 1) % L[axis]
        f["snapshots/%d/position" % snap][...] = p
    return fn


def replace_position(snap, **kw):
    """Snapshot snap's position dataset made anew with h5py's
    create_dataset(**kw) (data=... or shape=... and dtype=...)."""
    def fn(f):
        g = f["snapshots/%d" % snap]
        del g["position"]
        g.create_dataset("position", **kw)
    return fn


def snapshot_positions(runs, tmp):
    """Each snapshot's /snapshots/<i>/position must be the coordinates the
    writer derives from its sites (dlca_output.c, write_snapshot), exactly;
    a position dataset pdla cannot have written is damage, in bounded
    memory: each a failure of `snapshots` (exit 1) naming the snapshot and
    the dataset. Before session 31 the check read no snapshot position and
    every one of these passed."""
    c = os.path.join(runs["snap"], "cluster.h5")
    ck = os.path.join(runs["snap"], "checkpoint.h5")
    with h5py.File(c, "r") as f:
        N = f["monomers/site"].shape[0]
        snaps = int(f["snapshots"].attrs["count"])
        p2 = f["snapshots/2/position"][:]
    swapped = p2.copy()
    swapped[[0, 1]] = swapped[[1, 0]]
    cases = [
        (c, "snappos", shift_row(1, 3), 1, "snapshot 1: /snapshots/1/position row 3 is"),
        (ck, "ckpos", shift_row(1, 3, 1), 1, "snapshot 1: /snapshots/1/position row 3 is"),
        (c, "snapswap", replace_position(2, data=swapped), 2, "snapshot 2: /snapshots/2/position row 0 is"),
        (c, "snapgone", lambda f: f["snapshots/0"].__delitem__("position"), 1, "snapshot 0: /snapshots/0/position"),
        (c, "snapf64", replace_position(0, data=p2.astype("<f8")), 1, "snapshot 0: /snapshots/0/position is"),
        (c, "snapcols", replace_position(0, data=np.zeros((N, 3), "<i4")), 1, "snapshot 0: /snapshots/0/position is"),
        (c, "snapunstored", replace_position(0, shape=(N, 2), dtype="<i4"), 1,
         "snapshot 0: /snapshots/0/position declares"),
        (c, "snapchunk", replace_position(0, data=p2, maxshape=(None, 2), chunks=(1 << 22, 2), compression="gzip"), 1,
         "snapshot 0: /snapshots/0/position is stored in chunks of 4194304 rows"),
    ]
    for src, name, fn, nfail, text in cases:
        path = forged(src, tmp, name, fn)
        rc, kb = peak_rss_kb([PDLA, "check", path])
        out, err = check(path, 1, ["snapshots"], "forged " + name)
        want = "%d FAILED; first: %s" % (nfail, text)
        T.check(first_of(out, "snapshots").startswith(want) and rc == 1 and kb < 200000,
                "forged %s: rc %d, %d kB, want %r\n%s" % (name, rc, kb, want, out))
    # 2^40 rows declared and none stored: refused before a slab is read
    path = forged(c, tmp, "snapdeclared", replace_position(0, shape=(1 << 40, 2), dtype="<i4", chunks=(65536, 2)))
    t0 = time.time()
    rc, kb = peak_rss_kb([PDLA, "check", path])
    out, _ = check(path, 1, ["snapshots"], "forged snapdeclared")
    T.check(rc == 1 and kb < 200000 and time.time() - t0 < 20 and
            first_of(out, "snapshots").startswith("1 FAILED; first: snapshot 0: /snapshots/0/position is"),
            "2^40 snapshot positions declared: rc %d, %d kB, %.1f s\n%s" % (rc, kb, time.time() - t0, out))
    # every row of every snapshot moved: one failure a row, up to the cap
    def all_moved(f):
        for k in f["snapshots"]:
            p = f["snapshots/%s/position" % k][:]
            f["snapshots/%s/position" % k][...] = (p + 1) % 64
    out, _ = check(forged(c, tmp, "snapall", all_moved), 1, ["snapshots"], "every snapshot position moved")
    T.check(first_of(out, "snapshots").startswith("%d FAILED; first: snapshot 0: /snapshots/0/position row 0 is"
                                                  % (N * snaps)), "every snapshot position moved:\n%s" % out)
    out, _ = check(forged(c, tmp, "snaptouch2", snapshot_touch), 1, ["snapshots"], "snapshot touch")
    T.check("touch" in first_of(out, "snapshots"), "snapshot touch: the first failure is not the touch\n%s" % out)


def checkpoint_forgeries(runs, tmp):
    ck = os.path.join(runs["2d"], "checkpoint.h5")

    def merges(f):
        u = f["u64"][:]
        u[3] += 1  # CK_U_MRG
        f["u64"][...] = u
    o, e = check(forged(ck, tmp, "ckmerges", merges), 1, (), "checkpoint the loader refuses")
    T.check(o == "" and "merges counter" in e and e.count("\n") == 1, "loader refusal: %r %r" % (o, e))

    def mean(f):
        r = f["rows_f64"][:]
        r[3 * 1 + 1] = np.nextafter(r[3 * 1 + 1], 1e300)  # row 1's mean size
        f["rows_f64"][...] = r
    check(forged(ck, tmp, "ckmean", mean), 1, ["series"], "checkpoint with a row's mean size off by one ulp")


def many_failures(tmp):
    d = grow(tmp, "many", ["--dim", "2", "--box", "512", "--fill", "0.05", "--max-attempts", "100", "--seed", "1"])

    def one_site(f):
        f["monomers/position"][...] = np.zeros(f["monomers/position"].shape, np.int32)
        f["monomers/site"][...] = np.zeros(f["monomers/site"].shape, np.uint32)
    t0 = time.time()
    o, _ = check(forged(os.path.join(d, "cluster.h5"), tmp, "onesite", one_site), 1, ["shared"], "all on one site")
    T.check("STOPPED after 10000 failures" in o and "10000 FAILED" in o and time.time() - t0 < 5,
            "failure cap: %.1f s\n%s" % (time.time() - t0, o))


def peak_rss_kb(args):
    rc, _, kb = child_peak_rss(args, 120)
    return rc, kb


def hostile(runs, tmp):
    c2 = os.path.join(runs["2d"], "cluster.h5")
    for name, fn in (("nocluster", lambda f: f["monomers"].__delitem__("cluster")),
                     ("noclusters", lambda f: f.__delitem__("clusters")),
                     ("noseries", lambda f: f["series"].__delitem__("largest")),
                     ("version", lambda f: set_attr(f, "format_version", np.int32(2))),
                     ("hugebox", lambda f: set_attr(f["parameters"], "box", np.array([100000, 100000], np.uint64)))):
        check(forged(c2, tmp, name, fn), 2, (), "refused " + name)

    def one_chunk_series(f):
        # six /series columns each one gzip'ed chunk of 2^22 rows: each kept
        # its decompressed chunk (6 x 32 MB here, 3.2 GB at 2^26) before the
        # columns were held to pdla's 65536-row chunks
        for n in ("t", "attempts", "n_clusters", "largest", "mean_size", "weight_average_size"):
            dt = f["series/" + n].dtype
            del f["series/" + n]
            f["series"].create_dataset(n, data=np.zeros(2 ** 22, dt), chunks=(2 ** 22,), compression="gzip")
    _, e = check(forged(c2, tmp, "count", lambda f: set_attr(f["parameters"], "count", np.uint64(500))), 2, (),
                 "count 500")
    T.check("/parameters count 500" in e, "count 500: %r" % e)
    _, e = check(forged(c2, tmp, "one_chunk_series", one_chunk_series), 2, (), "one-chunk series")
    T.check("chunks of 4194304 rows" in e, "one-chunk series: %r" % e)

    def declared(f):
        del f["monomers/position"]
        f["monomers"].create_dataset("position", shape=(2 ** 40, 2), dtype="<i4", chunks=(65536, 2))
    _, e = check(forged(c2, tmp, "declared", declared), 2, (), "2^40 rows declared")
    T.check("more than the file stores" in e, "declared rows: %r" % e)
    check(forged(c2, tmp, "noresults", lambda f: f.__delitem__("results")), 1, ["results"], "no /results")
    def bigbox(f):
        set_attr(f["parameters"], "box", np.array([16384, 16384], np.uint64))
        # count = N, so that the parameters still give N and the bitmap is made
        set_attr(f["parameters"], "count", np.uint64(f["monomers/site"].shape[0]))
    big = forged(c2, tmp, "bigbox", bigbox)
    rc, kb = peak_rss_kb([PDLA, "check", big])
    T.check(rc == 1 and kb < 200000, "16384^2 box: rc %d, peak RSS %d kB" % (rc, kb))


def memory(tmp):
    """Peak RSS beyond a small file's: a bit a site and dck_fits' 56 bytes a
    monomer in 2D (allowed 80, and 1 MB of slack)."""
    d = grow(tmp, "mem", ["--dim", "2", "--box", "1024", "--fill", "0.1", "--max-attempts", "1", "--seed", "2"])
    rc0, kb0 = peak_rss_kb([PDLA, "check", os.path.join(d, "..", "2d", "cluster.h5")])
    rc, kb = peak_rss_kb([PDLA, "check", os.path.join(d, "cluster.h5")])
    n, v = 104858, 1024 * 1024
    # ASan's shadow memory and redzones add their own share: bounded there
    # by the other cases' 200 MB, measured here in release builds only
    ldd = subprocess.run(["ldd", PDLA], capture_output=True, text=True).stdout
    bound = (v / 8 + 80 * n) / 1024 + 1024 if "libasan" not in ldd else 200000
    T.check(rc0 == 0 and rc == 0 and kb - kb0 < bound,
            "memory: %d kB beyond a small file's for %d monomers (rc %d %d)" % (kb - kb0, n, rc0, rc))


def memory_refused(shim):
    """Under faultshim's FAULT_PHYS_PAGES=4 (a 16 KiB machine) the check of
    205 monomers (about 12 KB) is refused before it allocates, exit 1, for a
    cluster.h5 and a checkpoint alike."""
    tmp = tempfile.mkdtemp(prefix="pdla-check-dlca-mem-")
    try:
        d = grow(tmp, "small", ["--dim", "2", "--box", "64", "--fill", "0.05", "--seed", "1"], ckpt=True)
        env = dict(os.environ, LD_PRELOAD=shim_preload(PDLA, shim), FAULT_PHYS_PAGES="4")
        for f in ("cluster.h5", "checkpoint.h5"):
            p = subprocess.run([PDLA, "check", os.path.join(d, f)], capture_output=True, env=env, timeout=60)
            err = p.stderr.decode(errors="replace")
            T.check(p.returncode == 1 and p.stdout == b"" and err.count("\n") == 1 and "half of this machine's memory"
                    in err, "%s on a 16 KiB machine: rc %d %r" % (f, p.returncode, err))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    T.done()


def main():
    if sys.argv[2:3] == ["--shim"]:
        memory_refused(sys.argv[3])
        return
    tmp = tempfile.mkdtemp(prefix="pdla-check-dlca-")
    t0 = time.time()
    try:
        runs = passing(tmp)
        signal_stop(tmp)
        json_report(runs)
        forgeries(runs, tmp)
        checkpoint_forgeries(runs, tmp)
        snapshot_positions(runs, tmp)
        many_failures(tmp)
        hostile(runs, tmp)
        memory(tmp)
        print("%.1f s" % (time.time() - t0))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    T.done()


main()
