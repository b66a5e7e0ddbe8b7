#!/usr/bin/python3
"""test_ens_files.py - the files of `pdla ensemble --keep-positions` in other programs.

Usage: test_ens_files.py PDLA PV_SCRIPT

 - /clusters/positions is chunked by cluster (chunk = N rows for N <= 65536),
   shuffle + deflate at the --compress level (default 4; 0: no deflate), and
   cluster i's rows, read alone by h5py and by h5dump (start/count), are
   exactly /cluster/positions of `pdla --seed S+i` with the same options, for
   a few i, in 2D (arrival order) and 3D (tree order);
 - DIR/ensemble.xdmf2 opens in the real ParaView (pvpython, OpenDataFile):
   one block per cluster, N points each, bounds = numpy's min/max of the
   cluster's rows / D, "cluster" = i on every point, "arrival" 0..N-1,
   "distance" up to numpy's largest |x| / D;
 - the sidecar is rewritten, identically, by --resume; --force without
   --keep-positions removes the stale one; a bad --compress is refused;
 - hostile files: an ensemble whose /statistics/slope_N (for `pdla
   analyze`) or /clusters/positions (for `pdla export`) declares 2^40 rows
   that are not stored is refused with one line naming the dataset, exit 2,
   at once (no allocation or loop for the declared rows);
 - hostile journals: 2 MiB of forged record heads cost a resume a few
   seconds at most; a resume scanning 4 MiB of heads that look like this
   ensemble's own (each read whole: 4.2 GB, seconds of CPU) ends by SIGTERM within
   2 s of it, with one line, the journal byte for byte as it was.
A missing ParaView, h5py or h5dump is a failure, not a skip.
"""
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

PDLA = os.path.abspath(sys.argv[1])
PV = os.path.abspath(sys.argv[2])
fails = 0
checks = 0


def fnv1a(data, h=0xcbf29ce484222325):
    """The journal's checksum (src/ens/ens_journal.c)."""
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def check(ok, what):
    global fails, checks
    checks += 1
    if not ok:
        fails += 1
        print("FAIL:", what, file=sys.stderr)
    return ok


def run(args, env_drop=()):
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    p = subprocess.run(args, capture_output=True, text=True, env=env)
    return p.returncode, p.stdout, p.stderr


def grow(args, what):
    rc, _, se = run([PDLA] + args + ["-q"])
    return check(rc == 0, "%s: exit %d: %s" % (what, rc, se.strip()))


def pv_blocks(path):
    # MALLOC_PERTURB_ (set by meson test) upsets pvpython's X and GL libraries.
    rc, so, se = run(["pvpython", "--force-offscreen-rendering", PV, path], env_drop=("MALLOC_PERTURB_",))
    lines = [l for l in so.splitlines() if l.startswith("{")]
    if not check(rc == 0 and lines, "pvpython %s: exit %d: %s" % (path, rc, (se or so)[-400:])):
        return None
    return json.loads(lines[-1])


def h5dump_rows(path, row0, n, dim):
    """Rows [row0, row0 + n) of /clusters/positions as h5dump reads them
    (a hyperslab, written as little-endian binary)."""
    out = "dump-%d.bin" % row0
    rc, so, se = run(["h5dump", "-d", "/clusters/positions", "-s", "%d,0" % row0, "-c", "%d,%d" % (n, dim),
                      "-b", "LE", "-o", out, path])
    if not check(rc == 0 and os.path.exists(out), "h5dump: exit %d: %s" % (rc, se.strip())):
        return None
    return np.fromfile(out, dtype="<i4").reshape(-1, dim)


