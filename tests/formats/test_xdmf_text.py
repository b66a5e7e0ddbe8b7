#!/usr/bin/python3
"""test_xdmf_text.py MODE PDLA XDMF_TOOL [FAULTSHIM] - the XDMF 2 sidecars read without
ParaView, by an evaluator here that follows ParaView 5.11's XDMF 2 reader
(xdmf2::XdmfDataItem::UpdateFunction): HDF and XML items, HyperSlab items
(start, stride, count) over any item, Function items ($k the k-th child
item, arithmetic element by element, sqrt, ";" concatenating along the
first axis, WHERE(test) the indices where the test holds).

That reader puts a Function argument of one element into the expression as
a number, printed with 6 significant digits: a Function whose arguments are
all numbers is a scalar expression it cannot evaluate ("XdmfExpr : syntax
error": the array comes out empty), and a number of 1e+06 or more crashes
its parser. So no Function item may have an argument of one element; every
grid's points and arrays must equal what the HDF5 file holds: positions / D,
"distance" |position| / D, "arrival" 0..n-1, "cluster" the cluster's index,
the other arrays their datasets.

Sidecars checked: one-point grids (issue: they lost every computed array in
ParaView) from `pdla --target 1` (2D --arrival, 3D), `pdla ensemble
--target 1 --keep-positions` (2D --arrival, 3D) and an event run stopped at
one stuck particle; the same with more points; and xdmf_tool's sidecars of
one-point files written here with points off the origin (negative, and of
3x10^6 units).

stale: DLCA 2D and 4D, event, DLA runs one after another into one directory
with --force: after each, the *.xdmf2 there are exactly the run's own (a
4D DLCA run writes none; only the event model writes cluster-free.xdmf2)
and each reads cleanly against the new cluster.h5; an ensemble without
positions leaves no ensemble.xdmf2; xdmf_write_points with no points
removes an older sidecar.

memory: xdmf_write_ensemble (xdmf_tool) of 10^4 clusters of 100 points (26
MB of text) peaks under 4 MiB of RSS above one of 10 clusters, and the file
holds every cluster's grid and its end.

series (with tests/reliab's faultshim): a DLCA run with --snapshot-every
writes its temporal sidecar as the others: cluster.xdmf2.tmp.<pid>
fsync'ed once; a failing fsync gives exit 1 and one line, no sidecar and
no temporary left.
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import os
import re
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

TALLY = Tally()
check = TALLY.check


def run(args, cwd=None):
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, cwd=cwd)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


class Reader:
    """Evaluates the DataItems of one sidecar; problems go to self.probs."""

    def __init__(self, path):
        self.dir = os.path.dirname(path)
        self.root = ET.parse(path).getroot()
        self.probs = []

    def dims(self, e):
        return tuple(int(x) for x in e.get("Dimensions").split())

    def item(self, e):
        kind = e.get("ItemType", "Uniform")
        d = self.dims(e)
        if kind == "Uniform":
            if e.get("Format", "XML") == "HDF":
                fn, ds = e.text.strip().split(":", 1)
                with h5py.File(os.path.join(self.dir, fn), "r") as f:
                    if ds not in f:
                        self.probs.append("%s: no such dataset" % e.text.strip())
                        return np.zeros(d)
                    v = f[ds][()]
                if tuple(v.shape) != d:
                    self.probs.append("%s: Dimensions %s, dataset %s" % (e.text.strip(), d, v.shape))
                    return np.zeros(d)
            else:
                v = np.array(e.text.split(), dtype=np.float64)
            if e.get("NumberType", "Float") == "Float":
                v = np.asarray(v, dtype=np.float64)
            return np.reshape(v, d)
        kids = [c for c in e if c.tag == "DataItem"]
        if kind == "HyperSlab":
            sel = np.array(kids[0].text.split(), dtype=np.int64).reshape(3, -1)
            src = self.item(kids[1])
            idx = tuple(slice(a, a + s * c, s) for a, s, c in zip(*sel))
            v = src[idx]
            if v.size != int(np.prod(d)):
                self.probs.append("HyperSlab %s of %s: %d values for %s" % (sel.tolist(), src.shape, v.size, d))
            return np.reshape(v, d)
        if kind == "Function":
            return self.function(e, kids, d)
        self.probs.append("ItemType %s" % kind)
        return np.zeros(d)

    def function(self, e, kids, d):
        args = [np.ravel(self.item(k)) for k in kids]
        fn = e.get("Function")
        for k, a in enumerate(args):
            if ("$%d" % k) in fn and a.size == 1:
                self.probs.append("Function %s: $%d has one element (the reader makes it a number)" % (fn, k))
        if ";" in fn:
            v = np.concatenate([self.expr(part, args) for part in fn.split(";")])
        else:
            v = np.ravel(self.expr(fn, args))
        if v.size != int(np.prod(d)):
            self.probs.append("Function %s: %d values for Dimensions %s" % (fn, v.size, d))
            return np.zeros(d)
        return np.reshape(v, d)

    def expr(self, fn, args):
        py = re.sub(r"\$(\d)", r"a[\1]", fn)
        where = lambda m: np.nonzero(np.ravel(m))[0]
        return np.asarray(eval(py, {"__builtins__": {}}, {"a": args, "sqrt": np.sqrt, "WHERE": where}),
                          dtype=np.float64)

    def grids(self):
        """{name: (n, geometry [n][dim], {attribute: values})} of the Uniform grids."""
        out = {}
        for g in self.root.iter("Grid"):
            if g.get("GridType", "Uniform") != "Uniform":
                continue
            n = int(g.find("Topology").get("NumberOfElements"))
            geo = self.item(g.find("Geometry").find("DataItem"))
            attrs = {a.get("Name"): np.ravel(self.item(a.find("DataItem"))) for a in g.findall("Attribute")}
            out[g.get("Name")] = (n, geo, attrs)
        return out


def check_grid(what, grid, pos, upd, distance, row_index, cluster=None, arrays=()):
    """grid from Reader.grids against the rows pos (integer units) of the file."""
    n, geo, attrs = grid
    pos = np.asarray(pos, dtype=np.float64)
    check(n == len(pos), "%s: %d points, want %d" % (what, n, len(pos)))
    check(geo.shape == pos.shape and np.allclose(geo, pos / upd, rtol=1e-15, atol=0),
          "%s: geometry %s, want %s" % (what, geo.tolist()[:3], (pos / upd).tolist()[:3]))
    want = {}
    if distance:
        want["distance"] = np.sqrt(np.sum(pos * pos, axis=1)) / upd
    if row_index:
        want[row_index] = np.arange(len(pos), dtype=np.float64)
    if cluster is not None:
        want["cluster"] = np.full(len(pos), float(cluster))
    for name, vals in arrays:
        want[name] = np.asarray(vals, dtype=np.float64)
    check(sorted(attrs) == sorted(want), "%s: arrays %s, want %s" % (what, sorted(attrs), sorted(want)))
    for name, w in want.items():
        got = attrs.get(name)
        if got is None:
            continue
        check(got.shape == w.shape and np.allclose(got, w, rtol=1e-12, atol=0),
              "%s: %s = %s, want %s" % (what, name, got.tolist()[:4], w.tolist()[:4]))


def read_sidecar(path):
    if not check(os.path.isfile(path), "%s: no sidecar" % path):
        return None
    r = Reader(path)
    try:
        grids = r.grids()
    except Exception as ex:  # a sidecar this evaluator cannot follow is a failure, not a crash
        r.probs.append("cannot evaluate: %r" % ex)
        grids = None
    for p in r.probs:
        check(False, "%s: %s" % (path, p))
    return grids


def dla_cases(pdla, tmp):
    for dim, n, arrival in ((2, 1, True), (3, 1, False), (2, 20, True)):
        out = os.path.join(tmp, "dla%d_%d" % (dim, n))
        rc, so, se = run([pdla, "--dim", str(dim), "--target", str(n), "--out", out, "-q"] +
                         (["--arrival"] if arrival else []))
        if not check(rc == 0, "pdla --dim %d --target %d: exit %d: %s" % (dim, n, rc, se)):
            continue
        with h5py.File(os.path.join(out, "cluster.h5"), "r") as f:
            pos = f["cluster/positions"][()]
        grids = read_sidecar(os.path.join(out, "cluster.xdmf2"))
        if grids is not None and check(list(grids) == ["particles"], "%s: grids %s" % (out, list(grids))):
            check_grid("DLA %dD N=%d" % (dim, n), grids["particles"], pos, 32, True, "arrival" if arrival else None)


def ensemble_cases(pdla, tmp):
    for dim, m, n, arrival in ((2, 3, 1, True), (3, 2, 1, False), (2, 2, 20, True)):
        out = os.path.join(tmp, "ens%d_%d" % (dim, n))
        rc, so, se = run([pdla, "ensemble", "--dim", str(dim), "--clusters", str(m), "--target", str(n),
                          "--keep-positions", "--out", out, "-q"] + (["--arrival"] if arrival else []))
        if not check(rc == 0, "pdla ensemble --dim %d --target %d: exit %d: %s" % (dim, n, rc, se)):
            continue
        with h5py.File(os.path.join(out, "ensemble.h5"), "r") as f:
            pos = f["clusters/positions"][()]
        grids = read_sidecar(os.path.join(out, "ensemble.xdmf2"))
        if grids is None or not check(len(grids) == m, "%s: %d grids, want %d" % (out, len(grids), m)):
            continue
        for i in range(m):
            check_grid("ensemble %dD N=%d cluster %d" % (dim, n, i), grids["cluster %d" % i],
                       pos[i * n:(i + 1) * n], 32, True, "arrival" if arrival else None, cluster=i)


def event_case(pdla, tmp):
    out = os.path.join(tmp, "ev1")
    rc, so, se = run([pdla, "--model", "event", "--dim", "2", "--particles", "50", "--packing", "0.05",
                      "--seed", "3", "--max-stuck", "1", "--out", out])
    if not check(rc == 0, "event --max-stuck 1: exit %d: %s" % (rc, se)):
        return
    with h5py.File(os.path.join(out, "cluster.h5"), "r") as f:
        c = {k: f["cluster/" + k][()] for k in ("positions", "radii", "arrival_time", "species", "parent")}
        fr = {k: f["free/" + k][()] for k in ("positions", "radii", "species")}
    check(len(c["positions"]) == 1, "event --max-stuck 1: %d stuck" % len(c["positions"]))
    grids = read_sidecar(os.path.join(out, "cluster.xdmf2"))
    if grids is not None:
        check_grid("event stuck", grids["particles"], c["positions"], 1, False, "arrival",
                   arrays=[("radius", c["radii"]), ("arrival_time", c["arrival_time"]),
                           ("species", c["species"]), ("parent", c["parent"])])
    grids = read_sidecar(os.path.join(out, "cluster-free.xdmf2"))
    if grids is not None:
        check_grid("event free", grids["particles"], fr["positions"], 1, False, None,
                   arrays=[("radius", fr["radii"]), ("species", fr["species"])])


def off_origin_cases(tool, tmp):
    """One point away from the origin: xdmf_write_points and
    xdmf_write_ensemble on files written here."""
    h5 = os.path.join(tmp, "one.h5")
    rows2 = np.array([[64, -96]], dtype=np.int64)
    rows3 = np.array([[-5, 7, 3000001]], dtype=np.int64)
    ens2 = np.array([[64, -96], [-3, 2000000], [7, 0]], dtype=np.int64)
    ens3 = np.array([[1, -2, 3], [-3000000, 5, 9]], dtype=np.int32)
    with h5py.File(h5, "w") as f:
        f["p2"], f["p3"], f["e2"], f["e3"] = rows2, rows3, ens2, ens3
    for name, rows, upd in (("p2", rows2, 32), ("p3", rows3, 1)):
        xmf = os.path.join(tmp, name + ".xdmf2")
        rc, so, se = run([tool, "points", xmf, h5, "/" + name, "1", str(rows.shape[1]), str(upd), "1", "arrival"])
        if check(rc == 0, "xdmf_tool points %s: exit %d: %s" % (name, rc, se)):
            grids = read_sidecar(xmf)
            if grids is not None:
                check_grid("points %s" % name, grids["particles"], rows, upd, True, "arrival")
    for name, rows, upd, arrival in (("e2", ens2, 32, 1), ("e3", ens3, 4, 0)):
        xmf = os.path.join(tmp, name + ".xdmf2")
        rc, so, se = run([tool, "ensemble", xmf, h5, "/" + name, str(len(rows)), "1", str(rows.shape[1]),
                          str(upd), str(arrival)])
        if not check(rc == 0, "xdmf_tool ensemble %s: exit %d: %s" % (name, rc, se)):
            continue
        grids = read_sidecar(xmf)
        if grids is None:
            continue
        for i in range(len(rows)):
            check_grid("ensemble %s cluster %d" % (name, i), grids["cluster %d" % i], rows[i:i + 1], upd, True,
                       "arrival" if arrival else None, cluster=i)


def stale_cases(pdla, tool, tmp):
    """Runs of every model into one directory (--force): after each, the
    sidecars there are exactly the ones that run writes, and each describes
    the new file (its datasets there, with its Dimensions)."""
    d = os.path.join(tmp, "dx")
    dlca2 = ["--model", "dlca", "--dim", "2", "--box", "32", "--fill", "0.05", "--seed", "1", "-q"]
    dlca4 = ["--model", "dlca", "--dim", "4", "--box", "8", "--fill", "0.05", "--seed", "1", "-q"]
    event = ["--model", "event", "--dim", "2", "--particles", "50", "--packing", "0.05", "--seed", "3",
             "--max-stuck", "5", "--quiet"]
    dla = ["--target", "10", "-q"]
    ens_pos = ["ensemble", "--clusters", "2", "--target", "10", "--keep-positions", "-q"]
    ens = ["ensemble", "--clusters", "2", "--target", "10", "-q"]
    both, main = {"cluster.xdmf2", "cluster-free.xdmf2"}, {"cluster.xdmf2"}
    steps = [("DLCA 2D", dlca2, main), ("DLCA 4D", dlca4, set()), ("event", event, both), ("DLA", dla, main),
             ("event", event, both), ("DLCA 2D", dlca2, main), ("event", event, both), ("DLCA 4D", dlca4, set())]
    for what, args, want in steps:
        rc, so, se = run([pdla] + args + ["--out", d, "--force"])
        if not check(rc == 0, "%s --force: exit %d: %s" % (what, rc, se)):
            continue
        got = {n for n in os.listdir(d) if n.endswith(".xdmf2")}
        check(got == want, "%s --force: sidecars %s, want %s" % (what, sorted(got), sorted(want)))
        for n in sorted(got):
            read_sidecar(os.path.join(d, n))
    e = os.path.join(tmp, "ex")
    for what, args, want in (("with positions", ens_pos, {"ensemble.xdmf2"}), ("without", ens, set())):
        rc, so, se = run([pdla] + args + ["--out", e, "--force"])
        if check(rc == 0, "ensemble %s --force: exit %d: %s" % (what, rc, se)):
            got = {n for n in os.listdir(e) if n.endswith(".xdmf2")}
            check(got == want, "ensemble %s --force: sidecars %s, want %s" % (what, sorted(got), sorted(want)))
    # xdmf_write_points of no points: none written, an older one removed
    h5 = os.path.join(tmp, "none.h5")
    with h5py.File(h5, "w") as f:
        f["p"] = np.zeros((0, 2), dtype=np.int64)
    xmf = os.path.join(tmp, "none.xdmf2")
    open(xmf, "w").write("an older sidecar\n")
    rc, so, se = run([tool, "points", xmf, h5, "/p", "0", "2", "1", "1", "-"])
    check(rc == 0 and not os.path.exists(xmf), "xdmf_write_points, n = 0: exit %d, older sidecar %s" %
          (rc, "left" if os.path.exists(xmf) else "removed"))


def rss_of(tool, xmf, m):
    """xdmf_tool's peak RSS (KiB) writing an ensemble sidecar of m clusters
    of 100 3D points with arrival (about 2.6 kB of text a cluster)."""
    rc, so, se = run([tool, "ensemble", xmf, "e.h5", "/clusters/positions", str(m), "100", "3", "32", "1"])
    if not check(rc == 0 and so.startswith("peak_rss_kib "), "xdmf_tool ensemble M=%d: exit %d: %s" % (m, rc, se)):
        return None
    return int(so.split()[1])


def memory_case(tool, tmp):
    """The ensemble sidecar is streamed to its file: writing one of 10^4
    clusters (26 MB of text) takes no more memory than one of 10 (the whole
    text in memory took its size and more)."""
    xmf = os.path.join(tmp, "m.xdmf2")
    small = rss_of(tool, xmf, 10)
    m = 10000
    big = rss_of(tool, xmf, m)
    if small is None or big is None:
        return
    check(big - small < 4096, "ensemble sidecar of %d clusters: peak RSS %d KiB, %d KiB for 10 (want < 4 MiB more)" %
          (m, big, small))
    grids, last = 0, None
    with open(xmf) as f:
        for line in f:
            if line.startswith('   <Grid Name="cluster '):
                grids += 1
            last = line
    slab = '<DataItem Dimensions="3 2" Format="XML">%d 0 1 1 100 3</DataItem>' % ((m - 1) * 100)
    check(grids == m and last == "</Xdmf>\n" and slab in open(xmf).read(),
          "ensemble sidecar of %d clusters: %d grids, last line %r, last cluster's rows %s" %
          (m, grids, last, "found" if slab in open(xmf).read() else "missing"))


def series_case(pdla, shim, tmp):
    """The DLCA snapshot series' sidecar goes the way of the others
    (xdmf_write_text): its temporary is this process's own
    (cluster.xdmf2.tmp.<pid>) and fsync'ed, once per run; an fsync that
    fails is one line and exit 1, with no sidecar (the older one removed,
    it would describe another file) and no temporary left."""
    from reliab_util import shim_preload
    d = os.path.join(tmp, "series")
    args = ["--model", "dlca", "--dim", "2", "--box", "40x30", "--fill", "0.05", "--until-clusters", "3",
            "--snapshot-every", "15", "--seed", "3", "--out", d, "--force", "-q"]
    count = os.path.join(tmp, "fsyncs")
    env = dict(os.environ, LD_PRELOAD=shim_preload(pdla, shim), FAULT_OP="fsync",
               FAULT_PATH="cluster.xdmf2.tmp.", FAULT_COUNT=count)
    p = subprocess.run([pdla] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    if not check(p.returncode == 0, "series run: exit %d: %s" % (p.returncode, p.stderr.decode(errors="replace"))):
        return
    n = int(open(count).read().split()[0]) if os.path.exists(count) else -1
    check(n == 1, "series sidecar: %d fsyncs of cluster.xdmf2.tmp.<pid>, want 1" % n)
    grids = read_sidecar(os.path.join(d, "cluster.xdmf2"))
    check(grids is not None and len(grids) >= 2, "series sidecar: %s grids" % (len(grids) if grids else None))
    env = dict(env, FAULT_AT="1", FAULT_ERR="EIO")
    del env["FAULT_COUNT"]
    p = subprocess.run([pdla] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    err = p.stderr.decode(errors="replace").strip()
    check(p.returncode == 1 and len(err.splitlines()) == 1 and "cluster.xdmf2" in err,
          "series sidecar, fsync fails: exit %d, stderr %r (want 1 and one line naming it)" % (p.returncode, err))
    left = sorted(x for x in os.listdir(d) if x.startswith("cluster.xdmf2"))
    check(left == [], "series sidecar, fsync fails: left %s" % left)


def main():
    modes = ("text", "stale", "memory", "series")
    if len(sys.argv) not in (4, 5) or sys.argv[1] not in modes or (sys.argv[1] == "series") != (len(sys.argv) == 5):
        sys.exit("usage: test_xdmf_text.py text|stale|memory PDLA XDMF_TOOL, or series PDLA XDMF_TOOL FAULTSHIM")
    pdla, tool = (os.path.abspath(a) for a in sys.argv[2:4])
    with tempfile.TemporaryDirectory() as tmp:
        if sys.argv[1] == "text":
            dla_cases(pdla, tmp)
            ensemble_cases(pdla, tmp)
            event_case(pdla, tmp)
            off_origin_cases(tool, tmp)
        elif sys.argv[1] == "stale":
            stale_cases(pdla, tool, tmp)
        elif sys.argv[1] == "memory":
            memory_case(tool, tmp)
        else:
            series_case(pdla, os.path.abspath(sys.argv[4]), tmp)
    TALLY.done()


if __name__ == "__main__":
    main()
