#!/usr/bin/python3
"""test_export_kinds.py - `pdla export` on every pdla output that holds particles.

Usage: test_export_kinds.py PDLA

Files grown here: a DLA cluster.h5 (3D, arrival order), an ensemble.h5 with
kept positions (2D arrival order; 3D tree order), a DLCA cluster.h5 (2D and
3D) and an event-model cluster.h5 (2D and 3D). Each is exported to ply, csv
and xyz, once with the default slabs and once with --slab-rows 7 (the bytes
must be the same), and read back:
 - PLY by a strict reader (exactly the header pdla promises, with the
   `uint cluster` property where the file has clusters), x y z radius
   compared with h5py's data as float32, bit for bit;
 - CSV by numpy (header names, coordinates to 1e-12 of h5py's / D, the
   radius, arrival and cluster columns exactly);
 - XYZ by a parser of the extended XYZ lines (count, Properties, rows).
An ensemble's --cluster I gives cluster I's rows alone; without it every
cluster with a cluster column. Bad uses (--cluster on a DLCA file, an index
past M, an ensemble without positions, a 4D DLCA lattice) give one line and
exit 2. Memory: a synthetic ensemble of 4x10^6 rows (32 MB of positions) exports to PLY and CSV in
40 MB of address space (not under AddressSanitizer).
"""
import os
import resource
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

PDLA = os.path.abspath(sys.argv[1])
fails = 0
checks = 0


def check(ok, what):
    global fails, checks
    checks += 1
    if not ok:
        fails += 1
        print("FAIL:", what, file=sys.stderr, flush=True)
    return ok


def run(args, limit_as=None):
    def pre():
        if limit_as:
            resource.setrlimit(resource.RLIMIT_AS, (limit_as, limit_as))
    p = subprocess.run(args, capture_output=True, text=True, preexec_fn=pre, stdin=subprocess.DEVNULL)
    return p.returncode, p.stdout, p.stderr


def grow(args, what):
    rc, _, se = run([PDLA] + args)
    return check(rc == 0, "%s: exit %d: %s" % (what, rc, se.strip()))


def s(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def expected(path, kind, cluster=None):
    """What the export must hold, from h5py: dict of pos (in the output
    unit, float64), radius, arrival, cluster (arrays or None), dim, unit."""
    with h5py.File(path, "r") as f:
        if kind == "dla":
            d = f["/cluster/positions"]
            du = int(d.attrs["diameter_units"])
            q = d[...].astype(np.int64)
            arr = np.arange(len(q)) if s(d.attrs["order"]) == "arrival" else None
            return dict(q=q, du=du, pos=q / du, radius=None, arrival=arr, cluster=None, unit="diameters")
        if kind == "ensemble":
            d = f["/clusters/positions"]
            du, n = int(d.attrs["diameter_units"]), int(d.attrs["rows_per_cluster"])
            q = d[...].astype(np.int64)
            ids = np.arange(len(q)) // n
            arr = np.arange(len(q)) % n if s(d.attrs["order"]) == "arrival" else None
            if cluster is not None:
                q, ids = q[cluster * n:(cluster + 1) * n], None
                arr = arr[cluster * n:(cluster + 1) * n] if arr is not None else None
            return dict(q=q, du=du, pos=q / du, radius=None, arrival=arr, cluster=ids, unit="diameters")
        if kind == "dlca":
            q = f["/monomers/position"][...].astype(np.int64)
            return dict(q=q, du=1, pos=q.astype(np.float64), radius=None, arrival=None,
                        cluster=f["/monomers/cluster"][...].astype(np.int64), unit="lattice sites")
        pos = f["/cluster/positions"][...]
        return dict(q=None, du=1, pos=pos, radius=f["/cluster/radii"][...], arrival=np.arange(len(pos)),
                    cluster=None, unit="model lengths")


def read_ply(path, with_cluster):
    data = open(path, "rb").read()
    end = data.find(b"end_header\n")
    if end < 0:
        raise ValueError("no end_header")
    lines = data[:end].decode("ascii").split("\n")[:-1]
    if lines[:2] != ["ply", "format binary_little_endian 1.0"]:
        raise ValueError("bad magic or format: %r" % lines[:2])
    body = [ln for ln in lines[2:] if not ln.startswith("comment ")]
    props = ["property float x", "property float y", "property float z", "property float radius",
             "property uchar red", "property uchar green", "property uchar blue"]
    if with_cluster:
        props.append("property uint cluster")
    if not body or not body[0].startswith("element vertex ") or body[1:] != props:
        raise ValueError("unexpected header: %r" % body)
    n = int(body[0].split()[2])
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("radius", "<f4"), ("red", "u1"), ("green", "u1"),
              ("blue", "u1")] + ([("cluster", "<u4")] if with_cluster else [])
    dt = np.dtype(fields)
    raw = data[end + len(b"end_header\n"):]
    if len(raw) != n * dt.itemsize:
        raise ValueError("body of %d bytes for %d vertices of %d" % (len(raw), n, dt.itemsize))
    return np.frombuffer(raw, dtype=dt)


