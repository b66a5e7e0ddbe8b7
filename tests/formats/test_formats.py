#!/usr/bin/python3
"""test_formats.py - pdla's files in other programs.

  test_formats.py export PDLA FIXTURE
      `pdla export` to PLY, CSV and XYZ on two grown clusters (2D tree order,
      3D arrival order) and a synthetic file of 150000 rows (more than one
      slab): the PLY through a strict reader written here (header line by
      line, exact body length, little-endian records), the CSV by numpy with
      its header, the XYZ line by line; coordinates must equal the HDF5
      positions / D exactly, distances within the printed rounding, colours
      the ends of the inferno map at the seed / first arrival and at the
      farthest / last particle. A smaller --slab-rows gives the same bytes.
      Bad input: exit 2 and one line; a damaged chunk or a full file-size
      limit: exit 1 and one line; never an OUT or a temporary file left.
      Bounded memory (release builds): 10^7 rows export to PLY and CSV under
      ulimit -v 40 MB, and peak RSS differs from a 150000-row export by
      < 4 MiB.
  test_formats.py paraview PDLA FIXTURE PV_CHECK RENDER_SCRIPT
      the real ParaView (pvpython) on files pdla wrote: the .xdmf2 sidecar of
      each grown cluster opens with ParaView's own choice of reader, with N
      points and N cells, bounds and sampled points equal to positions / D,
      the "distance" array's range equal to numpy's, "arrival" equal to the
      row numbers; an exported PLY opens with N points and the same bounds;
      scripts/paraview-render draws a PNG that is not blank. A missing
      pvpython is a failure, not a skip.
  test_formats.py event PDLA PV_CHECK
      the event model's sidecars in the real ParaView: a 3D run stopped
      with 150 of 400 particles stuck writes cluster.xdmf2 (stuck, arrival
      order) and cluster-free.xdmf2 (free); each opens with ParaView's own
      reader with one point and cell per row, bounds and sampled points equal
      to /cluster/positions (/free/positions), "arrival" the row numbers,
      "radius", "arrival_time" and "species" the datasets' values.
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import glob
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile

import h5py
import numpy as np

checks = 0
fails = 0


def check(ok, what):
    global checks, fails
    checks += 1
    if not ok:
        fails += 1
        print("FAIL:", what, flush=True)
    return ok


def run(args, limit_as=None, limit_fsize=None, cwd=None, env_drop=()):
    """Runs args; returns (rc, stdout, stderr, peak RSS in KiB)."""
    def pre():
        if limit_as:
            resource.setrlimit(resource.RLIMIT_AS, (limit_as, limit_as))
        if limit_fsize:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_fsize, limit_fsize))
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=cwd,
                         preexec_fn=pre, stdin=subprocess.DEVNULL, env=env)
    out, err = p.communicate()
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return p.returncode, out.decode(errors="replace"), err.decode(errors="replace"), rss


def load(h5):
    with h5py.File(h5, "r") as f:
        d = f["cluster/positions"]
        pos = d[:].astype(np.int64)
        du = int(d.attrs["diameter_units"])
        order = d.attrs.get("order", b"")
        order = order.decode() if isinstance(order, bytes) else str(order)
    return pos, du, order == "arrival"


INFERNO_LO = (0, 0, 4)
INFERNO_HI = (252, 255, 164)
PLY_PROPS = ["property float x", "property float y", "property float z", "property float radius",
             "property uchar red", "property uchar green", "property uchar blue"]


def read_ply_strict(path):
    """A strict binary PLY reader: exactly the header pdla promises."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header\n")
    if end < 0:
        raise ValueError("no end_header")
    lines = data[:end].decode("ascii").split("\n")[:-1]
    if lines[0] != "ply" or lines[1] != "format binary_little_endian 1.0":
        raise ValueError("bad magic or format line: %r" % lines[:2])
    body_lines = [ln for ln in lines[2:] if not ln.startswith("comment ")]
    if len(body_lines) != 1 + len(PLY_PROPS) or not body_lines[0].startswith("element vertex "):
        raise ValueError("unexpected header lines: %r" % body_lines)
    n = int(body_lines[0].split()[2])
    if body_lines[1:] != PLY_PROPS:
        raise ValueError("unexpected properties: %r" % body_lines[1:])
    body = data[end + len(b"end_header\n"):]
    dt = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("radius", "<f4"),
                   ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    if len(body) != n * dt.itemsize:
        raise ValueError("body of %d bytes for %d vertices of %d" % (len(body), n, dt.itemsize))
    return np.frombuffer(body, dtype=dt)


