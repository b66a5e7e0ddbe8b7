#!/usr/bin/python3
"""hostile_models.py PDLA WORKDIR - forged and damaged files through the
readers of the DLCA and event models (issue 9: every HDF5 read goes through
the checked reader, pdla/h5check.h).

Makes one small DLCA run (cluster.h5 + checkpoint.h5) and one small event
run (checkpoint.h5), then damaged copies of them with h5py (the DLCA checkpoint with its snapshots) (nothing binary
is committed): a dataset that declares 2^61 or 10^8 rows but stores none,
one of the wrong element type or rank, an attribute that is an array where
one value is wanted, and the file cut in half. Each reader that reads the
damaged part - `pdla render` and `pdla analyze` of a DLCA file,
`pdla analyze` of an event cluster.h5,
`pdla --model dlca --start FILE`, `--model dlca --resume`, `--model event
--resume` - must refuse it: exit 1 or 2 with exactly one line on stderr,
never a signal, within a time limit and a peak-RSS bound (the forged
declarations ask for GBs). The undamaged copies must be read (exit 0), so
the test cannot pass by refusing everything. hostile.py does the same for
the DLA files.
"""
import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

from reliab_util import check, failures, run_rss

PDLA, WORK = sys.argv[1], sys.argv[2]
RSS_LIMIT_KB = 400 * 1024  # a clean read takes a few MB (tens under ASan)
TIME_LIMIT = 60
HUGE = 2**61 + 2**16
runs = []


def run(args):
    """(exit status or -signal, stderr lines, peak RSS in KB of this run), or
    (None, [], None) when it did not end within TIME_LIMIT."""
    with open(os.path.join(WORK, "stderr"), "w+b") as errf:
        rc, err, rss = run_rss(PDLA, args, TIME_LIMIT, errf)
    if rc is None:
        return None, [], None
    err = err.decode("utf-8", "replace").rstrip("\n")
    return rc, err.split("\n") if err else [], rss


def expect(tag, args, want):
    """want 'fail': refused with one line; 'pass': exit 0."""
    runs.append(tag)
    rc, lines, rss = run(args)
    if rc is None:
        check(False, tag + ": did not end within %d s" % TIME_LIMIT)
        return
    check(rc >= 0, tag + ": killed by signal %d" % -rc)
    check(rss < RSS_LIMIT_KB, tag + ": peak RSS %d KB" % rss)
    if want == "fail":
        check(rc in (1, 2), tag + ": exit %d, want 1 or 2 (refused): %r" % (rc, lines[:3]))
        check(len(lines) == 1, tag + ": %d lines on stderr, want 1: %r" % (len(lines), lines[:3]))
    else:
        check(rc == 0, tag + ": exit %d, want 0: %r" % (rc, lines[:3]))


def replace_dset(f, name, shape, dtype, chunks=None, maxshape=None):
    """Replace dataset `name` by one that declares `shape` and stores nothing."""
    if name in f:
        del f[name]
    return f.create_dataset(name, shape=shape, dtype=dtype, chunks=chunks, maxshape=maxshape)


def retype(f, name, dtype):
    """Dataset `name` with the same values as another element type."""
    v = f[name][()].astype(dtype)
    del f[name]
    f[name] = v


