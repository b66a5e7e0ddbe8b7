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
failures, in seconds and bounded memory).

Refused (exit 2, one line): a missing file, a DLCA and an event file, no
eps, an unknown option, two files.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

T = Tally()
PDLA = sys.argv[1]


def run(args, timeout=300):
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                       timeout=timeout)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


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


def forged(src, tmp, name, fn):
    dst = os.path.join(tmp, name + ".h5")
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        fn(f)
    return dst


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
    cases.append(("detached-tree", t2, lambda f: moved(f, 123, far), ["contacts     1 particles touch no other"]))
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
    T.check(caught is not None and ("overlaps     " in caught[0] and "none" not in caught[0].split("overlaps")[1][:20]
                                    or "touch no other" in caught[0]),
            "no forged checkpoint of %d caught by check while the loader accepts it" % len(cands))


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


def refused(tmp):
    check_file(os.path.join(tmp, "nope.h5"), 2, (), "missing file")
    d = os.path.join(tmp, "dlca")
    rc, _, err = run([PDLA, "--model", "dlca", "--dim", "2", "--box", "32", "--fill", "0.05",
                      "--out", d, "-q"])
    if T.check(rc == 0, "dlca run: %s" % err):
        check_file(os.path.join(d, "cluster.h5"), 2, (), "dlca file")
    e = os.path.join(tmp, "event")
    rc, _, err = run([PDLA, "--model", "event", "--dim", "2", "--particles", "200", "--packing", "0.05",
                      "--out", e])
    if T.check(rc == 0, "event run: %s" % err):
        check_file(os.path.join(e, "cluster.h5"), 2, (), "event file")


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
        checkpoints(tmp)
        refused(tmp)
        refused_args(files, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    T.done()


main()