def check_ply(path, pos, du, arrival, name):
    try:
        v = read_ply_strict(path)
    except (ValueError, UnicodeDecodeError, IndexError) as e:
        return check(False, "%s: strict PLY reader: %s" % (name, e))
    n, dim = pos.shape
    check(len(v) == n, "%s: %d vertices, want %d" % (name, len(v), n))
    if len(v) != n:
        return
    want = (pos / du).astype(np.float32)
    for a, c in enumerate("xyz"):
        w = want[:, a] if a < dim else np.zeros(n, np.float32)
        check(np.array_equal(v[c], w), "%s: %s differs from positions / D" % (name, c))
    check(np.all(v["radius"] == 0.5), "%s: radius not 0.5" % name)
    rgb = np.stack([v["red"], v["green"], v["blue"]], axis=1)
    r = np.sqrt((pos.astype(float) ** 2).sum(1))
    lo = 0 if arrival else int(np.argmin(r))
    hi = n - 1 if arrival else int(np.argmax(r))
    check(tuple(rgb[lo]) == INFERNO_LO, "%s: colour at the start %s, want %s" % (name, tuple(rgb[lo]), INFERNO_LO))
    check(tuple(rgb[hi]) == INFERNO_HI, "%s: colour at the end %s, want %s" % (name, tuple(rgb[hi]), INFERNO_HI))


def check_csv(path, pos, du, arrival, name):
    n, dim = pos.shape
    t = np.genfromtxt(path, delimiter=",", names=True)
    want = ["x", "y", "z"][:dim] + ["distance"] + (["arrival"] if arrival else [])
    check(list(t.dtype.names) == want, "%s: header %s, want %s" % (name, t.dtype.names, want))
    check(len(t) == n, "%s: %d rows, want %d" % (name, len(t), n))
    if list(t.dtype.names) != want or len(t) != n:
        return
    for a, c in enumerate("xyz"[:dim]):
        check(np.array_equal(t[c] * du, pos[:, a]), "%s: %s * D differs from the positions" % (name, c))
    r = np.sqrt((pos.astype(float) ** 2).sum(1)) / du
    dec = 10.0 ** -{32: 5, 16: 4, 8: 3, 4: 2}.get(du, 6)
    check(np.max(np.abs(t["distance"] - r)) <= 0.5 * dec + 1e-9, "%s: distance off" % name)
    if arrival:
        check(np.array_equal(t["arrival"], np.arange(n)), "%s: arrival is not 0..N-1" % name)


def check_xyz(path, pos, du, name):
    n, dim = pos.shape
    with open(path) as f:
        first = f.readline()
        second = f.readline()
        rest = f.read().splitlines()
    check(first.strip() == str(n), "%s: first line %r, want %d" % (name, first, n))
    check(second.startswith("Properties=species:S:1:pos:R:3:radius:R:1 "), "%s: comment %r" % (name, second))
    check(len(rest) == n, "%s: %d atom lines, want %d" % (name, len(rest), n))
    if len(rest) != n:
        return
    sp = [ln.split() for ln in rest]
    check(all(len(s) == 5 and s[0] == "X" and s[4] == "0.5" for s in sp), "%s: malformed atom lines" % name)
    xyz = np.array([[float(c) for c in s[1:4]] for s in sp])
    want = np.zeros((n, 3))
    want[:, :dim] = pos / du
    check(np.array_equal(xyz, want), "%s: positions differ from positions / D" % name)


