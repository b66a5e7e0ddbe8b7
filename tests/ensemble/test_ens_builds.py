#!/usr/bin/python3
"""test_ens_builds.py - which builds of pdla grew an ensemble.

Usage: test_ens_builds.py PDLA WORKDIR FAULTSHIM

A week-long ensemble may be resumed by another build of pdla (an upgrade
between two allocations). Its clusters are then the same law, not the same
bits as an uninterrupted run, and the files must say so:
 - a new journal lists the build that made it (`pdla --version`'s
   revision), and ensemble.h5 /ensemble builds says it;
 - a resume by another build (the journal's build line forged, its last
   records cut so that clusters are missing) prints one note naming both
   builds, appends a build record (the journal is not rewritten: its bytes
   before stay as they were), and /ensemble builds lists both in order; the
   clusters equal the uninterrupted run's (same build here);
 - a second resume with nothing to grow prints no note and changes nothing;
 - a journal from before builds were recorded (no build line) resumed:
   /ensemble builds is "unrecorded REV";
 - extending (`--clusters M2`) by another build adds it too;
 - a build line that is empty or holds a control character is a damaged
   header: one line, exit 2, nothing written;
 - a read error (EIO from pread, as a bad sector gives; faultshim) at each
   read of a resume: never taken for a torn tail - the journal's bytes are
   kept (appended to at most), the run fails with one line or finishes
   right, and a resume afterwards gives the uninterrupted ensemble.
"""
import os
import shutil
import struct
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import check, failures, runner, shim_preload  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from journal_util import fnv1a, read_journal, write_journal  # noqa: E402

PDLA, WORK, SHIM = os.path.abspath(sys.argv[1]), sys.argv[2], os.path.abspath(sys.argv[3])
PRELOAD = shim_preload(PDLA, SHIM)


pdla = runner(PDLA, 300)


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
check(all(r[:8] == b"PDLAREC1" for r in recs), "a new journal holds cluster records only")
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
check(t2 == other, "the header was rewritten: %r" % t2[:200])
check([r[:8] for r in r2] == [b"PDLAREC1"] * 2 + [b"PDLABLD1"] + [b"PDLAREC1"] * 2,
      "records: two clusters, this build, two clusters: %r" % [r[:8] for r in r2])
check(r2[2][16:-8] == rev.encode(), "the build record names %r: %r" % (rev, r2[2][16:-8]))
check(r2[:2] == recs[:2], "the records before the resume changed")
check(same_clusters("ref", "other"), "resumed clusters equal the uninterrupted run's")
before = open("other/clusters.journal", "rb").read()
rc, err = pdla("ensemble", "--resume", "other", "-q")
check(rc == 0 and "build" not in err, "second resume: %d %r" % (rc, err))
check(open("other/clusters.journal", "rb").read() == before, "second resume rewrote the journal")

# Damage before a build record that ends the journal: the scan goes on past
# the damage to the build record (not only to cluster records), so the build
# stays listed instead of being cut as a torn tail.
name = b"v0.0.8-third"
third = b"PDLABLD1" + struct.pack("=Q", len(name)) + name + struct.pack("=Q", fnv1a(struct.pack("=Q", len(name)) + name))
bad = bytearray(r2[1])
bad[40] ^= 0xFF
forged("dmgbld", other, 0)
write_journal("dmgbld/clusters.journal", other, [r2[0], bytes(bad), third])
rc, err = pdla("ensemble", "--resume", "dmgbld", "-q")
check(rc == 0, "resume past damage before a build record: %d %r" % (rc, err))
check(builds_attr("dmgbld").split() == ["v0.0.9-other", "v0.0.8-third", rev],
      "the build record after the damage was lost: builds %r" % builds_attr("dmgbld"))
check(same_clusters("ref", "dmgbld"), "clusters after damage before a build record")

# A journal from before builds were recorded.
old = text.replace("build=%s\n" % rev, "")
forged("old", old, 3)
rc, err = pdla("ensemble", "--resume", "old", "-q")
check(rc == 0 and "unknown (not recorded)" in err, "resume of an old journal: %d %r" % (rc, err))
_, r3 = read_journal("old/clusters.journal")
check([r[16:-8] for r in r3 if r[:8] == b"PDLABLD1"] == [b"unrecorded", rev.encode()],
      "old journal's build records: %r" % [r[:8] for r in r3])
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

# Read errors: each pread of a resume fails once in turn.
forged("pr", text, 2)
counter = os.path.join(WORK, "preads")
rc, err = pdla("ensemble", "--resume", "pr", "-q",
               env={"LD_PRELOAD": PRELOAD, "FAULT_OP": "pread", "FAULT_AT": "0", "FAULT_COUNT": counter})
shutil.rmtree("pr")
n = int(open(counter).read())
check(rc == 0 and n >= 4, "counting preads: %d %r, %d" % (rc, err, n))
for k in range(1, n + 1):
    tag = "pr%d" % k
    forged(tag, text, 2)
    jpath = os.path.join(tag, "clusters.journal")
    before = open(jpath, "rb").read()
    rc, err = pdla("ensemble", "--resume", tag, "-q",
                   env={"LD_PRELOAD": PRELOAD, "FAULT_OP": "pread", "FAULT_AT": str(k), "FAULT_ERR": "EIO"})
    lines = err.strip().splitlines()
    check(rc == 0 or len(lines) == 1, "pread %d: %d %r" % (k, rc, err))
    check("torn" not in err, "pread %d taken for a torn tail: %r" % (k, err))
    # Appends only: what was there stays (a failure after the growth, in
    # reading records back for ensemble.h5, leaves the new records too).
    check(open(jpath, "rb").read()[:len(before)] == before, "pread %d: journal bytes lost or overwritten" % k)
    rc, err = pdla("ensemble", "--resume", tag, "-q")
    check(rc == 0 and same_clusters("ref", tag), "pread %d: the resume after it: %d %r" % (k, rc, err))
    shutil.rmtree(tag)

print("%s (%d failures)" % ("ok" if not failures else "FAILED", len(failures)))
sys.exit(1 if failures else 0)