def check_ensemble(d, m, n, dim, seed, extra, level, serial):
    path = os.path.join(d, "ensemble.h5")
    with h5py.File(path, "r") as f:
        ds = f["/clusters/positions"]
        check(ds.shape == (m * n, dim), "%s: positions shape %s" % (d, ds.shape))
        check(ds.chunks == (n, dim), "%s: chunks %s, want one cluster (%d, %d)" % (d, ds.chunks, n, dim))
        check(ds.fletcher32 and ds.shuffle == (level > 0), "%s: filters %s" % (d, ds._filters))
        check(ds.compression == ("gzip" if level else None) and (not level or ds.compression_opts == level),
              "%s: compression %s %s, want level %d" % (d, ds.compression, ds.compression_opts, level))
        check(int(ds.attrs["rows_per_cluster"]) == n and int(ds.attrs["deflate_level"]) == level,
              "%s: rows_per_cluster / deflate_level attributes" % d)
        units = int(ds.attrs["diameter_units"])
        rows = [ds[i * n:(i + 1) * n] for i in range(m)]  # one cluster at a time
    for i in serial:
        c = "c%s%d" % (d, i)
        if grow(["--dim", str(dim), "--target", str(n), "--seed", str(seed + i), "--out", c] + extra,
                "pdla --seed %d" % (seed + i)):
            with h5py.File(os.path.join(c, "cluster.h5"), "r") as f:
                want = f["/cluster/positions"][...]
            check(np.array_equal(rows[i], want), "%s: cluster %d differs from pdla --seed %d" % (d, i, seed + i))
        dumped = h5dump_rows(path, i * n, n, dim)
        check(dumped is not None and np.array_equal(dumped, rows[i]),
              "%s: h5dump of cluster %d's rows differs from h5py's" % (d, i))
    pv = pv_blocks(os.path.join(d, "ensemble.xdmf2"))
    if pv is None:
        return
    check(pv["reader"] and pv["multiblock"] and len(pv["blocks"]) == m,
          "%s: ParaView: reader %s, %d blocks, want %d" % (d, pv["reader"], len(pv["blocks"]), m))
    for i, b in enumerate(pv["blocks"][:m]):
        x = rows[i] / units
        lo, hi = x.min(axis=0), x.max(axis=0)
        want = [v for a in range(3) for v in ((lo[a], hi[a]) if a < dim else (0.0, 0.0))]
        check(b["points"] == n and b["cells"] == n, "%s block %d: %d points, %d cells" % (d, i, b["points"], b["cells"]))
        check(np.allclose(b["bounds"], want, rtol=0, atol=1e-9), "%s block %d: bounds %s, want %s" % (d, i, b["bounds"], want))
        a = b["arrays"]
        check(a.get("cluster", {}).get("range") == [i, i], "%s block %d: cluster %s" % (d, i, a.get("cluster")))
        rmax = np.sqrt((x.astype(np.float64) ** 2).sum(axis=1)).max()
        dr = a.get("distance", {}).get("range", [None, None])
        check(dr[0] == 0 and abs(dr[1] - rmax) < 1e-9, "%s block %d: distance %s, want [0, %g]" % (d, i, dr, rmax))
        if "--arrival" in extra:
            check(a.get("arrival", {}).get("range") == [0, n - 1] and a["arrival"]["last"] == n - 1,
                  "%s block %d: arrival %s" % (d, i, a.get("arrival")))
        else:
            check("arrival" not in a, "%s block %d: an arrival array without --arrival" % (d, i))


def hostile(src):
    for name, cmd, ds in (("analyze", ["analyze"], "/statistics/slope_N"),
                          ("export", ["export", "-o", "h.csv"], "/clusters/positions")):
        path = "hostile-%s.h5" % name
        shutil.copy(src, path)
        with h5py.File(path, "r+") as f:
            old = f[ds]
            attrs = dict(old.attrs)
            del f[ds]
            rows = 2 ** 40 if ds.endswith("slope_N") else 3 * 2 ** 38
            shape = (rows,) if old.ndim == 1 else (rows, old.shape[1])
            d = f.create_dataset(ds, shape=shape, dtype=old.dtype, chunks=(1024,) + shape[1:])
            for k, v in attrs.items():
                d.attrs[k] = v
            if "rows_per_cluster" in attrs:
                d.attrs["rows_per_cluster"] = np.uint64(2 ** 38)
        try:
            p = subprocess.run([PDLA, cmd[0], path] + cmd[1:], capture_output=True, text=True, timeout=60)
            rc, se = p.returncode, p.stderr
        except subprocess.TimeoutExpired:
            rc, se = -1, "timed out"
        check(rc == 2 and len(se.strip().splitlines()) == 1 and ds in se and "declares" in se,
              "hostile %s (%s of 2^40 rows, none stored): exit %d, %r" % (name, ds, rc, se.strip()))


def rchar(pid):
    """Bytes process pid has read (/proc/PID/io), or None."""
    try:
        with open("/proc/%d/io" % pid) as f:
            return next(int(l.split()[1]) for l in f if l.startswith("rchar:"))
    except (OSError, StopIteration, ValueError):
        return None