def bad(pdla, args, name, want_rc=2, out=None):
    rc, so, se, _ = run([pdla, "export"] + args)
    lines = se.strip("\n").split("\n") if se else []
    check(rc == want_rc, "%s: exit status %d, want %d (%s)" % (name, rc, want_rc, se.strip()))
    check(len(lines) == 1 and lines[0].startswith("pdla export: "), "%s: stderr %r" % (name, se))
    check(so == "", "%s: wrote to stdout" % name)
    if out:
        check(not os.path.exists(out), "%s: left %s" % (name, out))
        check(not glob.glob(out + ".tmp*"), "%s: left a temporary file" % name)


def grow(pdla, tmp):
    for args in (["--dim", "2", "--target", "3000", "--seed", "3", "--out", "c2"],
                 ["--dim", "3", "--target", "2000", "--seed", "3", "--arrival", "--out", "c3"]):
        rc, _, se, _ = run([pdla, "-q"] + args, cwd=tmp)
        if not check(rc == 0, "pdla %s: %s" % (" ".join(args), se.strip())):
            sys.exit(1)


def is_asan(pdla):
    try:
        return b"libasan" in subprocess.run(["ldd", pdla], capture_output=True).stdout
    except OSError:
        return False


def test_export(pdla, fix, tmp):
    grow(pdla, tmp)
    os.chdir(tmp)
    check(run([fix, "synth", "big", "big.h5"])[0] == 0, "synth big")
    files = {"c2": "c2/cluster.h5", "c3": "c3/cluster.h5", "big": "big.h5"}
    for key, h5 in files.items():
        pos, du, arrival = load(h5)
        for fmt in ("ply", "csv", "xyz"):
            out = "%s.%s" % (key, fmt)
            rc, so, se, _ = run([pdla, "export", h5, "--format", fmt, "-o", out])
            if not check(rc == 0 and se == "" and so == "", "export %s: rc %d %s" % (out, rc, se.strip())):
                continue
            if fmt == "ply":
                check_ply(out, pos, du, arrival, out)
            elif fmt == "csv":
                check_csv(out, pos, du, arrival, out)
            else:
                check_xyz(out, pos, du, out)
    # Slab boundaries change nothing; the format comes from the name too.
    for fmt in ("ply", "csv"):
        rc, _, se, _ = run([pdla, "export", "big.h5", "-o", "slab." + fmt, "--slab-rows", "1000"])
        check(rc == 0 and open("slab." + fmt, "rb").read() == open("big." + fmt, "rb").read(),
              "--slab-rows 1000 gives other %s bytes (%s)" % (fmt, se.strip()))
    # --force replaces; without it an existing OUT stays as it was.
    keep = open("c2.csv", "rb").read()
    bad(pdla, ["c3/cluster.h5", "--format", "csv", "-o", "c2.csv"], "existing OUT")
    check(open("c2.csv", "rb").read() == keep, "export overwrote c2.csv without --force")
    rc, _, se, _ = run([pdla, "export", "c3/cluster.h5", "--format", "csv", "-o", "c2.csv", "--force"])
    check(rc == 0 and open("c2.csv", "rb").read() == open("c3.csv", "rb").read(), "--force: %s" % se.strip())

    # Bad input: exit 2, one line, no OUT.
    with open("text.h5", "w") as f:
        f.write("not HDF5\n")
    check(run([fix, "synth", "foreign", "foreign.h5"])[0] == 0, "synth foreign")
    check(run([fix, "synth", "wrongdims", "wrongdims.h5"])[0] == 0, "synth wrongdims")
    for args, name in ((["missing.h5", "--format", "ply", "-o", "n.ply"], "missing file"),
                       (["text.h5", "--format", "ply", "-o", "n.ply"], "text file"),
                       (["foreign.h5", "--format", "ply", "-o", "n.ply"], "foreign HDF5"),
                       (["wrongdims.h5", "--format", "ply", "-o", "n.ply"], "[N][4] positions"),
                       (["c2", "--format", "ply", "-o", "n.ply"], "directory"),
                       (["c2/cluster.h5", "--format", "vtk", "-o", "n.ply"], "unknown format"),
                       (["c2/cluster.h5", "-o", "n.txt"], "no format, unknown suffix"),
                       (["c2/cluster.h5", "--format", "ply"], "no -o"),
                       (["--format", "ply", "-o", "n.ply"], "no FILE"),
                       (["c2/cluster.h5", "c3/cluster.h5", "-o", "n.ply"], "two FILEs"),
                       (["c2/cluster.h5", "-o", "n.ply", "--bogus"], "unknown option"),
                       (["c2/cluster.h5", "--form", "ply", "-o", "n.ply"], "abbreviated --format"),
                       (["c2/cluster.h5", "-o", "n.ply", "--slab-rows", "0"], "bad --slab-rows"),
                       (["c2/cluster.h5", "-o", "/nonexistent-dir/n.ply"], "unwritable folder")):
        out = args[args.index("-o") + 1] if "-o" in args else None
        bad(pdla, args, name, out=out if out and not out.startswith("/nonexistent") else None)
    check(not os.path.exists("n.ply"), "a refused export left n.ply")

    # Runtime failures: exit 1, one line, nothing left behind.
    shutil.copy("big.h5", "corrupt.h5")
    with open("corrupt.h5", "r+b") as f:
        f.seek(300000)
        f.write(b"UUUUUUUU")
    bad(pdla, ["corrupt.h5", "--format", "csv", "-o", "dmg.csv"], "damaged chunk", 1, "dmg.csv")
    rc, so, se, _ = run([pdla, "export", "big.h5", "--format", "csv", "-o", "full.csv"],
                        limit_fsize=100000)
    check(rc == 1 and len(se.strip().split("\n")) == 1 and "cannot write full.csv" in se,
          "file size limit: exit %d, %r" % (rc, se))
    check(not os.path.exists("full.csv") and not glob.glob("full.csv.tmp*"),
          "a failed write left full.csv or its temporary file")

    # Bounded memory: 10^7 rows (80 MB of positions) in 40 MB of address
    # space, and peak RSS independent of N. Not under AddressSanitizer,
    # which reserves terabytes of address space and keeps freed memory.
    if is_asan(pdla):
        print("skipping the memory bound under AddressSanitizer")
        return
    check(run([fix, "synth", "huge", "huge.h5"])[0] == 0, "synth huge")
    _, _, _, rss_small = run([pdla, "export", "big.h5", "--format", "ply", "-o", "small-rss.ply"])
    n_huge = 10000000
    for fmt in ("ply", "csv"):
        out = "huge." + fmt
        rc, _, se, rss = run([pdla, "export", "huge.h5", "--format", fmt, "-o", out],
                             limit_as=40000 * 1024)
        check(rc == 0, "export of 10^7 rows to %s in 40 MB: %s" % (fmt, se.strip()))
        if fmt == "ply" and rc == 0:
            # RUSAGE_CHILDREN's peak is over all children so far: the biggest
            # one so far is this export or an earlier, smaller one.
            check(rss - rss_small < 4096, "peak RSS %d KiB for 10^7 rows, %d KiB for 1.5e5" % (rss, rss_small))
            size = os.path.getsize(out)
            hdr = open(out, "rb").read(1024)
            hlen = hdr.find(b"end_header\n") + len(b"end_header\n")
            check(size == hlen + 19 * n_huge, "huge.ply: %d bytes, want %d" % (size, hlen + 19 * n_huge))
        elif rc == 0:
            lines = 0
            with open(out, "rb") as f:
                for blk in iter(lambda: f.read(1 << 22), b""):
                    lines += blk.count(b"\n")
            check(lines == n_huge + 1, "huge.csv: %d lines, want %d" % (lines, n_huge + 1))
        if os.path.exists(out):
            os.unlink(out)
    os.unlink("huge.h5")


