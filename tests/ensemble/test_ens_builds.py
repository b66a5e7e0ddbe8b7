#!/usr/bin/python3
"""test_ens_builds.py - which builds of pdla grew an ensemble.

Usage: test_ens_builds.py PDLA WORKDIR

A week-long ensemble may be resumed by another build of pdla (an upgrade
between two allocations). Its clusters are then the same law, not the same
bits as an uninterrupted run, and the files must say so:
 - a new journal lists the build that made it (`pdla --version`'s
   revision), and ensemble.h5 /ensemble builds says it;
 - a resume by another build (the journal's build line forged, its last
   record cut so that clusters are missing) prints one note naming both
   builds, adds this build to the journal, and /ensemble builds lists both
   in order; the clusters equal the uninterrupted run's (same build here);
 - a second resume with nothing to grow prints no note and changes nothing;
 - a journal from before builds were recorded (no build line) resumed:
   /ensemble builds is "unrecorded REV";
 - extending (`--clusters M2`) by another build adds it too;
 - a build line that is empty or holds a control character is a damaged
   header: one line, exit 2, nothing written.
"""
import os
import shutil
import struct
import subprocess
import sys

import h5py
import numpy as np

PDLA, WORK = os.path.abspath(sys.argv[1]), sys.argv[2]
fails = 0


def check(ok, what):
    global fails
    if not ok:
        fails += 1
        print("FAIL:", what)


def pdla(*args):
    p = subprocess.run([PDLA] + list(args), capture_output=True, text=True, timeout=300)
    return p.returncode, p.stderr


def fnv1a(data):
    h = 0xcbf29ce484222325
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def read_journal(path):
    """(header text, [record bytes]) of a journal (native order)."""
    raw = open(path, "rb").read()
    assert raw[:8] == b"PDLAENS1"
    _, tl = struct.unpack("=II", raw[8:16])
    text = raw[16:16 + tl].decode()
    off, recs = 24 + tl, []
    while off < len(raw):
        (n,) = struct.unpack("=Q", raw[off + 8:off + 16])
        recs.append(raw[off:off + 24 + n])
        off += 24 + n
    return text, recs


def write_journal(path, text, recs):
    t = text.encode()
    head = b"PDLAENS1" + struct.pack("=II", 0x01020304, len(t)) + t + struct.pack("=Q", fnv1a(t))
    with open(path, "wb") as fh:
        fh.write(head + b"".join(recs))


def builds_attr(d):
    with h5py.File(os.path.join(d, "ensemble.h5"), "r") as f:
        b = f["ensemble"].attrs["builds"]
        return b.decode() if isinstance(b, bytes) else str(b)


def same_clusters(a, b):
    with h5py.File(os.path.join(a, "ensemble.h5"), "r") as fa, h5py.File(os.path.join(b, "ensemble.h5"), "r") as fb:
        for k in ("rg_diam", "seed", "jumps", "rg_final_diam"):
            if not np.array_equal(fa["clusters"][k][()], fb["clusters"][k][()]):
                return False
    return True


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)
rc, out = 0, subprocess.run([PDLA, "--version"], capture_output=True, text=True).stdout
rev = next(line.split(None, 1)[1] for line in out.splitlines() if line.startswith("revision "))
check(rev and " " not in rev, "--version revision %r" % rev)

GROW = ["--target", "3000", "--seed", "21", "-q"]
rc, err = pdla("ensemble", "--clusters", "4", "--out", "ref", *GROW)
check(rc == 0, "reference ensemble: %d %s" % (rc, err))
check(builds_attr("ref") == rev, "a new ensemble's builds: %r, want %r" % (builds_attr("ref"), rev))
text, recs = read_journal("ref/clusters.journal")
check(text.count("build=") == 1 and ("build=%s\n" % rev) in text, "journal header: %r" % text[:200])
check(len(recs) == 4, "4 records, got %d" % len(recs))


def forged(name, text_new, nrec):
    shutil.copytree("ref", name)
    os.remove(os.path.join(name, "ensemble.h5"))
    write_journal(os.path.join(name, "clusters.journal"), text_new, recs[:nrec])


# Another build grew the first two clusters.
other = text.replace("build=%s\n" % rev, "build=v0.0.9-other\n")
forged("other", other, 2)
rc, err = pdla("ensemble", "--resume", "other", "-q")
check(rc == 0, "resume by another build: %d %s" % (rc, err))
note = [line for line in err.splitlines() if "note:" in line and "build" in line]
check(len(note) == 1 and "v0.0.9-other" in note[0] and rev in note[0], "the note: %r" % err)
check(builds_attr("other") == "v0.0.9-other " + rev, "builds after the resume: %r" % builds_attr("other"))
t2, r2 = read_journal("other/clusters.journal")
check("build=v0.0.9-other\nbuild=%s\n" % rev in t2, "journal lists both builds in order: %r" % t2[:200])
check(len(r2) == 4, "resumed journal has 4 records: %d" % len(r2))
check(same_clusters("ref", "other"), "resumed clusters equal the uninterrupted run's")
before = open("other/clusters.journal", "rb").read()
rc, err = pdla("ensemble", "--resume", "other", "-q")
check(rc == 0 and "build" not in err, "second resume: %d %r" % (rc, err))
check(open("other/clusters.journal", "rb").read() == before, "second resume rewrote the journal")

# A journal from before builds were recorded.
old = text.replace("build=%s\n" % rev, "")
forged("old", old, 3)
rc, err = pdla("ensemble", "--resume", "old", "-q")
check(rc == 0 and "unknown (not recorded)" in err, "resume of an old journal: %d %r" % (rc, err))
check(builds_attr("old") == "unrecorded " + rev, "builds of an old journal: %r" % builds_attr("old"))
check(same_clusters("ref", "old"), "old journal's clusters")

# Extending by another build: the rewrite adds it.
forged("ext", other, 4)
rc, err = pdla("ensemble", "--resume", "ext", "--clusters", "6", "-q")
check(rc == 0 and "v0.0.9-other" in err, "extend by another build: %d %r" % (rc, err))
check(builds_attr("ext") == "v0.0.9-other " + rev, "builds after extending: %r" % builds_attr("ext"))

# Damaged build lines.
for tag, line in (("empty", "build=\n"), ("control", "build=v1\x01x\n"), ("blank", "build=v1 x\n")):
    forged("bad-" + tag, text.replace("build=%s\n" % rev, line), 2)
    before = open("bad-%s/clusters.journal" % tag, "rb").read()
    rc, err = pdla("ensemble", "--resume", "bad-" + tag, "-q")
    lines = err.strip().splitlines()
    check(rc == 2 and len(lines) == 1 and "bad build line" in err, "%s build line: %d %r" % (tag, rc, err))
    check(open("bad-%s/clusters.journal" % tag, "rb").read() == before, "%s: journal changed" % tag)
    check(not os.path.exists("bad-%s/ensemble.h5" % tag), "%s: ensemble.h5 written" % tag)

print("%s (%d failures)" % ("ok" if not fails else "FAILED", fails))
sys.exit(1 if fails else 0)