def check_ply(path, e, name):
    try:
        v = read_ply(path, e["cluster"] is not None)
    except (ValueError, UnicodeDecodeError, IndexError) as x:
        return check(False, "%s: strict PLY reader: %s" % (name, x))
    n, dim = e["pos"].shape
    if not check(len(v) == n, "%s: %d vertices, want %d" % (name, len(v), n)):
        return
    for a, c in enumerate("xyz"):
        w = (e["q"][:, a] / e["du"] if e["q"] is not None else e["pos"][:, a]) if a < dim else np.zeros(n)
        check(np.array_equal(v[c], w.astype(np.float32)), "%s: %s differs" % (name, c))
    r = e["radius"] if e["radius"] is not None else np.full(n, 0.5)
    check(np.array_equal(v["radius"], r.astype(np.float32)), "%s: radius differs" % name)
    if e["cluster"] is not None:
        check(np.array_equal(v["cluster"], e["cluster"]), "%s: cluster ids differ" % name)
    # README: "PLY colours: arrival index, else the cluster id (DLCA), else
    # the distance", in the inferno map, whose brightness rises: along that
    # order it never falls (beyond 1 of 255), from dark to bright
    if e["arrival"] is not None:
        key, by = e["arrival"], "arrival"
    elif e["unit"] == "lattice sites":
        key, by = e["cluster"], "cluster id"
    else:
        key, by = np.sqrt((e["pos"].astype(float) ** 2).sum(1)), "distance"
    lum = (np.stack([v["red"], v["green"], v["blue"]], 1).astype(float) @ [0.299, 0.587, 0.114])[
        np.argsort(key, kind="stable")]
    drops = np.count_nonzero(np.diff(lum) < -1)
    check(drops == 0 and lum[0] < 40 and lum[-1] > 200, "%s: colours by %s: brightness falls %d times, first %.0f, "
          "last %.0f" % (name, by, drops, lum[0], lum[-1]))


def check_csv(path, e, name):
    with open(path) as f:
        head = f.readline().strip().split(",")
    n, dim = e["pos"].shape
    want = ["x", "y", "z"][:dim] + (["distance"] if e["q"] is not None and e["unit"] == "diameters" else []) + \
        (["radius"] if e["radius"] is not None else []) + (["arrival"] if e["arrival"] is not None else []) + \
        (["cluster"] if e["cluster"] is not None else [])
    if not check(head == want, "%s: header %s, want %s" % (name, head, want)):
        return
    t = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=np.float64)
    if not check(t.shape == (n, len(want)), "%s: %s values, want %s" % (name, t.shape, (n, len(want)))):
        return
    col = {h: t[:, i] for i, h in enumerate(head)}
    for a, c in enumerate("xyz"[:dim]):
        check(np.allclose(col[c], e["pos"][:, a], rtol=1e-15, atol=1e-12), "%s: column %s differs" % (name, c))
    if "distance" in col:
        check(np.allclose(col["distance"], np.sqrt((e["pos"] ** 2).sum(axis=1)), rtol=0, atol=1e-5),
              "%s: distance differs" % name)
    for k in ("radius", "arrival", "cluster"):
        if k in col:
            check(np.array_equal(col[k], e[k]), "%s: column %s differs" % (name, k))