def pv_json(pv_check, path):
    # Without MALLOC_PERTURB_ (set by meson test): it makes pvpython's X and
    # GL libraries fail now and then, which says nothing about pdla.
    rc, so, se, _ = run(["pvpython", pv_check, os.path.abspath(path)], env_drop=("MALLOC_PERTURB_",))
    last = [ln for ln in so.splitlines() if ln.startswith("{")]
    if not check(rc == 0 and last, "pvpython on %s: exit %d: %s" % (path, rc, (se or so)[-500:])):
        return None
    return json.loads(last[-1])


def test_paraview(pdla, fix, pv_check, render, tmp):
    if not check(shutil.which("pvpython") is not None,
                 "pvpython not found: apt-get install paraview python3-paraview"):
        return
    grow(pdla, tmp)
    os.chdir(tmp)
    for key in ("c2", "c3"):
        pos, du, arrival = load(key + "/cluster.h5")
        n, dim = pos.shape
        side = key + "/cluster.xdmf2"
        if not check(os.path.exists(side), "pdla wrote no %s" % side):
            continue
        check("positions in diameters" in open(side, encoding="utf-8").read(),
              "%s: its comment does not say diameters" % side)
        j = pv_json(pv_check, side)
        if j is None:
            continue
        check(j["reader"] == "XdmfReader", "%s: reader %s" % (side, j["reader"]))
        check(j["points"] == n and j["cells"] == n, "%s: %d points %d cells, want %d" % (side, j["points"], j["cells"], n))
        p = np.zeros((n, 3))
        p[:, :dim] = pos / du
        want_b = [v for a in range(3) for v in (p[:, a].min(), p[:, a].max())]
        check(j["bounds"] == want_b, "%s: bounds %s, want %s" % (side, j["bounds"], want_b))
        rows = j["rows"]
        check(j["xyz"] == p[rows].tolist(), "%s: points at rows %s differ" % (side, rows))
        r = np.sqrt((pos.astype(float) ** 2).sum(1)) / du
        dist = j["arrays"].get("distance")
        if check(dist is not None, "%s: no distance array" % side):
            check(np.allclose(dist["range"], [r.min(), r.max()], rtol=1e-12, atol=0) and
                  np.allclose(dist["at"], r[rows], rtol=1e-12, atol=0),
                  "%s: distance range %s, want [%g, %g]" % (side, dist["range"], r.min(), r.max()))
        arr = j["arrays"].get("arrival")
        if arrival:
            if check(arr is not None, "%s: no arrival array" % side):
                check(arr["range"] == [0, n - 1] and arr["at"] == rows and arr["tuples"] == n,
                      "%s: arrival %s, want 0..%d" % (side, arr, n - 1))
        else:
            check(arr is None, "%s: an arrival array in a tree-order file" % side)
    # An exported PLY.
    rc, _, se, _ = run([pdla, "export", "c3/cluster.h5", "-o", "c3.ply"])
    if check(rc == 0, "export c3.ply: %s" % se.strip()):
        pos, du, _ = load("c3/cluster.h5")
        j = pv_json(pv_check, "c3.ply")
        if j is not None:
            want_b = [v for a in range(3) for v in ((pos[:, a] / du).min(), (pos[:, a] / du).max())]
            check(j["points"] == len(pos) and np.allclose(j["bounds"], want_b, rtol=0, atol=1e-6),
                  "c3.ply in ParaView: %d points, bounds %s" % (j["points"], j["bounds"]))
    # The picture script: a PNG of the asked size that is not blank.
    rc, so, se, _ = run([render, "c3/cluster.xdmf2", "-o", "c3.png", "--size", "160"])
    if check(rc == 0, "paraview-render: exit %d: %s" % (rc, se.strip()[:3000])):
        rc, so, se, _ = run([fix, "png", "c3.png", "160", "160"])
        check(rc == 0 and int(so.strip() or 0) > 500, "c3.png: %s %s" % (so.strip(), se.strip()))
    rc, so, se, _ = run([render, "c3/cluster.xdmf2", "-o", "c3.png", "--size", "160"])
    check(rc != 0 and "exists" in se, "paraview-render replaced c3.png without --force: %s" % se.strip())


