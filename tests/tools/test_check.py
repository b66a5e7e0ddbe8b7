#!/usr/bin/python3
"""test_check.py PDLA - `pdla check`: grown clusters pass, forged ones fail.

Pass (exit 0, "result pass"): 2D in tree order; 3D in arrival order with
every R_g(N) sample recomputed bit for bit; 2D and 3D grown by worker
threads (--threads 2 and 4, arrival order), whose R_g sums must cover
exactly the first N particles in arrival order (engine.c counts a particle
that takes the gyration mutex before its turn only in its turn); the
reference walkers; --no-snap-contact with a wide eps.

Fail (exit 1, the report naming the fault, one line on stderr), each on a
copy of a passing file changed in one way: a particle moved onto another
(overlap); the last arrival moved 10 diameters out (detached, arrival
order) and a particle moved out of a tree-order file (detached, found over
the tree); rows 0 and 1 swapped (seed not first); /results rg_diam and one
R_g sample changed by one ulp, r_ext_units by one unit, particles by one; a
coordinate beyond 2^28; 2e6 rows all at the origin (reading stops at 10000
failures, in seconds and bounded memory); a checkpoint and a cluster.h5
cut to half their size (HDF5 cannot open them). A passing 2e6-row file whose
positions are one gzip'ed chunk is read by check and analyze once, not once
per slab (bytes read under 3x the file's size).

Refused (exit 2, one line): a missing file, no eps, an unknown option,
two files. A DLCA file is checked (test_check_dlca.py: a grown one passes
here too), and so is an event file (test_check_event.py).
"""
import json
import math
import os
import shutil
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally, forged_copy as forged, run_text  # noqa: E402

T = Tally()
PDLA = sys.argv[1]


def run(args, timeout=300):
    return run_text(args, timeout)


def grow(tmp, name, args):
    out = os.path.join(tmp, name)
    rc, _, err = run([PDLA, *args, "--out", out, "-q"])
    T.check(rc == 0, "grow %s: rc %d %s" % (name, rc, err))
    return os.path.join(out, "cluster.h5")


def check_file(path, want_rc, want_text=(), what=""):
    rc, out, err = run([PDLA, "check", path])
    ok = T.check(rc == want_rc, "%s: rc %d, want %d\n%s%s" % (what, rc, want_rc, out, err))
    for t in want_text:
        T.check(t in out, "%s: %r not in the report\n%s" % (what, t, out))
    if want_rc == 1:
        T.check(err.count("\n") == 1 and "fails the check" in err, "%s: stderr %r" % (what, err))
    if want_rc == 2:
        T.check(out == "" and err.count("\n") == 1 and err.startswith("pdla check: "),
                "%s: want one line on stderr, got %r / %r" % (what, out, err))
    return ok, out


def passing(tmp):
    files = {}
    files["2d"] = grow(tmp, "2d", ["--dim", "2", "--target", "3000", "--seed", "3"])
    files["3d"] = grow(tmp, "3d", ["--dim", "3", "--target", "3000", "--arrival", "--seed", "4"])
    files["2d-thr"] = grow(tmp, "2d-thr", ["--dim", "2", "--target", "60000", "--serial-until", "2000",
                                            "--threads", "2", "--arrival"])
    files["3d-thr"] = grow(tmp, "3d-thr", ["--dim", "3", "--target", "30000", "--serial-until", "1000",
                                            "--threads", "4", "--arrival"])
    files["ref"] = grow(tmp, "ref", ["--dim", "2", "--target", "5000", "--serial-until", "500",
                                      "--reference-walkers", "8", "--arrival"])
    files["nosnap"] = grow(tmp, "nosnap", ["--dim", "2", "--target", "5000", "--no-snap-contact",
                                            "--eps", "8", "--arrival"])
    for k, path in files.items():
        _, out = check_file(path, 0, ["result       pass", "overlaps     none"], "grown " + k)
        if k != "2d":
            T.check("every one as stored" in out, "grown %s: series not all as stored\n%s" % (k, out))
    rc, out, _ = run([PDLA, "check", "--json", files["3d"]])
    j = json.loads(out) if rc == 0 else {}
    T.check(rc == 0 and j.get("pass") is True and j.get("particles") == 3000 and j.get("overlaps") == 0
            and j.get("series_mismatches") == 0 and j.get("series_checked", 0) > 300,
            "--json of a grown file: rc %d %r" % (rc, out[:300]))
    return files