def check_xyz(path, e, name):
    lines = open(path).read().split("\n")
    n, dim = e["pos"].shape
    props = "Properties=species:S:1:pos:R:3:radius:R:1" + (":cluster:I:1" if e["cluster"] is not None else "")
    unit = e["unit"] if " " not in e["unit"] else '"%s"' % e["unit"]
    check(lines[0] == str(n) and lines[1] == "%s units=%s dim=%d" % (props, unit, dim) and lines[-1] == "" and
          len(lines) == n + 3, "%s: count or comment line: %r" % (name, lines[:2]))
    rows = [ln.split() for ln in lines[2:2 + n]]
    if not check(all(r[0] == "X" and len(r) == (6 if e["cluster"] is not None else 5) for r in rows),
                 "%s: rows are not 'X x y z radius[ cluster]'" % name):
        return
    t = np.array([[float(v) for v in r[1:]] for r in rows]).reshape(n, -1)
    want = np.zeros((n, 3))
    want[:, :dim] = e["pos"]
    check(np.allclose(t[:, :3], want, rtol=1e-15, atol=1e-12), "%s: positions differ" % name)
    r = e["radius"] if e["radius"] is not None else np.full(n, 0.5)
    check(np.array_equal(t[:, 3], r), "%s: radii differ" % name)
    if e["cluster"] is not None:
        check(np.array_equal(t[:, 4], e["cluster"]), "%s: cluster ids differ" % name)


def export_all(path, kind, tag, extra=(), cluster=None):
    e = expected(path, kind, cluster)
    for fmt, chk in (("ply", check_ply), ("csv", check_csv), ("xyz", check_xyz)):
        out = "%s.%s" % (tag, fmt)
        rc, _, se = run([PDLA, "export", path, "-o", out] + list(extra))
        if not check(rc == 0, "%s %s: exit %d: %s" % (tag, fmt, rc, se.strip())):
            continue
        chk(out, e, "%s %s" % (tag, fmt))
        rc, _, se = run([PDLA, "export", path, "-o", "slab7-" + out, "--slab-rows", "7"] + list(extra))
        check(rc == 0 and open(out, "rb").read() == open("slab7-" + out, "rb").read(),
              "%s %s: --slab-rows 7 gives other bytes (%s)" % (tag, fmt, se.strip()))


def bad(args, needle, name):
    rc, so, se = run([PDLA, "export"] + args)
    check(rc == 2 and len(se.strip().splitlines()) == 1 and needle in se and not os.path.exists("bad.csv"),
          "%s: exit %d, %r (want 2 and %r)" % (name, rc, se.strip(), needle))