def test_event_paraview(pdla, pv_check, tmp):
    if not check(shutil.which("pvpython") is not None,
                 "pvpython not found: apt-get install paraview python3-paraview"):
        return
    os.chdir(tmp)
    rc, _, se, _ = run([pdla, "--model", "event", "--dim", "3", "--particles", "400", "--packing", "0.05",
                        "--max-stuck", "150", "--seed", "2", "--species", "300:0.5:1,100:0.8:1", "--out", "ev"])
    if not check(rc == 0, "event run: %s" % se.strip()):
        return
    with h5py.File("ev/cluster.h5", "r") as f:
        groups = {"cluster": {k: f["cluster/" + k][()] for k in ("positions", "radii", "arrival_time", "species")},
                  "free": {k: f["free/" + k][()] for k in ("positions", "radii", "species")}}
    for side, g, arrays in (("ev/cluster.xdmf2", "cluster", ("radius", "arrival_time", "species")),
                            ("ev/cluster-free.xdmf2", "free", ("radius", "species"))):
        d = groups[g]
        pos = d["positions"]
        n = len(pos)
        check(n == (150 if g == "cluster" else 250), "%s: %d rows" % (g, n))
        if not check(os.path.exists(side), "pdla wrote no %s" % side):
            continue
        # Species of radius 0.5 and 0.8: the positions are in the model's
        # length unit, and the sidecar must not call them diameters.
        text = open(side, encoding="utf-8").read()
        check("positions in the file's length unit" in text and "diameters" not in text,
              "%s: its comment names the wrong unit" % side)
        j = pv_json(pv_check, side)
        if j is None:
            continue
        check(j["reader"] == "XdmfReader", "%s: reader %s" % (side, j["reader"]))
        check(j["points"] == n and j["cells"] == n, "%s: %d points %d cells, want %d" % (side, j["points"], j["cells"], n))
        want_b = [v for a in range(3) for v in (pos[:, a].min(), pos[:, a].max())]
        check(j["bounds"] == want_b, "%s: bounds %s, want %s" % (side, j["bounds"], want_b))
        rows = j["rows"]
        check(j["xyz"] == pos[rows].tolist(), "%s: points at rows %s differ" % (side, rows))
        src = {"radius": d["radii"], "arrival_time": d.get("arrival_time"), "species": d["species"]}
        for a in arrays:
            got = j["arrays"].get(a)
            if check(got is not None, "%s: no %s array" % (side, a)):
                want = np.asarray(src[a], dtype=float)
                check(got["tuples"] == n and got["range"] == [want.min(), want.max()] and
                      got["at"] == want[rows].tolist(), "%s: %s %s" % (side, a, got))
        arr = j["arrays"].get("arrival")
        if g == "cluster":
            if check(arr is not None, "%s: no arrival array" % side):
                check(arr["range"] == [0, n - 1] and arr["at"] == rows, "%s: arrival %s" % (side, arr))
        else:
            check(arr is None, "%s: an arrival array for free particles" % side)


def main():
    mode = sys.argv[1] if len(sys.argv) > 1 else ""
    if mode not in ("export", "paraview", "event") or \
            len(sys.argv) < (4 if mode in ("export", "event") else 6):
        sys.exit("usage: test_formats.py export PDLA FIXTURE | paraview PDLA FIXTURE PV_CHECK RENDER"
                 " | event PDLA PV_CHECK")
    pdla, fix = os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
    tmp = tempfile.mkdtemp(prefix="pdla-formats.")
    try:
        if mode == "event":
            test_event_paraview(pdla, fix, tmp)  # argv[3] is PV_CHECK here
        elif mode == "export":
            test_export(pdla, fix, tmp)
        else:
            test_paraview(pdla, fix, os.path.abspath(sys.argv[4]), os.path.abspath(sys.argv[5]), tmp)
    finally:
        os.chdir("/")
        shutil.rmtree(tmp, ignore_errors=True)
    print("%d checks, %d failed" % (checks, fails))
    sys.exit(1 if fails else 0)


main()
