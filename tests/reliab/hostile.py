#!/usr/bin/python3
"""hostile.py PDLA WORKDIR - the hostile-file suite (issue 10).

Grows one small cluster with checkpoints, then makes damaged or forged
copies of cluster.h5 and checkpoint.h5 with h5py (nothing binary is
committed) and runs every reader on each: pdla info, info --json, render,
analyze --csv, and pdla --resume for checkpoints. Every run must end by
itself within a time limit, exit 0 (the damage does not concern that
reader) or exit 1/2 with exactly one line on stderr, never a signal; keep
its peak RSS under a bound; and leave no temporary file. Cases listed in
`must_fail` must be refused by those readers, cases in `must_pass` read.
"""
import json
import os
import resource
import shutil
import subprocess
import sys

import h5py
import numpy as np

from reliab_util import check, failures, run_rss

PDLA, WORK = sys.argv[1], sys.argv[2]
# Peak RSS bound per run: a clean read of this cluster takes a few MB (tens
# under ASan); the forged declarations ask for GBs.
RSS_LIMIT_KB = 400 * 1024
TIME_LIMIT = 60



def run(args, env=None):
    """Run pdla ARGS; (exit status or -signal, stderr bytes, peak RSS in KB of
    this run alone - wait4 gives each child's own rusage), or (None, b"",
    None) when it did not end within TIME_LIMIT (then it is killed)."""
    import tempfile
    with tempfile.TemporaryFile() as errf:
        return run_rss(PDLA, args, TIME_LIMIT, errf, env)


def tmp_left(d):
    return [f for f in os.listdir(d) if ".tmp." in f or f.endswith(".new")] if os.path.isdir(d) else []


def one_run(case, reader, args, expect, tmpdirs):
    rc, err, rss = run(args)
    tag = "%s/%s" % (case, reader)
    if rc is None:
        check(False, tag + ": did not end within %d s" % TIME_LIMIT)
        return
    lines = err.decode("utf-8", "replace").rstrip("\n").split("\n") if err else []
    check(rc >= 0, tag + ": killed by signal %d" % -rc)
    check(rc in (0, 1, 2), tag + ": exit %d" % rc)
    if rc in (1, 2):
        check(len(lines) == 1, tag + ": %d lines on stderr: %r" % (len(lines), lines[:3]))
    check(rss < RSS_LIMIT_KB, tag + ": peak RSS %d KB" % rss)
    if expect == "fail":
        check(rc in (1, 2), tag + ": accepted (exit %d), must be refused" % rc)
    if expect == "pass":
        check(rc == 0, tag + ": refused (exit %d: %r)" % (rc, lines))
    for d in tmpdirs:
        left = tmp_left(d)
        check(not left, tag + ": temporary files left: %r" % left)
    return rc


# ---- the base run ---------------------------------------------------------
base = os.path.join(WORK, "base")
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
rc, err, _ = run(["--target", "600", "--seed", "5", "--out", base, "--checkpoint", "-q"])
if rc != 0:
    sys.exit("base run failed: %r" % err)
CLUSTER = os.path.join(base, "cluster.h5")
CKPT = os.path.join(base, "checkpoint.h5")


def replace_dset(f, name, shape, dtype, chunks=None, maxshape=None, fletcher32=False):
    """Replace dataset `name` by one that declares `shape` and stores nothing."""
    attrs = dict(f[name].attrs) if name in f and isinstance(f[name], h5py.Dataset) else {}
    if name in f:
        del f[name]
    d = f.create_dataset(name, shape=shape, dtype=dtype, chunks=chunks, maxshape=maxshape,
                         fletcher32=fletcher32)
    for k, v in attrs.items():
        d.attrs[k] = v
    return d


HUGE = 2**61 + 2**16
cluster_cases = {}


def case(name, must_fail=(), must_pass=()):
    def deco(fn):
        cluster_cases[name] = (fn, set(must_fail), set(must_pass))
        return fn
    return deco


@case("gyration_2^61_rows", must_fail={"info", "json", "analyze"})
def _(f):
    for n, t in (("/gyration/N", "u8"), ("/gyration/rg_diam", "f8")):
        replace_dset(f, n, (HUGE,), t, chunks=(65536,), maxshape=(None,))


@case("gyration_1e8_rows", must_fail={"info", "json", "analyze"})
def _(f):
    for n, t in (("/gyration/N", "u8"), ("/gyration/rg_diam", "f8")):
        replace_dset(f, n, (10**8,), t, chunks=(65536,))