def synth_ensemble(path, m, n):
    """An ensemble file with the layout pdla writes, m clusters of n rows."""
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "pdla-ensemble"
        f.attrs["format_version"] = np.int32(1)
        f.create_group("ensemble").attrs["clusters"] = np.uint64(m)
        d = f.create_dataset("clusters/positions", shape=(m * n, 2), dtype="<i4", chunks=(65536, 2))
        for r in range(0, m * n, 1 << 20):
            k = min(1 << 20, m * n - r)
            i = np.arange(r, r + k, dtype=np.int64)
            d[r:r + k] = np.stack([(i % 20000) - 10000, (i // 7) % 30000 - 15000], axis=1).astype(np.int32)
        d.attrs["rows_per_cluster"] = np.uint64(n)
        d.attrs["diameter_units"] = np.int32(32)
        d.attrs["order"] = "arrival"


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-export-kinds.")
    os.chdir(tmp)
    try:
        if grow(["--dim", "3", "--target", "800", "--seed", "3", "--arrival", "--out", "dla", "-q"], "DLA"):
            export_all("dla/cluster.h5", "dla", "dla")
        # README: a DLA CSV is fixed point "with as many decimals as make x/D
        # exact (5 at D = 32)": 2 at D = 4, 7 at D = 128, x and y exactly
        # the positions / D (compared as decimal text, not as floats)
        for res, dec in ((4, 2), (128, 7)):
            tag = "dla%d" % res
            if grow(["--target", "300", "--resolution", str(res), "--seed", "2", "--out", tag, "-q"], tag):
                rc, _, se = run([PDLA, "export", tag + "/cluster.h5", "-o", tag + ".csv"])
                if check(rc == 0, "%s: export exit %d: %s" % (tag, rc, se.strip())):
                    pos = h5py.File(tag + "/cluster.h5", "r")["cluster/positions"][:]
                    rows = open(tag + ".csv").read().split("\n")[1:-1]
                    off = [r for r, p in zip(rows, pos) for f, x in zip(r.split(",")[:2], p)
                           if len(f.split(".")[1]) != dec or f != "%.*f" % (dec, x / res)]
                    check(len(rows) == len(pos) and not off, "%s: %d rows for %d particles, want %d decimals, x/D "
                          "exactly (first bad row %s)" % (tag, len(rows), len(pos), dec, off[:1]))
        if grow(["ensemble", "--clusters", "3", "--target", "400", "--seed", "4", "--keep-positions", "--arrival",
                 "--out", "e2", "-q"], "2D ensemble"):
            export_all("e2/ensemble.h5", "ensemble", "e2all")
            export_all("e2/ensemble.h5", "ensemble", "e2c1", ["--cluster", "1"], cluster=1)
            bad(["e2/ensemble.h5", "--cluster", "3", "-o", "bad.csv"], "has clusters 0..2", "--cluster past M")
        if grow(["ensemble", "--dim", "3", "--clusters", "2", "--target", "300", "--keep-positions", "--out", "e3",
                 "-q"], "3D ensemble"):
            export_all("e3/ensemble.h5", "ensemble", "e3all")
        if grow(["ensemble", "--clusters", "2", "--target", "100", "--out", "e0", "-q"], "ensemble, no positions"):
            bad(["e0/ensemble.h5", "-o", "bad.csv"], "without --keep-positions", "ensemble without positions")
        for dim, box in ((2, "48"), (3, "16")):
            tag = "dlca%d" % dim
            if grow(["--model", "dlca", "--dim", str(dim), "--box", box, "--count", "200", "--until-clusters", "6",
                     "--out", tag, "--quiet"], tag):
                export_all(tag + "/cluster.h5", "dlca", tag)
        if os.path.exists("dlca2/cluster.h5"):
            bad(["dlca2/cluster.h5", "--cluster", "0", "-o", "bad.csv"], "--cluster applies to ensemble files",
                "--cluster on DLCA")
        if grow(["--model", "dlca", "--dim", "4", "--box", "6", "--count", "40", "--until-clusters", "30",
                 "--out", "dlca4", "--quiet"], "4D DLCA"):
            bad(["dlca4/cluster.h5", "-o", "bad.csv"], "2D and 3D", "4D DLCA")
        for dim in (2, 3):
            tag = "event%d" % dim
            if grow(["--model", "event", "--dim", str(dim), "--particles", "300", "--max-stuck", "60", "--out", tag,
                     "--quiet"], tag):
                export_all(tag + "/cluster.h5", "event", tag)
        # Bounded memory (AddressSanitizer reserves terabytes of address space).
        if b"libasan" in subprocess.run(["ldd", PDLA], capture_output=True).stdout:
            print("skipping the memory bound under AddressSanitizer")
        else:
            synth_ensemble("big.h5", 8, 500000)
            for fmt in ("ply", "csv"):
                rc, _, se = run([PDLA, "export", "big.h5", "-o", "big." + fmt], limit_as=40000 * 1024)
                check(rc == 0, "4x10^6-row ensemble to %s in 40 MB: exit %d: %s" % (fmt, rc, se.strip()))
            if os.path.exists("big.csv"):
                with open("big.csv", "rb") as f:
                    f.seek(-200, 2)
                    last = f.read().split(b"\n")[-2].split(b",")
                check(last[-2:] == [b"499999", b"7"], "big.csv: last row %r, want arrival 499999, cluster 7" % last)
            if os.path.exists("big.ply"):
                check(os.path.getsize("big.ply") >= 4 * 10**6 * 23, "big.ply is too short")
    finally:
        os.chdir("/")
        shutil.rmtree(tmp, ignore_errors=True)


main()
print("%d checks, %d failed" % (checks, fails))
sys.exit(1 if fails else 0)