def sigterm_in_scan(journal):
    """(session 27) `journal` is record 0 of "dos" and then 4 MiB of copies
    of record 1's head: this ensemble's own fingerprint and fixed fields,
    each read whole to its declared length (160 kB) and hashed before its
    checksum fails: 4.2 GB read, 4.9-6.0 s of CPU in the release build
    (runs/readme-claims/journal-scan.txt, the scan run to its end). A SIGTERM was
    seen only when the scan ended, and the resume then cut the heads as a
    torn tail. SIGTERM once the scan has read 20 MB must end the process by
    the signal within 2 s, with the line saying so, and leave the journal as
    it was byte for byte. Why 2 s: the scan polls the flag at every
    candidate, and one candidate is one record's read and hash (160 kB: well
    under a millisecond here), so the rest is the exit; 2 s leave room for a
    loaded machine and the sanitizer builds, and are far below the scan."""
    with open("dos/clusters.journal", "wb") as fh:
        fh.write(journal)
    p = subprocess.Popen([PDLA, "ensemble", "--resume", "dos", "-q"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while p.poll() is None and time.time() < t0 + 60:
        got = rchar(p.pid)
        if (got is None and time.time() > t0 + 1) or (got or 0) > 20e6:
            break
        time.sleep(0.01)
    scanning = p.poll() is None
    p.send_signal(signal.SIGTERM)
    t1 = time.time()
    try:
        p.wait(timeout=2)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
    dt, se = time.time() - t1, p.stderr.read().strip()
    # The time README quotes (runs/readme-claims/ensemble-files.txt).
    print("SIGTERM after %.2f s of scan: the process ended %.3f s later (%s)" %
          (t1 - t0, dt, "by the signal" if p.returncode == -signal.SIGTERM else "exit %s" % p.returncode), flush=True)
    check(scanning and p.returncode == -signal.SIGTERM and dt < 2 and "stopped by signal while reading" in se and
          len(se.splitlines()) == 1,
          "SIGTERM in the scan of 4 MiB of this ensemble's heads: running %s, exit %s after %.2f s (want by "
          "SIGTERM within 2 s, one line): %r" % (scanning, p.returncode, dt, se[:300]))
    with open("dos/clusters.journal", "rb") as fh:
        check(fh.read() == journal, "the journal changed under a resume stopped in its scan")


def main():
    for tool in ("pvpython", "h5dump"):
        if not check(shutil.which(tool) is not None, "%s not found (apt-get install paraview python3-paraview hdf5-tools)" % tool):
            return
    tmp = tempfile.mkdtemp(prefix="pdla-ens-files.")
    os.chdir(tmp)
    try:
        # 2D, arrival order, the default level.
        if grow(["ensemble", "--clusters", "4", "--target", "3000", "--seed", "21", "--keep-positions", "--arrival",
                 "--threads", "2", "--out", "e2"], "2D ensemble"):
            check_ensemble("e2", 4, 3000, 2, 21, ["--arrival"], 4, (0, 3))
        # 3D, tree order, uncompressed.
        if grow(["ensemble", "--dim", "3", "--clusters", "3", "--target", "1500", "--seed", "8", "--keep-positions",
                 "--compress", "0", "--out", "e3"], "3D ensemble"):
            check_ensemble("e3", 3, 1500, 3, 8, [], 0, (1,))
        # A resume without --compress writes at the level the ensemble was
        # started with (the journal's), not the default (it did until session 25).
        if os.path.exists("e3/ensemble.h5"):
            os.unlink("e3/ensemble.h5")
            rc, _, se = run([PDLA, "ensemble", "--resume", "e3", "-q"])
            check(rc == 0 and os.path.exists("e3/ensemble.h5"), "resume of e3: %s" % se.strip())
            if rc == 0:
                with h5py.File("e3/ensemble.h5", "r") as f:
                    ds = f["/clusters/positions"]
                    check(ds.compression is None and ds.attrs["deflate_level"] == 0,
                          "resume of a --compress 0 ensemble wrote %s level %s (want none, 0)"
                          % (ds.compression, ds.compression_opts))
            # A journal from before the level was recorded (its header
            # without the deflate_level line, checksum remade): level 4.
            shutil.copytree("e3", "e3old")
            os.unlink("e3old/ensemble.h5")
            raw = open("e3old/clusters.journal", "rb").read()
            tl = struct.unpack_from("<I", raw, 12)[0]
            text = raw[16:16 + tl]
            old = b"".join(l for l in text.splitlines(True) if not l.startswith(b"deflate_level="))
            check(b"deflate_level=0\n" in text and len(old) < len(text), "e3's journal header: no deflate_level=0 line")
            with open("e3old/clusters.journal", "wb") as f:
                f.write(b"PDLAENS1" + struct.pack("<II", 0x01020304, len(old)) + old + struct.pack("<Q", fnv1a(old)))
                f.write(raw[24 + tl:])
            rc, _, se = run([PDLA, "ensemble", "--resume", "e3old", "-q"])
            check(rc == 0, "resume of a journal without deflate_level: %s" % se.strip())
            if rc == 0:
                with h5py.File("e3old/ensemble.h5", "r") as f:
                    ds = f["/clusters/positions"]
                    check(ds.compression == "gzip" and ds.compression_opts == 4,
                          "a journal without deflate_level resumed at %s %s (want gzip 4)"
                          % (ds.compression, ds.compression_opts))
        if os.path.exists("e3/ensemble.h5"):
            hostile("e3/ensemble.h5")
        # --resume rewrites the sidecar, the same text.
        before = open("e2/ensemble.xdmf2").read() if os.path.exists("e2/ensemble.xdmf2") else None
        os.unlink("e2/ensemble.xdmf2") if before is not None else None
        rc, _, se = run([PDLA, "ensemble", "--resume", "e2", "--compress", "9", "-q"])
        check(rc == 0 and os.path.exists("e2/ensemble.xdmf2") and open("e2/ensemble.xdmf2").read() == before,
              "resume: the sidecar is not rewritten as it was (%s)" % se.strip())
        with h5py.File("e2/ensemble.h5", "r") as f:
            check(f["/clusters/positions"].compression_opts == 9, "resume --compress 9: level not taken")
        # An ensemble without positions replaces the old one: no stale sidecar.
        grow(["ensemble", "--clusters", "2", "--target", "200", "--out", "e2", "--force"], "--force, no positions")
        check(not os.path.exists("e2/ensemble.xdmf2"), "--force without --keep-positions left the old sidecar")
        # (session 26) a journal whose records are replaced by 2 MiB of
        # record heads, each declaring a record length near the longest: every head
        # was read whole and hashed (about 21 GB here, 20 s more than a resume
        # without them in the release build); now
        # its fixed part is checked first. The clusters grow again.
        if check(grow(["ensemble", "--clusters", "2", "--target", "20000", "--keep-positions", "--out", "dos"], "dos"),
                 "ensemble for the forged heads"):
            with open("dos/clusters.journal", "rb") as fh:
                d = fh.read()
            hl = struct.unpack("<I", d[12:16])[0]
            # record 0: its magic (with the fingerprint, 24 bytes before the
            # payload, or format 1's 16), length; record 1's head after it
            rec0, n0 = 24 + hl, struct.unpack_from("<Q", d, 24 + hl + 8)[0]
            skip = 24 if d[rec0:rec0 + 8] == b"PDLAREC2" else 16
            rec1 = rec0 + skip + n0 + 8
            heads = (d[rec0:rec0 + 8] + struct.pack("<Q", 160000) + d[rec0 + 16:rec0 + skip]) * (1 << 17)

            def resume_with(tail):
                """The journal's header and `tail`, resumed: (exit, rows, seconds, stderr)."""
                with open("dos/clusters.journal", "wb") as fh:
                    fh.write(d[:24 + hl] + tail)
                t0 = time.time()
                rc, so, se = run([PDLA, "ensemble", "--resume", "dos", "-q"])
                dt = time.time() - t0
                n = -1
                if rc == 0:
                    with h5py.File("dos/ensemble.h5", "r") as f:
                        n = f["/clusters/positions"].shape[0]
                return rc, n, dt, se.strip()
            # the time to grow both clusters again is the baseline (a sanitizer
            # build is several times slower); the heads may add a few seconds
            # (0.7 s in the release build here), not the 20 s they did
            rc0, n0, base, se0 = resume_with(b"")
            rc, n, dt, se = resume_with(heads)
            check(rc0 == 0 and n0 == 40000 and rc == 0 and n == 40000 and dt < base + 5,
                  "resume over 2 MiB of forged record heads: exit %d, %d rows, %.1f s against %.1f s without "
                  "them (want 0, 40000, under %.1f s): %s %s" % (rc, n, dt, base, base + 5, se0, se))
            sigterm_in_scan(d[:rec1] + d[rec1:rec1 + skip + 136] * ((4 << 20) // (skip + 136)))
        # Bad levels: one line, exit 2, nothing written.
        for bad in ("10", "-1", "x", "4x"):
            rc, so, se = run([PDLA, "ensemble", "--clusters", "2", "--target", "100", "--keep-positions",
                              "--compress", bad, "--out", "b"])
            check(rc == 2 and len(se.strip().splitlines()) == 1 and "--compress" in se and not os.path.exists("b"),
                  "--compress %s: exit %d, %s" % (bad, rc, se.strip()))
    finally:
        os.chdir("/")
        shutil.rmtree(tmp, ignore_errors=True)


main()
print("%d checks, %d failed" % (checks, fails))
sys.exit(1 if fails else 0)