@case("positions_1e12_rows", must_fail={"info", "json", "render", "analyze"})
def _(f):
    replace_dset(f, "/cluster/positions", (10**12, 2), "i4", chunks=(65536, 2))


@case("positions_2^61_rows", must_fail={"info", "json", "render", "analyze"})
def _(f):
    replace_dset(f, "/cluster/positions", (2**61, 2), "i4", chunks=(65536, 2), maxshape=(None, 2))


@case("positions_float", must_fail={"info", "json", "render", "analyze"})
def _(f):
    p = f["/cluster/positions"][...].astype("f8")
    du = f["/cluster/positions"].attrs["diameter_units"]
    del f["/cluster/positions"]
    f["/cluster/positions"] = p
    f["/cluster/positions"].attrs["diameter_units"] = du


# 64-bit positions, one of them past 32 bits: HDF5 clamped it to 2^31 - 1
# when read as int32, and the tools went on (session 26)
@case("positions_int64_2^40", must_fail={"render", "analyze"})
def _(f):
    p = f["/cluster/positions"][...].astype("i8")
    attrs = dict(f["/cluster/positions"].attrs)
    p[len(p) // 2] = [1 << 40, -(1 << 40)]
    del f["/cluster/positions"]
    f["/cluster/positions"] = p
    for k, v in attrs.items():
        f["/cluster/positions"].attrs[k] = v


@case("positions_rank3", must_fail={"info", "json", "render", "analyze"})
def _(f):
    replace_dset(f, "/cluster/positions", (3, 2, 2), "i4")


@case("positions_rank1", must_fail={"info", "json", "render", "analyze"})
def _(f):
    replace_dset(f, "/cluster/positions", (6,), "i4")


@case("positions_7_columns", must_fail={"info", "json", "render", "analyze"})
def _(f):
    replace_dset(f, "/cluster/positions", (6, 7), "i4")


@case("positions_group", must_fail={"info", "json", "render", "analyze"})
def _(f):
    del f["/cluster/positions"]
    f.create_group("/cluster/positions")


@case("positions_dangling", must_fail={"info", "json", "render", "analyze"})
def _(f):
    del f["/cluster/positions"]
    f["/cluster/positions"] = h5py.SoftLink("/nowhere/at/all")


@case("positions_external_dangling", must_fail={"info", "json", "render", "analyze"})
def _(f):
    del f["/cluster/positions"]
    f["/cluster/positions"] = h5py.ExternalLink("no-such-file.h5", "/x")


@case("gyration_dangling", must_fail={"info", "json", "analyze"})
def _(f):
    del f["/gyration"]
    f["/gyration"] = h5py.SoftLink("/nowhere")


@case("gyration_N_group", must_fail={"info", "json", "analyze"})
def _(f):
    del f["/gyration/N"]
    f.create_group("/gyration/N")


@case("gyration_N_strings", must_fail={"info", "json", "analyze"})
def _(f):
    n = len(f["/gyration/N"])
    del f["/gyration/N"]
    f.create_dataset("/gyration/N", data=np.array([b"x"] * n, dtype="S8"))


@case("gyration_N_rank2", must_fail={"info", "json", "analyze"})
def _(f):
    replace_dset(f, "/gyration/N", (4, 4), "u8")


for name, val in (("2^32+32", np.int64(2**32 + 32)), ("zero", np.int64(0)), ("negative", np.int64(-4)),
                  ("huge", np.int64(2**62)), ("NaN", np.float64("nan")), ("inf", np.float64("inf")),
                  ("string", "16"), ("array", np.array([16, 16], dtype="i8"))):
    def mk(val):
        def fn(f):
            f["/cluster/positions"].attrs["diameter_units"] = val
            f["/parameters"].attrs["resolution"] = val
        return fn
    cluster_cases["diameter_units_" + name] = (mk(val), {"info", "json", "render", "analyze"}, set())


@case("format_version_array_1000", must_fail={"info", "json", "render", "analyze"})
def _(f):
    f.attrs["format_version"] = np.ones(1000, dtype="i8")


@case("format_array_of_strings", must_fail={"info", "json", "render", "analyze"})
def _(f):
    f.attrs["format"] = np.array([b"pdla-cluster"] * 50, dtype="S13")


@case("format_vlen_array", must_fail={"info", "json", "render", "analyze"})
def _(f):
    f.attrs.create("format", ["pdla-cluster"] * 50, dtype=h5py.string_dtype())


@case("format_int", must_fail={"info", "json", "render", "analyze"})
def _(f):
    f.attrs["format"] = np.int64(7)


@case("format_missing", must_fail={"info", "json", "render", "analyze"})
def _(f):
    del f.attrs["format"]


# Strings of every HDF5 kind for `format`: vlen UTF-8 (h5py's default),
# vlen ASCII, fixed NUL-terminated/NUL-padded/space-padded: all read.
@case("format_vlen_utf8", must_pass={"info", "json", "render", "analyze"})
def _(f):
    f.attrs["format"] = "pdla-cluster"


@case("format_vlen_ascii", must_pass={"info", "json", "render", "analyze"})
def _(f):
    f.attrs.create("format", "pdla-cluster", dtype=h5py.string_dtype("ascii"))


@case("format_fixed_ascii_nullpad", must_pass={"info", "json", "render", "analyze"})
def _(f):
    f.attrs["format"] = np.bytes_(b"pdla-cluster")


@case("format_fixed_long", must_pass={"info", "json", "render", "analyze"})
def _(f):
    f.attrs.create("format", np.bytes_(b"pdla-cluster"), dtype=h5py.string_dtype("utf-8", 40))


@case("results_nan_inf", must_pass={"info", "json", "render", "analyze"})
def _(f):
    for k in list(f["/results"].attrs):
        f["/results"].attrs[k] = np.float64("nan")
    f["/results"].attrs["extra_inf"] = np.float64("-inf")


@case("invalid_utf8_attrs", must_pass={"info", "json", "render", "analyze"})
def _(f):
    f["/Code"].attrs["command_line"] = np.bytes_(b"pdla \xff\xfe\xc3( \xed\xa0\x80 \"q\" \x01")
    f["/parameters"].attrs.create("note", "\u00e9t\u00e9", dtype=h5py.string_dtype())


# Overlapping particles: every row at the seed, or a forged diameter of 2^20
# units over real positions. render drew each disc over a fifth of the
# picture (2e5 such rows: minutes; 1e6: about a day); it now refuses a
# cluster whose balls hold more volume than their bounding box.
@case("positions_stacked", must_fail={"render"})
def _(f):
    f["/cluster/positions"][...] = 0


@case("diameter_units_2^20_real_positions", must_fail={"render"})
def _(f):
    f["/cluster/positions"].attrs["diameter_units"] = np.int64(2**20)
    f["/parameters"].attrs["resolution"] = np.int64(2**20)


@case("empty_cluster", must_pass={"info", "json"})
def _(f):
    replace_dset(f, "/cluster/positions", (0, 2), "i4")


def readers(path, out):
    return {
        "info": ["info", path],
        "json": ["info", "--json", path],
        "render": ["render", path, "-o", os.path.join(out, "x.png")],
        "analyze": ["analyze", path, "--csv", os.path.join(out, "csv")],
    }


for name, (fn, must_fail, must_pass) in cluster_cases.items():
    d = os.path.join(WORK, "c-" + name.replace("^", ""))
    os.makedirs(d)
    path = os.path.join(d, "cluster.h5")
    shutil.copy(CLUSTER, path)
    with h5py.File(path, "r+") as f:
        fn(f)
    for reader, args in readers(path, d).items():
        expect = "fail" if reader in must_fail else "pass" if reader in must_pass else None
        rc = one_run(name, reader, args, expect, [d, os.path.join(d, "csv")])
        if reader == "json" and rc == 0:
            out = subprocess.run([PDLA] + args, capture_output=True).stdout
            try:
                json.loads(out.decode("utf-8", "strict"))
            except (ValueError, UnicodeDecodeError) as e:
                check(False, name + "/json: output is not valid UTF-8 JSON: %s" % e)

# A FIFO given to a reader must be refused, not waited on.
fifo = os.path.join(WORK, "fifo.h5")
os.mkfifo(fifo)
for reader, args in readers(fifo, WORK).items():
    one_run("fifo", reader, args, "fail", [WORK])

# ---- checkpoints ---------------------------------------------------------
ckpt_cases = {}


def ck(name):
    def deco(fn):
        ckpt_cases[name] = fn
        return fn
    return deco


@ck("tree_inner_2^30_records")
def _(f):
    f["/tree"].attrs["inner_records"] = np.uint64(2**30)
    replace_dset(f, "/tree/inner", (2**30, 4), "u4", chunks=(65536, 4), fletcher32=True)


@ck("gyration_N_2^40_rows")
def _(f):
    replace_dset(f, "/gyration/N", (2**40,), "u8", chunks=(65536,), fletcher32=True)


@ck("chunks_packed_group")
def _(f):
    del f["/tree/chunks_packed"]
    f.create_group("/tree/chunks_packed")


@ck("tree_dangling")
def _(f):
    del f["/tree"]
    f["/tree"] = h5py.SoftLink("/gone")


@ck("params_nan")
def _(f):
    f["/parameters"].attrs["birth_margin"] = np.float64("nan")
    f["/parameters"].attrs["kill_ratio"] = np.float64("inf")


@ck("params_huge_negative")
def _(f):
    f["/parameters"].attrs["resolution"] = np.int64(-(2**40))
    f["/parameters"].attrs["dim"] = np.int64(2**33 + 2)


@ck("particles_attr_array")
def _(f):
    f.attrs["particles"] = np.ones(5000, dtype="u8")


@ck("format_vlen_array")
def _(f):
    f.attrs.create("format", ["pdla-checkpoint"] * 40, dtype=h5py.string_dtype())


# A forged R_g grid position (2^63 stopped the sampling for good: /gyration
# ended at 3020 of 1e5 particles, exit 0; one step off put samples off the
# grid ensembles share) and forged growth times (NaN, -1e300 printed and
# carried into every later file).
@ck("rg_next_k_2^63")
def _(f):
    f["/state"].attrs.modify("rg_next_k", np.uint64(2**63))


@ck("rg_next_k_off_grid")
def _(f):
    f["/state"].attrs.modify("rg_next_k", np.uint64(int(f["/state"].attrs["rg_next_k"]) - 1))


@ck("rg_next_later_grid_point")
def _(f):
    # On the grid, but one point later than the engine's: a sample skipped.
    import math
    k = int(f["/state"].attrs["rg_next_k"]) + 1
    pd = int(f["/parameters"].attrs["rg_per_decade"])
    n = 1
    for j in range(1, k + 1):
        n = max(int(round(10.0 ** (j / pd))), n + 1)
    f["/state"].attrs.modify("rg_next_k", np.uint64(k))
    f["/state"].attrs.modify("rg_next_n", np.uint64(n))


@ck("grow_seconds_nan")
def _(f):
    f["/state"].attrs.modify("grow_seconds", np.float64("nan"))


@ck("grow_seconds_-1e300")
def _(f):
    f["/state"].attrs.modify("grow_seconds", np.float64(-1e300))


@ck("parallel_seconds_inf")
def _(f):
    f["/state"].attrs.modify("parallel_seconds", np.float64("inf"))


# The control: the same checkpoint, unforged, resumes to a larger target,
# so the cases below fail for their forgery (each resumes to 2000 too).
ctl = os.path.join(WORK, "k-control")
os.makedirs(ctl)
shutil.copy(CKPT, os.path.join(ctl, "checkpoint.h5"))
one_run("control", "resume", ["--resume", os.path.join(ctl, "checkpoint.h5"), "--target", "2000", "-q"],
        "pass", [ctl])

for name, fn in ckpt_cases.items():
    d = os.path.join(WORK, "k-" + name.replace("^", ""))
    os.makedirs(d)
    path = os.path.join(d, "checkpoint.h5")
    shutil.copy(CKPT, path)
    with h5py.File(path, "r+") as f:
        fn(f)
    one_run(name, "resume", ["--resume", path, "--target", "2000", "-q"], "fail", [d])

fifo_d = os.path.join(WORK, "k-fifo")
os.makedirs(fifo_d)
os.mkfifo(os.path.join(fifo_d, "checkpoint.h5"))
one_run("fifo", "resume", ["--resume", os.path.join(fifo_d, "checkpoint.h5"), "-q"], "fail", [fifo_d])
with open(os.path.join(WORK, "s.scene"), "w"):
    pass
os.unlink(os.path.join(WORK, "s.scene"))
os.mkfifo(os.path.join(WORK, "s.scene"))
one_run("fifo", "scene", ["--scene", os.path.join(WORK, "s.scene"), "--no-output"], "fail", [WORK])

n = len(cluster_cases) * 4 + 4 + 1 + len(ckpt_cases) + 2
print("hostile: %d runs, %d failures" % (n, len(failures)))
_ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print("children's CPU time: %.1f s user, %.1f s system" % (_ru.ru_utime, _ru.ru_stime))
sys.exit(1 if failures else 0)