def forged(src, tag, fn):
    """A copy of src damaged by fn(h5py file), or cut in half (fn None)."""
    d = os.path.join(WORK, tag)
    os.makedirs(d)
    path = os.path.join(d, os.path.basename(src))
    shutil.copy(src, path)
    if fn is None:
        with open(path, "r+b") as fh:
            fh.truncate(os.path.getsize(path) // 2)
    else:
        with h5py.File(path, "r+") as f:
            fn(f)
    return d, path


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

# ---- DLCA: cluster.h5 through render / analyze / --start ------------------
base = os.path.join(WORK, "dlca")
rc, lines, _ = run(["--model", "dlca", "--dim", "2", "--box", "48", "--fill", "0.05", "--until-clusters", "20",
                    "--seed", "4", "--out", base, "--checkpoint", "--snapshot-every", "2", "-q"])
if rc != 0:
    sys.exit("the DLCA base run failed: %r" % lines)
CL, CK = os.path.join(base, "cluster.h5"), os.path.join(base, "checkpoint.h5")
START = ["--model", "dlca", "--dim", "2", "--box", "48", "--until-clusters", "20", "--no-output", "--start"]


def dlca_readers(d, path):
    return {"render": ["render", path, "-o", os.path.join(d, "x.png")],
            "analyze": ["analyze", path],
            "start": START + [path]}


for reader, args in dlca_readers(WORK, CL).items():
    expect("dlca-clean/" + reader, args, "pass")

POS = "/monomers/position"
dlca_cases = {
    "position_2^61_rows": lambda f: replace_dset(f, POS, (HUGE, 2), "i4", chunks=(65536, 2), maxshape=(None, 2)),
    "position_1e8_rows": lambda f: replace_dset(f, POS, (10**8, 2), "i4", chunks=(65536, 2)),
    "position_float": lambda f: retype(f, POS, "f8"),
    "position_rank3": lambda f: replace_dset(f, POS, (3, 2, 2), "i4"),
    "position_dangling": lambda f: (f.__delitem__(POS), f.__setitem__(POS, h5py.SoftLink("/nowhere"))),
    "truncated": None,
}
for name, fn in dlca_cases.items():
    d, path = forged(CL, "dlca-" + name.replace("^", ""), fn)
    for reader, args in dlca_readers(d, path).items():
        expect("dlca-%s/%s" % (name, reader), args, "fail")
# (review D) 3e7 rows of zeros, gzip'ed into 0.4 MB (within the 1100:1
# stored-size rule) in a box of 2^30 sites: the start read all of them
# (716 MB RSS) before it found monomers 1 and 2 on one site; now the
# second row is refused, a slab of rows in memory.
bomb = os.path.join(WORK, "dlca-start-zeros.h5")
with h5py.File(bomb, "w") as f:
    ROWS, CHUNK = 3 * 10**7, 10**6
    dz = f.create_dataset(POS, shape=(ROWS, 3), dtype="i4", chunks=(CHUNK, 3), compression="gzip",
                          compression_opts=1)
    zeros = np.zeros((CHUNK, 3), "i4")
    for r in range(0, ROWS, CHUNK):
        dz[r:r + CHUNK] = zeros
expect("dlca-start-gzip-zeros/start", ["--model", "dlca", "--dim", "3", "--box", "1024", "--no-output", "--start",
                                       bomb], "fail")
# What only the tools read: /clusters, and /parameters box.
tool_cases = {
    "clusters_size_2^61_rows": lambda f: replace_dset(f, "/clusters/size", (HUGE,), "u8", chunks=(65536,),
                                                      maxshape=(None,)),
    "clusters_rg_strings": lambda f: (f.__delitem__("/clusters/rg"),
                                      f.create_dataset("/clusters/rg", data=np.array([b"x"] * 4, dtype="S8"))),
    "box_array_1000": lambda f: f["/parameters"].attrs.__setitem__("box", np.ones(1000, dtype="u8")),
    "box_float": lambda f: f["/parameters"].attrs.__setitem__("box", np.array([48.0, 48.0])),
    # audit-dlca: lengths past the model's (16384, < 2^31 sites) overflowed
    # analyze's int strides (UBSan) and render drew them.
    "box_100000": lambda f: f["/parameters"].attrs.__setitem__("box", np.array([100000, 100000], dtype="u8")),
    "box_2^32-1": lambda f: f["/parameters"].attrs.__setitem__("box", np.array([2**32 - 1] * 2, dtype="u8")),
}
for name, fn in tool_cases.items():
    d, path = forged(CL, "dlca-" + name.replace("^", ""), fn)
    for reader in ("render", "analyze"):
        expect("dlca-%s/%s" % (name, reader), dlca_readers(d, path)[reader], "fail")

# ---- DLCA checkpoint through --resume -------------------------------------
expect("dlca-ckpt-clean/resume", ["--model", "dlca", "--resume", CK, "--out", os.path.join(WORK, "dlca-resumed"),
                                  "-q"], "pass")
dlca_ck_cases = {
    "rows_u64_2^61": lambda f: replace_dset(f, "rows_u64", (HUGE,), "u8", chunks=(65536,), maxshape=(None,)),
    "rows_both_1e8": lambda f: [replace_dset(f, n, (3 * 10**8,), t, chunks=(65536,))
                                for n, t in (("rows_u64", "u8"), ("rows_f64", "f8"))],
    "site_not_stored": lambda f: replace_dset(f, "site", f["site"].shape, "u4", chunks=True),
    "u64_float": lambda f: retype(f, "u64", "f8"),
    "snapshots_count_array_5000": lambda f: f["snapshots"].attrs.__setitem__("count", np.ones(5000, dtype="u8")),
    "snapshots_count_2^60": lambda f: f["snapshots"].attrs.__setitem__("count", np.uint64(2**60)),
    "snapshot_site_2^61_rows": lambda f: replace_dset(f, "snapshots/0/site", (HUGE,), "u4", chunks=(65536,),
                                                      maxshape=(None,)),
    "snapshot_t_array_5000": lambda f: f["snapshots/1"].attrs.__setitem__("t", np.ones(5000, dtype="f8")),
    "truncated": None,
}


def dlca_u64(i, v):
    """Entry i of the checkpoint's scalar array u64 set to v."""
    def damage(f):
        a = f["u64"][()]
        a[i] = v
        del f["u64"]
        f["u64"] = a
    return damage


# Session 11: these resumed without a word (a NaN or negative time, a stop
# state out of range, an all-zero RNG state), or sized memory by a forged
# monomer count (2e8 in a 16384^2 box declared in a few KB: 795 MB RSS).
dlca_ck_cases.update({
    "t_nan": lambda f: (f.__setitem__("f64_x", np.array([np.nan, f["f64"][1]])), f.__delitem__("f64"),
                        f.move("f64_x", "f64")),
    "t_negative": lambda f: (f.__setitem__("f64_x", np.array([-1.0, f["f64"][1]])), f.__delitem__("f64"),
                             f.move("f64_x", "f64")),
    "stop_99": dlca_u64(13, 99),
    "spanning_7": dlca_u64(12, 7),
    # audit-dlca: stopped by spanning with no cluster spanning resumed as
    # "stop: spanning" at once, whatever the stops asked.
    "stop_spanning_unflagged": dlca_u64(13, 3),
    "rng_zero": lambda f: (f.__delitem__("rng"), f.__setitem__("rng", np.zeros(4, dtype="u8"))),
    "count_2e8_box_16384": lambda f: (dlca_u64(14, 2 * 10**8)(f),
                                      f["parameters"].attrs.__setitem__("box", np.array([16384, 16384], dtype="u8"))),
})


L0 = 48  # the base run's box side


def dlca_anchor(shift, off_shift=0):
    """The largest cluster's anchor moved by shift sites along axis 0 (None:
    by -off_shift, wrapped into the box) and its offsets (and bounding box)
    by off_shift: the sites, which wrap, still
    match (audit-dlca: an anchor outside the box or a bounding box without
    the anchor's own offset 0 resumed, and window() then stepped monomers
    off the lattice: a heap overflow)."""
    def damage(f):
        d = int(f["parameters"].attrs["dim"])
        sn = f["slot_n"][()]
        g = f["geom"][()].reshape(-1, 3 * d)
        c = int(np.argmax(sn))
        g[c, 0] += shift if shift is not None else (g[c, 0] - off_shift) % L0 - g[c, 0]
        g[c, d] += off_shift
        g[c, 2 * d] += off_shift
        first = int(sn[:c].sum())
        off = f["offset"][()].reshape(-1, d)
        off[first:first + sn[c], 0] += off_shift
        for name, v in (("geom", g), ("offset", off)):
            del f[name]
            f[name] = v.reshape(-1).astype("i4")
    return damage


dlca_ck_cases.update({
    "anchor_plus_L": dlca_anchor(L0),
    "anchor_minus_L": dlca_anchor(-L0),
    "anchor_plus_5L": dlca_anchor(5 * L0),
    "bbox_without_anchor": dlca_anchor(None, 40),
})
for name, fn in dlca_ck_cases.items():
    d, path = forged(CK, "dlcack-" + name.replace("^", ""), fn)
    expect("dlca-ckpt-%s/resume" % name, ["--model", "dlca", "--resume", path, "--out", os.path.join(d, "o"), "-q"],
           "fail")



# The values a resumed run only carries into its cluster.h5 (counters, the
# series, the snapshots) resumed without a word however forged: each must
# be refused with one line naming it (want), exit 2, no run directory made.
def dlca_set(name, i, v):
    """Entry i of the checkpoint's dataset `name` set to v."""
    def damage(f):
        a = f[name][()]
        a[i] = v
        del f[name]
        f[name] = a
    return damage


def dlca_attr(group, key, v):
    return lambda f: f[group].attrs.__setitem__(key, v)


R = 3 * 2  # the series' third row (three values a row)
dlca_ck_values = {
    "merges_1e9": (dlca_u64(3, 10**9), "merges"),
    "moves_past_attempts": (dlca_u64(1, 10**12), "moves counter"),
    "monomer_moves_1": (dlca_u64(2, 1), "monomer moves"),
    "candidates_2^63": (dlca_u64(5, 2**63), "candidates"),
    "row_nc_0": (dlca_u64(8, 0), "row_nc"),
    "row_nc_1e12": (dlca_u64(8, 10**12), "row_nc"),
    "smin_1e9": (dlca_u64(9, 10**9), "smallest cluster size"),
    "row_t_nan": (dlca_set("rows_f64", R, np.nan), "series row 2 has t"),
    "row_t_negative": (dlca_set("rows_f64", R, -5.0), "series row 2 has t"),
    "row_t_after_state": (dlca_set("rows_f64", R, 1e9), "series row 2 has t"),
    "row_mean_inf": (dlca_set("rows_f64", R + 1, np.inf), "series row 2 has mean_size"),
    "row_weight_negative": (dlca_set("rows_f64", R + 2, -1.0), "series row 2 has weight_size"),
    "row_attempts_1e15": (dlca_set("rows_u64", R, 10**15), "series row 2 has attempts"),
    "row_clusters_1e9": (dlca_set("rows_u64", R + 1, 10**9), "series row 2 has n_clusters"),
    "row_clusters_0": (dlca_set("rows_u64", R + 1, 0), "series row 2 has n_clusters"),
    "row_largest_1e9": (dlca_set("rows_u64", R + 2, 10**9), "series row 2 has largest"),
    "snapshots_every_nan": (dlca_attr("snapshots", "every", np.nan), "snapshot period"),
    "snapshots_every_negative": (dlca_attr("snapshots", "every", -2.0), "snapshot period"),
    "snapshots_every_inf": (dlca_attr("snapshots", "every", np.inf), "snapshot period"),
    "snapshot_t_nan": (dlca_attr("snapshots/3", "t", np.nan), "snapshot 3 has t"),
    "snapshot_t_negative": (dlca_attr("snapshots/3", "t", -1.0), "snapshot 3 has t"),
    "snapshot_t_after_state": (dlca_attr("snapshots/3", "t", 1e9), "snapshot 3 has t"),
    "snapshot_attempts_1e15": (dlca_attr("snapshots/3", "attempts", np.uint64(10**15)), "snapshot 3 has attempts"),
    "snapshot_clusters_1e9": (dlca_attr("snapshots/3", "n_clusters", np.uint64(10**9)), "snapshot 3 has n_clusters"),
    "snapshot_clusters_0": (dlca_attr("snapshots/3", "n_clusters", np.uint64(0)), "snapshot 3 has n_clusters"),
    "snapshot_site_2^31": (dlca_set("snapshots/3/site", 0, 2**31), "snapshot 3 has a site"),
    "snapshot_cluster_2^31": (dlca_set("snapshots/3/cluster", 0, 2**31), "snapshot 3 has a cluster number"),
    # /parameters' count or fill that give another N than the state holds
    # (the load once set count = N, so a forged count or fill went unseen)
    "parameters_count_70": (dlca_attr("parameters", "count", np.uint64(70)), "the 70 its parameters give"),
    "parameters_fill_doubled": (lambda f: f["parameters"].attrs.__setitem__(
        "fill", 2 * f["parameters"].attrs["fill"]), "monomers are not the"),
}


def dlca_disconnect(f):
    """Two lone monomers made one cluster (slot_n, site, offset, geom, the
    active list, N_c, merges and sum s^2 kept consistent): its monomers far
    apart, as the review forged it (forge_disc.py): it resumed and passed
    --check, and the output held a cluster that is not face-connected."""
    d = int(f["parameters"].attrs["dim"])
    L = np.array(f["parameters"].attrs["box"][:d], dtype=np.int64)
    sn, site = f["slot_n"][()], f["site"][()]
    off, geom = f["offset"][()].reshape(-1, d), f["geom"][()].reshape(-1, 3, d)
    u, dv = f["u64"][()], f["f64"][()]
    starts = np.concatenate([[0], np.cumsum(sn[1:].astype(np.int64))])
    a, b = [c for c in range(1, len(sn)) if sn[c] == 1][:2]
    ia, ib = int(starts[a - 1]), int(starts[b - 1])
    xa, xb = (np.array([int(site[i]) // int(np.prod(L[:k])) % L[k] for k in range(d)]) for i in (ia, ib))
    D = (xb - xa + L // 2) % L - L // 2
    keep = [i for i in range(len(site)) if i != ib]
    site2, off2 = np.insert(site[keep], ia + 1, site[ib]), np.insert(off[keep], ia + 1, D, axis=0)
    sn[a], sn[b] = 2, 0
    geom[a] = [xa, np.minimum(0, D), np.maximum(0, D)]
    act = np.array([c for c in f["active"][()] if c != b], "u4")
    u[7] -= 1
    u[3] += 1
    dv[1] += 2
    for k, v in (("slot_n", sn), ("site", site2.astype("u4")), ("offset", off2.astype("i4").ravel()),
                 ("geom", geom.astype("i4").ravel()), ("active", act), ("u64", u), ("f64", dv)):
        del f[k]
        f[k] = v


# (review D) a spanning flag with no spanning cluster: the resume stopped
# at once, "stop: spanning", and the flag turned the contact checks off;
# a cluster of two pieces passed every check.
dlca_ck_values.update({
    "spanning_forged": (dlca_u64(12, 1), "no cluster spans the box"),
    "cluster_disconnected": (dlca_disconnect, "is not face-connected"),
})


def dlca_span_by_offsets(f):
    """A 2-monomer cluster's second offset moved by L along the axis the two
    touch on (the same site on the torus, offsets L - 1 apart, extent L),
    its bounding box to match, and the spanning flag and stop set: the
    checks took the stored extent as proof, and the resume (even --check)
    stopped at once, "stop: spanning" with a largest cluster of 4."""
    d = int(f["parameters"].attrs["dim"])
    L = np.array(f["parameters"].attrs["box"][:d], dtype=np.int64)
    sn, off, g = f["slot_n"][()], f["offset"][()].reshape(-1, d), f["geom"][()].reshape(-1, 3, d)
    starts = np.concatenate([[0], np.cumsum(sn[1:].astype(np.int64))])
    c = [c for c in range(1, len(sn)) if sn[c] == 2][0]
    i = int(starts[c - 1])
    j = i + 1 if not off[i].any() else i  # not the anchor (offset 0)
    a = int(np.nonzero(off[j])[0][0])
    off[j, a] -= np.sign(off[j, a]) * L[a]
    g[c, 1], g[c, 2] = np.minimum(0, off[j]), np.maximum(0, off[j])
    u = f["u64"][()]
    u[12], u[13] = 1, 3  # spanning; stop: spanning
    for k, v in (("offset", off.astype("i4").ravel()), ("geom", g.astype("i4").ravel()), ("u64", u)):
        del f[k]
        f[k] = v


dlca_ck_values["spanning_by_offsets"] = (dlca_span_by_offsets, "no cluster spans the box")
# (session 27) the checkpoint schedule a bare --resume keeps: a forged one
# would set the resumed run's checkpoint triggers
SCHED_S, SCHED_A = "schedule_every_seconds", "schedule_every_attempts"
dlca_ck_values.update({
    "schedule_seconds_negative": (dlca_attr("/", SCHED_S, -1.0), SCHED_S),
    "schedule_seconds_nan": (dlca_attr("/", SCHED_S, np.nan), SCHED_S),
    "schedule_seconds_inf": (dlca_attr("/", SCHED_S, np.inf), SCHED_S),
    "schedule_seconds_2e9": (dlca_attr("/", SCHED_S, 2e9), SCHED_S),
    "schedule_seconds_string": (dlca_attr("/", SCHED_S, np.bytes_(b"30m")), SCHED_S),
    "schedule_seconds_array": (dlca_attr("/", SCHED_S, np.ones(3)), SCHED_S),
    "schedule_attempts_negative": (dlca_attr("/", SCHED_A, np.int64(-5)), SCHED_A),
    "schedule_attempts_float": (dlca_attr("/", SCHED_A, 2000.0), SCHED_A),
    "schedule_attempts_alone": (lambda f: (f.attrs.__setitem__(SCHED_A, np.uint64(2000)), f.attrs.pop(SCHED_S, 0)),
                                SCHED_S),
})
for name, (fn, want) in dlca_ck_values.items():
    d, path = forged(CK, "dlcack-" + name.replace("^", ""), fn)
    tag = "dlca-ckpt-%s/resume" % name
    runs.append(tag)
    rc, lines, _ = run(["--model", "dlca", "--resume", path, "--out", os.path.join(d, "o"), "-q"])
    check(rc == 2 and len(lines) == 1 and want in lines[0], "%s: exit %s, want 2 and one line with %r: %r"
          % (tag, rc, want, lines[:3]))
    check(not os.path.exists(os.path.join(d, "o")), tag + ": the run directory was made")

# (review D) /snapshots holding 300 hard links to snapshot 0 (count 300) of
# 2e5 monomers: each was read, 1.7 MB, before the count was held against
# the schedule (2000 such links took 3.3 GB); now the count is refused
# first, beside the period, the time and the memory budget.
sb = os.path.join(WORK, "dlca-snaplinks")
rc, lines, _ = run(["--model", "dlca", "--box", "2048", "--fill", "0.05", "--seed", "1", "--snapshot-every", "0.05",
                    "--until-time", "0.06", "--checkpoint", "--out", sb, "-q"])
if rc != 0:
    sys.exit("the DLCA snapshot base run failed: %r" % lines)
with h5py.File(os.path.join(sb, "checkpoint.h5"), "r+") as f:
    for i in range(1, 300):
        f["snapshots"][str(i)] = f["snapshots/0"]
    f["snapshots"].attrs["count"] = np.uint64(300)
tag = "dlca-ckpt-snapshot_links_300/resume"
runs.append(tag)
rc, lines, rss = run(["--model", "dlca", "--resume", sb, "-q"])
check(rc == 2 and len(lines) == 1 and "more than the 2 due by its time" in lines[0] and rss < RSS_LIMIT_KB,
      "%s: exit %s, peak RSS %s KB, want 2, one line 'more than the 2 due...': %r" % (tag, rc, rss, lines[:3]))

# ---- DLCA --search boxes checkpoint: the box side A ------------------------
# A box side of 0, or one that is no power of two >= --grid-box, looped for
# ever in dlca_search_init (A *= 2 never reaches the clusters' extent; the
# loop ignored SIGTERM); 2^31 wrapped to a negative int.
boxes = os.path.join(WORK, "dlca-boxes")
rc, lines, _ = run(["--model", "dlca", "--dim", "2", "--box", "48", "--fill", "0.05", "--until-clusters", "20",
                    "--seed", "4", "--search", "boxes", "--out", boxes, "--checkpoint", "-q"])
if rc != 0:
    sys.exit("the DLCA boxes base run failed: %r" % lines)
BK = os.path.join(boxes, "checkpoint.h5")
# (48 sites a side: A never passes 64, the first power of two >= 48.)
for name, a, want in (("A_4", 4, "pass"), ("A_64", 64, "pass"), ("A_0", 0, "fail"), ("A_3", 3, "fail"),
                      ("A_128", 128, "fail"), ("A_2^31", 2**31, "fail")):
    d, path = forged(BK, "dlcabox-" + name.replace("^", ""), dlca_u64(10, a))
    expect("dlca-boxes-ckpt-%s/resume" % name, ["--model", "dlca", "--resume", path, "--until-clusters", "5",
                                                "--out", os.path.join(d, "o"), "-q"], want)

# ---- event checkpoint through --resume ------------------------------------
ev = os.path.join(WORK, "event")
rc, lines, _ = run(["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--seed-radius", "1",
                    "--t-max", "2", "--series-dt", "0.5", "--seed", "3", "--out", ev, "--checkpoint"])
if rc != 0:
    sys.exit("the event base run failed: %r" % lines)
EK = os.path.join(ev, "checkpoint.h5")


def ev_copy(tag, fn):
    d, path = forged(EK, tag, fn)
    return d


def ev_resume(d):
    return ["--model", "event", "--resume", d, "--t-max", "3", "--quiet"]


expect("event-clean/resume", ev_resume(ev_copy("event-clean", lambda f: None)), "pass")
ev_cases = {
    "series_time_2^61": lambda f: replace_dset(f, "series/time", (HUGE,), "f8", chunks=(65536,), maxshape=(None,)),
    "series_all_1e8": lambda f: [replace_dset(f, "series/" + n, (10**8,), t, chunks=(65536,))
                                 for n, t in (("time", "f8"), ("kinetic_energy", "f8"), ("pressure", "f8"),
                                              ("stuck", "u8"), ("collisions", "u8"))],
    "state_kind_float": lambda f: retype(f, "state/kind", "f8"),
    "state_ps_not_stored": lambda f: replace_dset(f, "state/ps", f["state/ps"].shape, "f8", chunks=True),
    "format_version_array_5000": lambda f: f.attrs.__setitem__("format_version", np.ones(5000, dtype="i8")),
    "format_string_array": lambda f: f.attrs.__setitem__("format", np.array([b"pdla-event-checkpoint"] * 50)),
    "truncated": None,
}


def ev_values(name, fn):
    """Dataset `name` with its values changed by fn(numpy array)."""
    def damage(f):
        a = fn(f[name][()].copy())
        del f[name]
        f[name] = a
    return damage


def ev_set(i, v):
    def fn(a):
        a[i] = v
        return a
    return fn


def ev_param(key, value, attrs):
    """The parameter line `key=...` set to value, and the root attributes."""
    def damage(f):
        t = bytes(f["parameters"][()]).decode()
        t = "\n".join(key + "=" + value if ln.startswith(key + "=") else ln for ln in t.split("\n"))
        del f["parameters"]
        f["parameters"] = np.frombuffer(t.encode(), dtype="u1")
        for k, v in attrs.items():
            f.attrs[k] = np.int64(v)
    return damage


# Values the loader used to trust (session 11): before, NaN or infinite
# numbers, an event time before `now`, a negative time or a zero series
# interval ran without end; a cell face out of range read out of bounds
# (UBSan); a particle outside its cell, a changed radius or an unknown event
# kind ran on silently; parameters declaring 1e8 particles in a 10 KB file
# allocated and initialised for them before the state was found missing.
ev_cases.update({
    "ps_nan": ev_values("state/ps", ev_set(0, np.nan)),
    "ps_velocity_inf": ev_values("state/ps", ev_set(2, np.inf)),
    "ps_outside_cell": ev_values("state/ps", ev_set(0, 1e6)),
    "ps_radius_changed": ev_values("state/ps", ev_set(5, 3.0)),
    "t_pair_before_now": ev_values("state/t_pair", lambda a: a * 0 - 1e300),
    "t_cell_nan": ev_values("state/t_cell", lambda a: a * np.nan),
    "kind_99": ev_values("state/kind", lambda a: a * 0 + 99),
    "cell_what_99": ev_values("state/cell_what", lambda a: a * 0 + 99),
    "parent_out_of_range": ev_values("state/parent", lambda a: a * 0 + 0xfffffff0),
    "stuck_flags_all": ev_values("state/stuck", lambda a: a * 0 + 1),
    "now_nan": ev_values("state/reals", ev_set(0, np.nan)),
    "now_negative": ev_values("state/reals", ev_set(0, -1e300)),
    "series_dt_zero": ev_values("state/reals", ev_set(1, 0.0)),
    "rng_zero": ev_values("state/counters", lambda a: np.concatenate([a[:9], np.zeros(4, dtype="u8")])),
    # counters that do not add up, sums of non-negative terms made negative
    # (session 26: resumed and written to /results as they were)
    "collisions_wrapped": ev_values("state/counters", ev_set(1, 2**64 - 1)),
    "events_short": ev_values("state/counters", lambda a: np.concatenate([a[:1] - 1, a[1:]])),
    "sticks_not_stuck": ev_values("state/counters",  # the events' sum kept
                                  lambda a: np.concatenate([a[:1] + 1, a[1:3], a[3:4] + 1, a[4:]])),
    "ke_stuck_negative": ev_values("state/reals", ev_set(2, -1.0)),
    "wall_impulse_negative": ev_values("state/reals", ev_set(4, -1e-9)),
    "particles_1e8": ev_param("particles", "100000000", {"particles": 10**8, "ntot": 10**8 + 1}),
    # the seed (index 300, radius 1) grown to 1.4: the cells are sized by the
    # parameters' seed (side >= 1 + 0.5 since session 14), so particles could
    # touch it from cells the scans never visit; accepted before session 14
    "seed_radius_grown": ev_values("state/ps", ev_set(300 * 6 + 5, 1.4)),
})


def ev_series_rows(n, compress):
    """Every /series dataset n rows of zeros (stored: gzip where compress)."""
    def damage(f):
        for k, t in (("time", "f8"), ("kinetic_energy", "f8"), ("pressure", "f8"), ("stuck", "u8"),
                     ("collisions", "u8")):
            del f["series/" + k]
            f.create_dataset("series/" + k, data=np.zeros(n, dtype=t), chunks=(1 << 20,) if compress else None,
                             compression="gzip" if compress else None)
    return damage


# Accepted before session 16: a series interval of 1e-300 (not the
# parameter's times a power of 2: a million empty rows, one at a time), a
# series longer than a run keeps (65536 rows; 1.5e7 gzip rows in a 1 MB file
# took 600 MB), series times not in order or NaN.
ev_cases.update({
    "series_dt_1e-300": ev_values("state/reals", ev_set(1, 1e-300)),
    "series_dt_3x": ev_values("state/reals", lambda a: np.concatenate([a[:1], a[1:2] * 3, a[2:]])),
    "series_65537_rows": ev_series_rows(65537, False),
    "series_1.5e7_rows_gzip": ev_series_rows(15 * 10**6, True),
    "series_time_nan": ev_values("series/time", ev_set(-1, np.nan)),
    "series_time_backwards": ev_values("series/time", lambda a: a[::-1].copy()),
})
def ev_swap_parents(f, a):
    """The first two stuck particles made each other's parent."""
    i, j = (int(k) for k in f["state/stuck_idx"][:2])
    a[i], a[j] = j, i
    return a


def ev_params_text(fn):
    """The parameters' text changed by fn(str)."""
    def damage(f):
        t = fn(bytes(f["parameters"][()]).decode())
        del f["parameters"]
        f["parameters"] = np.frombuffer(t.encode(), dtype="u1")
    return damage


# Read silently before session 16: a last line cut of its newline, or what
# follows a NUL byte, took its default; a key given twice, the later value.
ev_cases.update({
    "params_last_line_cut": ev_params_text(lambda t: t + "t-max=2.5"),
    "params_nul": ev_params_text(lambda t: t.replace("\nseed=", "\0seed=")),
    "params_t_max_twice": ev_params_text(lambda t: t + "t-max=2.5\n"),
    # two stuck particles each the other's parent: a cycle in /cluster/parent
    "parent_cycle": lambda f: ev_values("state/parent", lambda a: ev_swap_parents(f, a))(f),
})
for name, fn in ev_cases.items():
    expect("event-ckpt-%s/resume" % name, ev_resume(ev_copy("eventck-" + name.replace("^", ""), fn)), "fail")
# (session 27) the checkpoint schedule a bare --resume keeps: exit 2, one
# line naming the attribute
for name, v in (("negative", -1.0), ("nan", np.nan), ("inf", np.inf), ("2e9", 2e9),
                ("string", np.bytes_(b"30m")), ("array", np.ones(3))):
    tag = "event-ckpt-schedule_seconds_%s/resume" % name
    runs.append(tag)
    rc, lines, _ = run(ev_resume(ev_copy("eventck-schedule-" + name, dlca_attr("/", SCHED_S, v))))
    check(rc == 2 and len(lines) == 1 and SCHED_S in lines[0], "%s: exit %s, want 2 and one line with %r: %r"
          % (tag, rc, SCHED_S, lines[:3]))


# ---- (session 27, s27-evfix) event checkpoints whose particles break the
# model's invariants, each value in range and every pending event one the
# loop could have made: resumed before, the damage went on into cluster.h5.
# Each must be refused with exit 2 and one line naming it, and the run
# directory left as it was (every file's bytes, no file added).
def dir_state(d):
    """{relative path: bytes} of every file under d."""
    out = {}
    for root, _, names in os.walk(d):
        for n in names:
            p = os.path.join(root, n)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, d)] = fh.read()
    return out


def refused(tag, args, want, d, limit=TIME_LIMIT, gone=None):
    """args refused within limit s: exit 2, one stderr line containing
    want, nothing on stdout, the directory d unchanged and `gone` (an
    output path) not made."""
    runs.append(tag)
    before = dir_state(d)
    try:
        p = subprocess.run([PDLA] + args, capture_output=True, timeout=limit)
    except subprocess.TimeoutExpired:
        check(False, "%s: did not end within %d s" % (tag, limit))
        return
    lines = p.stderr.decode("utf-8", "replace").rstrip("\n").split("\n")
    check(p.returncode == 2 and len(lines) == 1 and want in lines[0],
          "%s: exit %s, want 2 and one line with %r: %r" % (tag, p.returncode, want, lines[:3]))
    check(p.stdout == b"", "%s: printed %r" % (tag, p.stdout[:200]))
    check(dir_state(d) == before, tag + ": the directory's files changed")
    check(gone is None or not os.path.exists(gone), tag + ": wrote " + str(gone))


def ev_arrays(f):
    """The checkpoint's particle rows: ps as (ntot, 2D + 2) and D."""
    D = int(f.attrs["dim"])
    return f["state/ps"][()].reshape(int(f.attrs["ntot"]), 2 * D + 2), D


def ev_put(f, name, a):
    """Dataset `name` replaced by a (same type)."""
    t = f[name].dtype
    del f[name]
    f[name] = np.asarray(a).astype(t).reshape(-1)


def ev_free_pair(f):
    """The first two free particles."""
    st = f["state/stuck"][()]
    return [int(k) for k in np.flatnonzero(st[:int(f.attrs["particles"])] == 0)[:2]]


PER_PARTICLE = ("kind", "partner", "pcount", "cell", "cell_what", "t_pair", "t_cell")


def ev_duplicate(ke_stuck=None):
    """A free particle made an exact copy of another (its state and pending
    events), its collision count moved on so that events naming it are
    stale: the two overlap wholly. ke_stuck: also that stored sum (the
    overlap tolerance must not grow with it without bound)."""
    def damage(f):
        i, j = ev_free_pair(f)
        ps, _ = ev_arrays(f)
        ps[j] = ps[i]
        ev_put(f, "state/ps", ps)
        for k in PER_PARTICLE:
            a = f["state/" + k][()]
            a[j] = a[i]
            ev_put(f, "state/" + k, a)
        c = f["state/count"][()]
        c[j] += 1000
        ev_put(f, "state/count", c)
        if ke_stuck is not None:
            r = f["state/reals"][()]
            r[2] = ke_stuck
            ev_put(f, "state/reals", r)
    return damage


def ev_on_seed(f):
    """A free particle at rest on the seed (in the seed's cell, no pending
    event, its count moved on): a particle inside the seed."""
    n = int(f.attrs["particles"])
    i = ev_free_pair(f)[0]
    ps, D = ev_arrays(f)
    now = f["state/reals"][0]
    ps[i, :D] = ps[n, :D] + 0.1
    ps[i, D:2 * D] = 0
    ps[i, 2 * D] = now
    ev_put(f, "state/ps", ps)
    for k, v in (("kind", 0), ("t_pair", np.inf), ("cell_what", -1), ("t_cell", np.inf),
                 ("cell", f["state/cell"][n])):
        a = f["state/" + k][()]
        a[i] = v
        ev_put(f, "state/" + k, a)
    c = f["state/count"][()]
    c[i] += 1000
    ev_put(f, "state/count", c)


def ev_stuck_moved(f):
    """The first stuck particle moved 1e-4 of the contact distance away from
    its parent (its cell the same): no longer touching it."""
    i = int(f["state/stuck_idx"][0])
    ps, D = ev_arrays(f)
    q = ps[int(f["state/parent"][i])]
    d = ps[i, :D] - q[:D]
    sig = ps[i, 2 * D + 1] + q[2 * D + 1]
    ps[i, :D] += 1e-4 * sig * d / np.linalg.norm(d)
    ev_put(f, "state/ps", ps)


def ev_rest_moving(which):
    """A stuck particle (which 'stuck') or the seed ('seed') given a velocity,
    its local time now (so its position now is where it was)."""
    def damage(f):
        ps, D = ev_arrays(f)
        i = int(f["state/stuck_idx"][0]) if which == "stuck" else int(f.attrs["particles"])
        ps[i, D:2 * D] = 5.0
        ps[i, 2 * D] = f["state/reals"][0]
        ev_put(f, "state/ps", ps)
    return damage


def ev_relabel(f):
    """50 free particles of kind 0 relabelled kind 1 (their radius is the
    same, 0.5): 100 and 200 particles where the parameter gives 150 each."""
    sp = f["state/species"][()]
    st = f["state/stuck"][()]
    n = int(f.attrs["particles"])
    sel = [k for k in range(n) if sp[k] == 0 and not st[k]][:50]
    sp[sel] = 1
    ev_put(f, "state/species", sp)


ev2 = os.path.join(WORK, "event2")
rc, lines, _ = run(["--model", "event", "--dim", "2", "--species", "150:0.5:1,150:0.5:5", "--packing", "0.1",
                    "--seed-radius", "1", "--t-max", "2", "--series-dt", "0.5", "--seed", "3", "--out", ev2,
                    "--checkpoint"])
if rc != 0:
    sys.exit("the two-kind event base run failed: %r" % lines)
EK2 = os.path.join(ev2, "checkpoint.h5")
expect("event2-clean/resume", ev_resume(forged(EK2, "event2-clean", lambda f: None)[0]), "pass")
for name, src, fn, want in (
        ("duplicate", EK, ev_duplicate(), "particles overlap"),
        # the kinetic energy's bound (free and stuck, at most 100 d N kT)
        # refuses this ke_stuck before the overlap is measured (review E)
        ("duplicate_ke_stuck_1e300", EK, ev_duplicate(1e300), "kinetic energy"),
        ("free_on_seed", EK, ev_on_seed, "particles overlap"),
        ("stuck_moved", EK, ev_stuck_moved, "not at contact"),
        ("stuck_velocity", EK, ev_rest_moving("stuck"), "with a velocity"),
        ("seed_velocity", EK, ev_rest_moving("seed"), "with a velocity"),
        ("kinds_relabelled", EK2, ev_relabel, "kind 1 has 100 particles, its species parameter 150")):
    d, _ = forged(src, "eventck-" + name, fn)
    refused("event-ckpt-%s/resume" % name, ev_resume(d), want, d)

# ---- event cluster.h5 through pdla analyze -------------------------------
EC = os.path.join(ev, "cluster.h5")
expect("event-clean/analyze", ["analyze", EC], "pass")
ev_file_cases = {
    "series_time_2^61": lambda f: replace_dset(f, "series/time", (HUGE,), "f8", chunks=(65536,), maxshape=(None,)),
    "positions_1e8_rows": lambda f: replace_dset(f, "cluster/positions", (10**8, 2), "f8", chunks=(65536, 2)),
    "dim_array_5000": lambda f: f.attrs.__setitem__("dim", np.ones(5000, dtype="f8")),
    "box_side_array_5000": lambda f: f["results"].attrs.__setitem__("box_side", np.ones(5000, dtype="f8")),
    "truncated": None,
}
for name, fn in ev_file_cases.items():
    d, path = forged(EC, "evfile-" + name.replace("^", ""), fn)
    expect("event-file-%s/analyze" % name, ["analyze", path], "fail")

# A NaN cluster position gave R_g 0, a distance inf and exit 0 (refused
# now); an infinite series value printed "inf" in --json, which is no JSON
# (null now).
d, path = forged(EC, "evfile-position_nan", ev_values("cluster/positions", ev_set(0, np.nan)))
expect("event-file-position_nan/analyze", ["analyze", path], "fail")
d, path = forged(EC, "evfile-ke_inf", ev_values("series/kinetic_energy", ev_set(-1, np.inf)))
expect("event-file-ke_inf/analyze", ["analyze", "--json", path], "pass")
try:
    with open(os.path.join(WORK, "an.json"), "w+b") as out:
        subprocess.run([PDLA, "analyze", "--json", path], stdout=out, stderr=subprocess.DEVNULL, timeout=TIME_LIMIT)
        out.seek(0)
        check(json.loads(out.read())["kinetic_energy_last"] is None, "event-file-ke_inf: kinetic_energy_last")
except ValueError as e:
    check(False, "event-file-ke_inf/analyze --json: not JSON: %s" % e)

# ---- event cluster.h5 through pdla render --------------------------------
# A radius for each position, free positions of the cluster's dimension,
# finite numbers: before, a short /cluster/radii or /free/radii, or a
# 1-column /free/positions, were read past their end (ASan: heap overflow),
# a NaN position made the disc bounds undefined, and a radius of 6e4 box
# sides drew its disc in 1e12 pixel steps (no end within the time limit).
def ev_render(path):
    return ["render", path, "-o", os.path.join(os.path.dirname(path), "x.png")]


expect("event-clean/render", ev_render(forged(EC, "evrender-clean", lambda f: None)[1]), "pass")
ev_render_cases = {
    "cluster_radii_short": ev_values("cluster/radii", lambda a: a[:1]),
    "free_radii_short": ev_values("free/radii", lambda a: a[:1]),
    "free_positions_1_column": ev_values("free/positions", lambda a: a[:, :1].copy()),
    "free_position_nan": ev_values("free/positions", lambda a: a * np.nan),
    "free_radius_inf": ev_values("free/radii", ev_set(0, np.inf)),
    "box_side_nan": lambda f: f["results"].attrs.__setitem__("box_side", np.nan),
}
for name, fn in ev_render_cases.items():
    d, path = forged(EC, "evrender-" + name, fn)
    expect("event-file-%s/render" % name, ev_render(path), "fail")


def ev_free_rows(n, at, radius, box=None):
    """/free replaced by n gzip rows at `at` (a fraction of the box side)
    with radius `radius` (a fraction too; box: the box side set to it)."""
    def damage(f):
        L = float(f["results"].attrs["box_side"]) if box is None else box
        D = int(f.attrs["dim"])
        for k, shape, v in (("positions", (n, D), at * L), ("radii", (n,), radius * L),
                            ("velocities", (n, D), 0.0), ("species", (n,), 0)):
            t = f["free/" + k].dtype
            del f["free/" + k]
            f.create_dataset("free/" + k, data=np.full(shape, v, dtype=t), compression="gzip", chunks=True)
        f["results"].attrs["box_side"] = L
    return damage


# The clean files of a periodic box (centres wrapped into [0, L], discs
# across its faces) pass the box checks below, before and after a resume
# (a --seeds run's render: event-adversary).
evp = os.path.join(WORK, "event-periodic")
rc, lines, _ = run(["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.3", "--seed-radius", "1",
                    "--box-walls", "periodic", "--t-max", "2", "--seed", "3", "--out", evp, "--checkpoint"])
if rc != 0:
    sys.exit("the periodic event base run failed: %r" % lines)
expect("event-periodic-clean/render", ev_render(os.path.join(evp, "cluster.h5")), "pass")
expect("event-periodic-clean/resume", ["--model", "event", "--resume", evp, "--t-max", "3", "--quiet"], "pass")
expect("event-periodic-clean/render-resumed", ev_render(os.path.join(evp, "cluster.h5")) + ["--force"], "pass")

# (session 27, s27-evfix) discs the model never writes, which each cost the
# whole image: 2e4 discs of half the box at its centre ran for minutes
# (N x image size). Refused at once: outside the box (the forged side of 1
# leaves the cluster outside), larger than half the box (a radius of 4e6
# sides was drawn in the image's pixels before, and passed), more volume
# than the box (packing above 1). Exit 2, one line, no image, within 10 s.
for name, fn, want in (
        ("2e4_discs_box_1", ev_free_rows(20000, 0.5, 0.5, box=1.0), "outside the box"),
        ("2e4_discs_half_box", ev_free_rows(20000, 0.5, 0.5), "filling more than the box"),
        ("free_radius_4e6", ev_values("free/radii", ev_set(0, 4e6)), "larger than half"),
        ("free_position_outside", ev_values("free/positions", ev_set(0, -3.0)), "outside the box")):
    d, path = forged(EC, "evrender-" + name, fn)
    png = os.path.join(d, "x.png")
    refused("event-file-%s/render" % name, ["render", path, "-o", png], want, d, limit=10, gone=png)

# (session 27, s27-evfix) a NaN seed, or a box side of 0 or less, went into
# analyze's numbers (farthest from a seed inf, the D_f fit over box/8), exit
# 0; render already refused them. Exit 2, one line.
SEED_WANT = "seed position or radius is not finite"
for name, fn, want in (
        ("seed_x_nan", lambda f: f["cluster"].attrs.__setitem__("seed_x", np.nan), SEED_WANT),
        ("seed_radius_nan", lambda f: f["cluster"].attrs.__setitem__("seed_radius", np.nan), SEED_WANT),
        ("seed_positions_nan", lambda f: (f["cluster"].create_dataset("seed_positions", data=np.full((3, 2), np.nan)),
                                          f["cluster"].create_dataset("seed_radii", data=np.ones(3))), SEED_WANT),
        ("seed_radii_inf", lambda f: (f["cluster"].create_dataset("seed_positions", data=np.ones((3, 2))),
                                      f["cluster"].create_dataset("seed_radii", data=np.full(3, np.inf))), SEED_WANT),
        ("box_side_-5", lambda f: f["results"].attrs.__setitem__("box_side", -5.0), "box_side -5"),
        ("box_side_0", lambda f: f["results"].attrs.__setitem__("box_side", 0.0), "box_side 0")):
    d, path = forged(EC, "evanalyze-" + name, fn)
    for reader, args in (("analyze", ["analyze", path]), ("analyze-json", ["analyze", "--json", path]),
                         ("render", ev_render(path))):
        refused("event-file-%s/%s" % (name, reader), args, want if reader != "render" else "malformed", d,
                gone=args[-1] if reader == "render" else None)

# (session 27, s27-evfix) a /species table of more rows than the kinds a run
# may have (EV_MAX_SPECIES, 8): info --json printed half an object and
# "cannot read its attributes", exit 1. Checked before anything is printed.
d, path = forged(EC, "evinfo-species_9_rows",
                 lambda f: [(f.__delitem__("species/" + k), f.create_dataset("species/" + k, data=np.ones(9)))
                            for k in ("count", "radius", "density", "stuck", "sticky", "mass")])
for args in (["info", path], ["info", "--json", path]):
    refused("event-file-species_9_rows/" + " ".join(args[:-1]), args, "more than 8 kinds", d)

# ---- event cluster.h5 through pdla export --------------------------------
# A stuck particle's position NaN or radius inf or negative: refused, and no
# output file left (before session 17: exit 0 and NaN written to the file).
def ev_export(path, fmt):
    return ["export", path, "--format", fmt, "-o", os.path.join(os.path.dirname(path), "x." + fmt)]


for fmt in ("ply", "csv", "xyz"):
    expect("event-clean/export-" + fmt, ev_export(forged(EC, "evexport-clean-" + fmt, lambda f: None)[1], fmt),
           "pass")
for name, fn in {"cluster_position_nan": ev_values("cluster/positions", lambda a: a * np.nan),
                 "cluster_radius_inf": ev_values("cluster/radii", ev_set(0, np.inf)),
                 "cluster_radius_negative": ev_values("cluster/radii", ev_set(0, -1.0))}.items():
    for fmt in ("ply", "csv", "xyz"):
        d, path = forged(EC, "evexport-%s-%s" % (name, fmt), fn)
        expect("event-file-%s/export-%s" % (name, fmt), ev_export(path, fmt), "fail")
        check(not os.path.exists(os.path.join(d, "x." + fmt)), "event-file-%s/export-%s: output left" % (name, fmt))

print("hostile-models: %d runs, %d failures" % (len(runs), len(failures)))
sys.exit(1 if failures else 0)