def moved(f, row, xyz):
    pos = f["cluster/positions"]
    pos[row] = xyz


def forgeries(files, tmp):
    a3, t2 = files["3d"], files["2d"]
    with h5py.File(a3, "r") as f:
        p3 = f["cluster/positions"][:]
        rg = float(f["results"].attrs["rg_diam"])
    last = p3[-1].copy()
    out_dir = last + np.sign(last) * 320 + (last == 0) * 320
    cases = [
        ("overlap", a3, lambda f: moved(f, 100, p3[50]), ["overlaps     "]),
        ("detached-arrival", a3, lambda f: moved(f, len(p3) - 1, out_dir), ["contacts     1 particles touch no earlier"]),
        ("seed-second", a3, lambda f: (moved(f, 0, p3[1]), moved(f, 1, p3[0])), ["NOT at the origin"]),
        ("rg-ulp", a3, lambda f: f["results"].attrs.modify("rg_diam", np.nextafter(rg, 2 * rg)),
         ["R_g          ", "DIFFERS"]),
        ("series-ulp", a3, lambda f: f["gyration/rg_diam"].__setitem__(
            200, np.nextafter(f["gyration/rg_diam"][200], 1e300)), ["R_g series   1 of", "sample 200"]),
        ("rext-unit", a3, lambda f: f["results"].attrs.modify(
            "r_ext_units", f["results"].attrs["r_ext_units"] + 1), ["R_ext", "DIFFERS"]),
        ("count-one", a3, lambda f: f["results"].attrs.modify(
            "particles", f["results"].attrs["particles"] + 1), ["count        /results particles: DIFFERS"]),
        ("out-of-range", a3, lambda f: moved(f, 7, [1 << 30, 0, 0]), ["range        1 rows beyond"]),
    ]
    with h5py.File(t2, "r") as f:
        p2 = f["cluster/positions"][:]
    far = p2[123] + np.array([0, 1 << 20])
    cases.append(("detached-tree", t2, lambda f: moved(f, 123, far), ["contacts     1 particles not joined to the seed"]))
    for name, src, fn, texts in cases:
        check_file(forged(src, tmp, name, fn), 1, texts + ["result       FAIL"], "forged " + name)


