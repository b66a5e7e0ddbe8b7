#!/usr/bin/env python3
"""test_dlca_start.py PDLA - `pdla --model dlca --start FILE` and
`--snapshot-every T`.

--start: monomers from a text file land where the file says (slot order =
file order); face-adjacent ones start joined; an HDF5 cluster.h5 restarts
from its /monomers/position; bad files (two monomers on one site, outside
the box, wrong number of coordinates, a number not ended by a blank, '#' or
the line's end such as "1+2" or "1,2", empty, missing) and --start with
--resume are refused with one line, exit 2 and no run directory.

--snapshot-every: /snapshots/i holds the state at the first attempt at or
after (i+1) T: the same sites and cluster numbers as a run stopped by
--until-time (i+1) T; snapshots do not change the history (digest); a
checkpoint keeps them, so a resumed run holds the same snapshots.
"""
import os
import re
import subprocess
import sys
import tempfile

import h5py
import numpy as np

pdla = sys.argv[1]
fails = 0


def check(cond, msg):
    global fails
    if not cond:
        fails += 1
        print("FAIL:", msg)


def run(*args):
    p = subprocess.run([pdla, "--model", "dlca", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       stdin=subprocess.DEVNULL)
    return p.returncode, p.stderr.decode(errors="replace")


tmp = tempfile.mkdtemp()


def path(name):
    return os.path.join(tmp, name)


def write(name, text):
    with open(path(name), "w") as f:
        f.write(text)
    return path(name)


# A text start, no two adjacent: already 3 clusters, so the run stops at once
# and the positions are the file's, in its order.
ok = write("ok.txt", "# x y\n1 1\n5 1\n\n10 20  # a comment\n")
rc, err = run("--box", "32", "--start", ok, "--until-clusters", "3", "--out", path("r1"), "--check", "-q")
check(rc == 0, f"text start: exit {rc} {err}")
if rc == 0:
    with h5py.File(path("r1/cluster.h5"), "r") as f:
        pos = f["monomers/position"][()]
        check(pos.tolist() == [[1, 1], [5, 1], [10, 20]], f"text start positions {pos.tolist()}")
        check(int(f["parameters"].attrs["count"]) == 3, "count is not the file's 3 monomers")

# Face-adjacent monomers of the file start joined (across the periodic edge).
adj = write("adj.txt", "0 3\n31 3\n")
rc, err = run("--box", "32", "--start", adj, "--until-clusters", "1", "--max-attempts", "1", "--out", path("r2"), "-q")
check(rc == 0, f"adjacent start: exit {rc} {err}")
if rc == 0:
    with h5py.File(path("r2/cluster.h5"), "r") as f:
        check(int(f["results"].attrs["n_clusters"]) == 1 and int(f["results"].attrs["attempts"]) == 0,
              "adjacent monomers across the edge did not start joined")

# An HDF5 start: a random run's end state, restarted: the same sites.
rc, err = run("--box", "64x48", "--fill", "0.05", "--until-clusters", "10", "--seed", "3", "--out", path("r3"), "-q")
check(rc == 0, f"random run: exit {rc} {err}")
rc, err = run("--box", "64x48", "--start", path("r3/cluster.h5"), "--until-clusters", "10", "--out", path("r4"), "-q")
check(rc == 0, f"HDF5 start: exit {rc} {err}")
if rc == 0:
    with h5py.File(path("r3/cluster.h5"), "r") as a, h5py.File(path("r4/cluster.h5"), "r") as b:
        sa, sb = sorted(a["monomers/site"][()].tolist()), sorted(b["monomers/site"][()].tolist())
        check(sa == sb, "HDF5 start: the sites differ from the file's")
        check(int(b["results"].attrs["n_clusters"]) == 10, "HDF5 start: the 10 clusters did not start joined")

# Refused: one line, exit 2, no run directory.
bad = {
    "dup": write("dup.txt", "1 1\n2 2\n1 1\n"),
    "outside": write("out.txt", "1 1\n32 0\n"),
    "negative": write("neg.txt", "-1 0\n"),
    "coords": write("dim.txt", "1 1 1\n"),
    "junk": write("junk.txt", "1 x\n"),
    "empty": write("empty.txt", "# nothing\n"),
    "missing": path("nosuch.txt"),
    # audit-dlca: fgets split a line past 4095 bytes and read its tail as a
    # line of its own: the end of a long comment became monomer (7, 7).
    "long_comment": write("longc.txt", "# " + "a" * 4092 + " 7 7\n5 5\n"),
    "long_line": write("longl.txt", "1 2" + " " * 4093 + "\n3 3\n"),
    # session 27 review: strtoll stopped at the '+' and "1+2" started a
    # monomer at (1, 2); commas were read as blanks, which no help said.
    "plus": write("plus.txt", "1+2\n10 10\n"),
    "comma": write("comma.txt", "10 10\n1,2\n"),
    "suffix": write("suffix.txt", "1 2x\n"),
}
# A line of exactly 4095 bytes and its newline is a line.
fits = write("fits.txt", "1 2" + " " * 4092 + "\n3 3\n")
rc, err = run("--box", "32", "--start", fits, "--until-clusters", "2", "--out", path("fits"), "-q")
check(rc == 0, f"--start with a 4095-byte line: exit {rc} {err!r}")
# An endless start (audit-dlca: read to its end before any check, memory
# without bound): refused once it passes the box's sites (N < V).
yes = subprocess.Popen(["yes", "0 0"], stdout=subprocess.PIPE)
try:
    p = subprocess.run([pdla, "--model", "dlca", "--box", "32", "--start", "/dev/stdin", "--out", path("bad")],
                       stdin=yes.stdout, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=20)
    rc, err = p.returncode, p.stderr.decode(errors="replace")
except subprocess.TimeoutExpired:
    rc, err = None, "did not end within 20 s"
finally:
    yes.kill()
    yes.wait()
check(rc == 2 and err.count("\n") == 1 and not os.path.exists(path("bad")), f"--start endless: exit {rc} {err!r}")
for what, f in bad.items():
    rc, err = run("--box", "32", "--start", f, "--out", path("bad"))
    check(rc == 2 and err.count("\n") == 1 and err.startswith("pdla: ") and not os.path.exists(path("bad")),
          f"--start {what}: exit {rc}, stderr {err!r}")
    # README: "naming the file and line" (the line where there is one)
    check(f in err, f"--start {what}: the message does not name the file: {err!r}")
    if what in ("junk", "coords", "long_line", "long_comment"):
        check(re.search(r": lines? [0-9]", err) is not None, f"--start {what}: the message names no line: {err!r}")
    want = {"plus": ": line 1: expected 2 integer coordinates separated by spaces or tabs",
            "comma": ": line 2: expected 2 integer coordinates separated by spaces or tabs",
            "suffix": ": line 1: expected 2 integer coordinates"}.get(what)
    if want:
        check(want in err, f"--start {what}: want {want!r} in {err!r}")
rc, err = run("--resume", path("r3"), "--start", ok)
check(rc == 2 and err.count("\n") == 1, f"--start with --resume: exit {rc} {err!r}")
for v in ("0", "-1", "x"):
    rc, err = run("--snapshot-every", v, "--out", path("bad"))
    check(rc == 2 and err.count("\n") == 1 and not os.path.exists(path("bad")), f"--snapshot-every {v}: exit {rc}")

# Snapshots: each equals a run stopped by --until-time at its multiple of T.
T = 40.0
base = ["--box", "64", "--fill", "0.05", "--until-clusters", "5", "--seed", "4"]
rc, err = run(*base, "--snapshot-every", str(T), "--out", path("sn"), "-q")
check(rc == 0, f"--snapshot-every: exit {rc} {err}")
rc2, err2 = run(*base, "--out", path("plain"), "-q")
with h5py.File(path("sn/cluster.h5"), "r") as f, h5py.File(path("plain/cluster.h5"), "r") as g:
    check(f["results"].attrs["history_digest"] == g["results"].attrs["history_digest"],
          "snapshots changed the history")
    n = int(f["snapshots"].attrs["count"])
    t_end = float(f["results"].attrs["t"])
    check(n == int(t_end // T) or n == int(t_end // T) + 1 and t_end % T == 0, f"{n} snapshots up to t = {t_end}")
    N = int(f["results"].attrs["n_monomers"])
    for i in range(n):
        s = f[f"snapshots/{i}"]
        t, site, cl = float(s.attrs["t"]), s["site"][()], s["cluster"][()]
        check(t >= (i + 1) * T and (i == 0 or t > float(f[f"snapshots/{i - 1}"].attrs["t"])), f"snapshot {i} at t {t}")
        check(len(site) == N and len(np.unique(site)) == N and cl.max() + 1 == s.attrs["n_clusters"],
              f"snapshot {i}: not N distinct sites with numbered clusters")
    for i in sorted({0, n // 2, n - 1}) if n else []:
        s = f[f"snapshots/{i}"]
        d = path(f"until{i}")
        rc, err = run(*base, "--until-time", str((i + 1) * T), "--out", d, "-q")
        with h5py.File(os.path.join(d, "cluster.h5"), "r") as h:
            check(rc == 0 and float(h["results"].attrs["t"]) == float(s.attrs["t"]) and
                  np.array_equal(h["monomers/site"][()], s["site"][()]) and
                  np.array_equal(h["monomers/cluster"][()], s["cluster"][()]),
                  f"snapshot {i} differs from the run stopped at t = {(i + 1) * T}")

# Snapshots across a checkpoint: a run stopped at t = 150 (3 snapshots
# taken) and resumed without --snapshot-every (the period is the
# checkpoint's) holds the same /snapshots, bit for bit, as the straight run
# above, and the same history.
rc, err = run(*base, "--snapshot-every", str(T), "--until-time", "150", "--checkpoint-attempts", "1000000",
              "--out", path("ck"), "-q")
check(rc == 0, f"run to t = 150 with checkpoints: exit {rc} {err}")
rc, err = run("--resume", path("ck"), "--until-time", "0", "-q")
check(rc == 0, f"resume: exit {rc} {err}")
if rc == 0:
    with h5py.File(path("ck/cluster.h5"), "r") as f, h5py.File(path("sn/cluster.h5"), "r") as g:
        check(f["results"].attrs["history_digest"] == g["results"].attrs["history_digest"],
              "the resumed run's history differs")
        n = int(f["snapshots"].attrs["count"]) if "snapshots" in f else 0
        m = int(g["snapshots"].attrs["count"])
        every = float(f["snapshots"].attrs["every"]) if n else None
        check(n == m and n > 3 and every == T, f"resumed run: {n} snapshots, every {every}; straight run {m}")
        for i in range(min(n, m)):
            a, b = f[f"snapshots/{i}"], g[f"snapshots/{i}"]
            check(all(a.attrs[k] == b.attrs[k] for k in ("t", "attempts", "n_clusters")) and
                  all(np.array_equal(a[k][()], b[k][()]) for k in ("site", "cluster", "position")),
                  f"snapshot {i} differs after the resume")

# A checkpoint whose /snapshots claims more snapshots than it holds (or one
# of the wrong length) is refused with one line, exit 2.
rc, err = run(*base, "--snapshot-every", str(T), "--until-time", "100", "--checkpoint", "--out", path("forge"), "-q")
check(rc == 0, f"run for the forged checkpoints: exit {rc} {err}")
for what in ("count", "length"):
    subprocess.run(["cp", path("forge/checkpoint.h5"), path(f"forge-{what}.h5")])
    with h5py.File(path(f"forge-{what}.h5"), "r+") as f:
        if what == "count":
            f["snapshots"].attrs["count"] = np.uint64(10**9)
        else:
            del f["snapshots/0/site"]
            f["snapshots/0/site"] = np.zeros(3, dtype="u4")
    rc, err = run("--resume", path(f"forge-{what}.h5"), "--out", path(f"forge-{what}"), "-q")
    check(rc == 2 and err.count("\n") == 1 and "snapshots" in err, f"forged snapshot {what}: exit {rc} {err!r}")



def rchar():
    """Bytes this process and its waited-for children have read (read,
    pread: /proc/self/io; a child's are added when it is reaped)."""
    with open("/proc/self/io") as f:
        return int(next(ln for ln in f if ln.startswith("rchar:")).split()[1])


# An HDF5 start whose /monomers/position is one gzip'ed chunk larger than
# HDF5's default 1 MiB chunk cache: the start read it in slabs of 65536
# rows and HDF5 read and decompressed the whole chunk again for each (a
# start of 1.2e7 monomers took 157 s, not 16 s: quadratic in N). Now the
# chunk is read once: the run reads about the file's size, where it read 8
# times that (5e5 rows, 8 slabs). Bytes read, not seconds: deterministic.
n1, L1 = 500000, 2048
k1 = np.random.default_rng(5).choice(L1 * L1, size=n1, replace=False)
with h5py.File(path("onechunk.h5"), "w") as f:
    f.create_dataset("/monomers/position", data=np.stack([k1 % L1, k1 // L1], axis=1).astype("i4"),
                     chunks=(n1, 2), compression="gzip", compression_opts=1)
size1, before = os.path.getsize(path("onechunk.h5")), rchar()
rc, err = run("--box", str(L1), "--start", path("onechunk.h5"), "--max-attempts", "1", "--no-output", "-q")
read1 = rchar() - before
check(rc == 0, f"one-chunk gzip start: exit {rc} {err}")
check(read1 < 2 * size1, f"one-chunk gzip start: read {read1} bytes of a {size1}-byte file (want < 2x: once)")

subprocess.run(["rm", "-rf", tmp])
print("dlca start/snapshots:", "all passed" if fails == 0 else f"{fails} failed")
sys.exit(1 if fails else 0)