def checkpoints(tmp):
    """A grown checkpoint passes (tree order, and arrival order with worker
    threads); one whose chunk bytes are forged so that the library's loader
    still accepts it (the x bytes of two particles of one chunk swapped:
    count, gyration sums and tree structure unchanged) fails with exit 1."""
    ck = {}
    for name, args in (("ck3", ["--dim", "3", "--target", "3000", "--seed", "5"]),
                       ("ck2thr", ["--dim", "2", "--target", "20000", "--serial-until", "2000", "--threads", "2",
                                   "--arrival"])):
        out = os.path.join(tmp, name)
        rc, _, err = run([PDLA, *args, "--checkpoint", "--out", out, "-q"])
        T.check(rc == 0, "grow %s: %s" % (name, err))
        ck[name] = os.path.join(out, "checkpoint.h5")
        _, out_txt = check_file(ck[name], 0, ["result       pass"], "checkpoint " + name)
    T.check("every one as stored" in out_txt, "checkpoint with arrival: series not checked\n" + out_txt)
    with h5py.File(ck["ck3"], "r") as f:
        packed = f["tree/chunks_packed"][:].tobytes()
    cands, at = [], 0
    while at < len(packed) and len(cands) < 40:
        link = int.from_bytes(packed[at:at + 4], "little")
        m = link if link <= 10 else 10
        if m >= 2 and abs(packed[at + 4] - packed[at + 5]) >= 64:
            cands.append(at + 4)
        at += 4 + 3 * m
    caught = None
    for k, off in enumerate(cands):
        forged_ck = os.path.join(tmp, "ck-forged-%d.h5" % k)
        shutil.copyfile(ck["ck3"], forged_ck)
        with h5py.File(forged_ck, "r+") as f:
            b = bytearray(packed)
            b[off], b[off + 1] = b[off + 1], b[off]
            f["tree/chunks_packed"][...] = np.frombuffer(bytes(b), dtype=np.uint8)
        rc, out, err = run([PDLA, "check", forged_ck])
        if rc == 1:
            caught = (out, err)
            break
    # The same forged tree under an arrival record: the record passes its
    # checks, the tree (what --resume grows from) is not the record's.
    out = os.path.join(tmp, "ck3a")
    rc, _, err = run([PDLA, "--dim", "3", "--target", "3000", "--seed", "5", "--arrival", "--checkpoint",
                      "--out", out, "-q"])
    ck3a = os.path.join(out, "checkpoint.h5")
    with h5py.File(ck3a, "r") as f:
        same = f["tree/chunks_packed"][:].tobytes() == packed
    T.check(rc == 0 and same, "the arrival run's tree differs from the tree-order run's: %s" % err)
    if caught is not None and same:
        shutil.copyfile(ck3a, ck3a + ".forged.h5")
        with h5py.File(ck3a + ".forged.h5", "r+") as f:
            b = bytearray(packed)
            off = cands[k]
            b[off], b[off + 1] = b[off + 1], b[off]
            f["tree/chunks_packed"][...] = np.frombuffer(bytes(b), dtype=np.uint8)
        check_file(ck3a + ".forged.h5", 1, ["tree         2 particles of the tree are NOT in the arrival record"],
                   "forged tree under an arrival record")
    # A checkpoint the loader refuses as damaged fails the check (exit 1).
    dmg = os.path.join(tmp, "ck-damaged.h5")
    shutil.copyfile(ck["ck3"], dmg)
    with h5py.File(dmg, "r+") as f:
        f["state"].attrs.modify("gyration_n", int(f["state"].attrs["gyration_n"]) + 1)
    rc, out, err = run([PDLA, "check", dmg])
    T.check(rc == 1 and err.count("\n") == 1 and "damaged" in err, "damaged checkpoint: rc %d %r" % (rc, err))
    # Truncated (a copy cut short, a full disk): HDF5 sees its signature but
    # cannot open the file. A damaged file fails (exit 1), as the loader's
    # refusal does; before, check called it a foreign file (exit 2).
    for src, what in ((ck["ck3"], "checkpoint"), (os.path.join(os.path.dirname(ck["ck3"]), "cluster.h5"),
                                                   "cluster.h5")):
        cut = os.path.join(tmp, "truncated-" + what)
        with open(src, "rb") as f_in, open(cut, "wb") as f_out:
            f_out.write(f_in.read()[:os.path.getsize(src) // 2])
        rc, out, err = run([PDLA, "check", cut])
        T.check(rc == 1 and out == "" and err.count("\n") == 1 and "damaged" in err,
                "truncated %s: rc %d %r %r" % (what, rc, out, err))
    T.check(caught is not None and ("overlaps     " in caught[0] and "none" not in caught[0].split("overlaps")[1][:20]
                                    or "not joined to the seed" in caught[0]),
            "no forged checkpoint of %d caught by check while the loader accepts it" % len(cands))


def synthetic(tmp, name, P, order="tree", D=32, eps=2, results=True, params=None, gyr=None, layout=None):
    """A small cluster file written by hand, with R_g and R_ext computed as
    the engine does (exact integer sums, long double mean); layout: h5py's
    create_dataset options for /cluster/positions (chunks, compression)."""
    P = np.asarray(P, dtype=np.int64)
    path = os.path.join(tmp, name + ".h5")
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "pdla-cluster"
        f.attrs["format_version"] = 1
        g = f.create_group("parameters")
        g.attrs["dim"], g.attrs["resolution"], g.attrs["eps"] = 2, D, eps
        for k, v in (params or {}).items():
            g.attrs[k] = v
        d = f.create_dataset("cluster/positions", data=P.astype(np.int32), **(layout or {}))
        d.attrs["diameter_units"] = D
        if order:
            d.attrs["order"] = order
        r = f.create_group("results")
        if results:
            n = np.longdouble(len(P))
            m2 = sum((np.longdouble(int(x)) / n) ** 2 for x in P.sum(axis=0))
            v = np.longdouble(int((P * P).sum())) / n - m2
            r.attrs["particles"] = len(P)
            r.attrs["rg_diam"] = float(np.sqrt(np.float64(v) if v > 0 else 0.0)) / D
            r2 = int((P * P).sum(axis=1).max())
            q = math.isqrt(r2)
            r.attrs["r_ext_units"] = q + (q * q < r2)
        if gyr:
            f.create_dataset("gyration/N", data=np.array(gyr[0], dtype=np.uint64))
            f.create_dataset("gyration/rg_diam", data=np.array(gyr[1], dtype=np.float64))
    return path


def hand_made(tmp):
    """Files a reviewer forged by hand: what grown clusters never are."""
    L = 1 << 28
    line = [[0, 0], [32, 0], [64, 0]]
    ok = synthetic(tmp, "line", line)
    check_file(ok, 0, ["result       pass"], "hand-made line")
    check_file(synthetic(tmp, "disconnected", [[0, 0], [32, 0], [100000, 0], [100032, 0]]), 1,
               ["contacts     2 particles not joined to the seed"], "two dimers apart")
    for sign in (1, -1):
        check_file(synthetic(tmp, "limit%d" % sign, [[0, 0], [32 * sign, 0], [sign * (L - 32), 0], [sign * L, 0]]),
                   1, ["range        1 rows beyond"], "a row at x = %d 2^28" % sign)
    check_file(synthetic(tmp, "no-order", line, order=None, params={"record_arrival": 1},
                         gyr=([1, 2, 3], [7.0, 8.0, 9.0])), 1, ["order        NOT arrival"], "order dropped")
    check_file(synthetic(tmp, "no-results", line, order="arrival", results=False,
                         params={"rg_per_decade": 100}), 1,
               ["count        /results particles: NOT stored", "R_g series   MISSING"], "no /results, no series")
    nan = synthetic(tmp, "nan-rg", line)
    with h5py.File(nan, "r+") as f:
        f["results"].attrs["rg_diam"] = np.nan
    check_file(nan, 1, ["R_g          ", "NOT stored"], "R_g NaN")
    mism = synthetic(tmp, "d-mismatch", [[0, 0], [16, 0], [32, 0]], D=16)
    with h5py.File(mism, "r+") as f:
        f["parameters"].attrs["resolution"] = 32
    check_file(mism, 2, (), "diameter_units against resolution")
    lone = synthetic(tmp, "lone-seed", [[0, 0], [1000, 0], [1032, 0]])
    rc, out, _ = run([PDLA, "check", "--json", lone])
    j = json.loads(out) if out else {}
    T.check(rc == 1 and j.get("detached") == 2 and j.get("first_detached", {}).get("row", 0) is None
            and j["first_detached"]["x"] in ([1000, 0], [1032, 0]),
            "--json of a lone seed: %r" % out[:400])
    # A series of 2^24 rows (gzip'd zeros, a file of about 100 KB) beside 3 particles.
    bomb = synthetic(tmp, "series-bomb", line, order="arrival", params={"rg_per_decade": 100})
    with h5py.File(bomb, "r+") as f:
        n = 1 << 24
        for name, t in (("gyration/N", "<u8"), ("gyration/rg_diam", "<f8")):
            d = f.create_dataset(name, (n,), t, chunks=(1 << 20,), compression="gzip", compression_opts=9)
            for i in range(0, n, 1 << 20):
                d[i:i + (1 << 20)] = np.zeros(1 << 20, dtype=t)
    rc, out, err = run(["/usr/bin/time", "-f", "%e %M", PDLA, "check", bomb], timeout=120)
    last = err.strip().splitlines()[-1].split()
    T.check(rc == 2 and "rows, more than" in err and float(last[1]) < 100000,
            "series bomb: rc %d, %s KB\n%s" % (rc, last[1], err))


def zero_rows(files, tmp):
    """2e6 rows at the origin: stops after 10000 failures, quickly."""
    dst = os.path.join(tmp, "zeros.h5")
    with h5py.File(files["2d"], "r") as src, h5py.File(dst, "w") as f:
        for k, v in src.attrs.items():
            f.attrs[k] = v
        for g in ("parameters", "results", "Code"):
            src.copy(g, f)
        n = 2000000
        d = f.create_dataset("cluster/positions", data=np.zeros((n, 2), dtype="<i4"), chunks=(65536, 2))
        for k, v in src["cluster/positions"].attrs.items():
            d.attrs[k] = v
        f["results"].attrs.modify("particles", n)
    rc, out, err = run(["/usr/bin/time", "-f", "%e %M", PDLA, "check", dst], timeout=120)
    last = err.strip().splitlines()[-1].split() if err.strip() else ["nan", "nan"]
    T.check(rc == 1 and "reading stopped" in out, "zero rows: rc %d\n%s%s" % (rc, out, err))
    T.check(float(last[0]) < 20 and float(last[1]) < 200000, "zero rows: %s s, %s KB" % tuple(last))


def rchar():
    """Bytes this process and its reaped children have read (/proc/self/io)."""
    with open("/proc/self/io") as f:
        return int(next(ln for ln in f if ln.startswith("rchar:")).split()[1])


def one_chunk(tmp):
    """A foreign file whose /cluster/positions (2e6 rows, a filled square
    lattice, a passing cluster) is one gzip'ed 16 MB chunk: the tools read
    it in slabs of 65536 rows, and HDF5's 1 MiB chunk cache cannot hold the
    chunk, so each slab decompressed it again: check read 68 MB of a 2.2 MB
    file, analyze (two passes) 136 MB in 2 s. Now the chunk is cached and
    read once. Bytes read, not seconds: deterministic."""
    k = 707
    g = np.arange(-k, k + 1) * 32
    x, y = np.meshgrid(g, g)
    P = np.stack([x.ravel(), y.ravel()], axis=1)
    o = np.flatnonzero((P == 0).all(axis=1))[0]
    P[[0, o]] = P[[o, 0]]  # the seed first, at the origin
    path = synthetic(tmp, "one-chunk", P, layout={"chunks": (len(P), 2), "compression": "gzip",
                                                   "compression_opts": 1})
    size = os.path.getsize(path)
    for tool, want in (("check", "result       pass"), ("analyze", "D_f")):
        before = rchar()
        rc, out, err = run([PDLA, tool, path], timeout=120)
        got = rchar() - before
        T.check(rc == 0 and want in out, "one-chunk %s: rc %d\n%s%s" % (tool, rc, out[-400:], err))
        T.check(got < 3 * size, "one-chunk %s: read %d bytes of a %d-byte file (want < 3x: the chunk once)" %
                (tool, got, size))


def refused(tmp):
    check_file(os.path.join(tmp, "nope.h5"), 2, (), "missing file")
    d = os.path.join(tmp, "dlca")
    rc, _, err = run([PDLA, "--model", "dlca", "--dim", "2", "--box", "32", "--fill", "0.05",
                      "--out", d, "-q"])
    if T.check(rc == 0, "dlca run: %s" % err):  # checked, not refused: test_check_dlca.py
        check_file(os.path.join(d, "cluster.h5"), 0, ("result       pass",), "dlca file")
    e = os.path.join(tmp, "event")
    rc, _, err = run([PDLA, "--model", "event", "--dim", "2", "--particles", "200", "--packing", "0.05",
                      "--out", e])
    if T.check(rc == 0, "event run: %s" % err):
        check_file(os.path.join(e, "cluster.h5"), 0, ("model        event",), "event file (test_check_event.py)")


def refused_args(files, tmp):
    noeps = forged(files["2d"], tmp, "noeps", lambda f: f["parameters"].attrs.__delitem__("eps"))
    check_file(noeps, 2, (), "no eps")
    for args, what in ((["--bogus", files["2d"]], "unknown option"),
                       ([files["2d"], files["3d"]], "two files")):
        rc, out, err = run([PDLA, "check", *args])
        T.check(rc == 2 and out == "" and err.count("\n") == 1, "%s: rc %d %r %r" % (what, rc, out, err))


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-check-")
    try:
        files = passing(tmp)
        forgeries(files, tmp)
        zero_rows(files, tmp)
        one_chunk(tmp)
        checkpoints(tmp)
        hand_made(tmp)
        refused(tmp)
        refused_args(files, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    T.done()


main()
