#!/usr/bin/python3
"""test_ens_builds.py - which builds of pdla grew an ensemble.

Usage: test_ens_builds.py PDLA WORKDIR FAULTSHIM OLD_JOURNAL

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
   right, and a resume afterwards gives the uninterrupted ensemble;
 - a journal of format 1, from before records carried the fingerprint of
   their growth parameters (OLD_JOURNAL, written by build 62cf198 of
   session 26): whole, it resumes with nothing to grow and nothing written;
   with a record cut, the missing cluster grows and is appended with this
   ensemble's fingerprint, the old records and the format-1 header stay;
   the ensemble equals a clean run's (every per-cluster dataset but the
   timings, the positions, /statistics). A format-1 record of an ensemble
   that differs only in --eps is refused and grown again after the first
   record with a fingerprint in an old journal, and anywhere in a new one.
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
from journal_util import (as_format1, fingerprint, fnv1a, read_journal, record_index,  # noqa: E402
                          write_journal)

PDLA, WORK, SHIM = os.path.abspath(sys.argv[1]), sys.argv[2], os.path.abspath(sys.argv[3])
OLD_JOURNAL = os.path.abspath(sys.argv[4])
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
check(all(r[:8] == b"PDLAREC2" for r in recs), "a new journal holds cluster records (with fingerprints) only")
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
check([r[:8] for r in r2] == [b"PDLAREC2"] * 2 + [b"PDLABLD1"] + [b"PDLAREC2"] * 2,
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


# ---- a journal of format 1 (records without a fingerprint) -------------------
def same_all(a, b):
    """Every per-cluster dataset but the timings, the positions,
    /gyration/N and /statistics of a/ and b/ensemble.h5 are equal."""
    with h5py.File(os.path.join(a, "ensemble.h5"), "r") as fa, h5py.File(os.path.join(b, "ensemble.h5"), "r") as fb:
        names = [k for k in fa["clusters"] if k not in ("cpu_seconds", "wall_seconds")]
        sets = ["clusters/" + k for k in names] + ["gyration/N"] + ["statistics/" + k for k in fa["statistics"]]
        return set(fa["clusters"]) == set(fb["clusters"]) and \
            all(np.array_equal(fa[k][()], fb[k][()], equal_nan=True) for k in sets)


# The fixture's ensemble (README of tests/ensemble/data), grown by this build.
OLD_ARGS = ["--clusters", "4", "--target", "400", "--seed", "7", "--keep-positions", "--arrival"]
rc, err = pdla("ensemble", *OLD_ARGS, "--eps", "3", "--out", "v1ref", "-q")
check(rc == 0, "the format-1 fixture's ensemble, clean: %d %r" % (rc, err))
# The same but --eps 2: its records have cluster i's index, seed, dimension
# and size.
rc, err = pdla("ensemble", *OLD_ARGS, "--eps", "2", "--out", "v1eps2", "-q")
check(rc == 0, "the --eps 2 ensemble: %d %r" % (rc, err))
_, new_recs = read_journal("v1ref/clusters.journal")
_, eps2_recs = read_journal("v1eps2/clusters.journal")
alien3 = as_format1([r for r in eps2_recs if record_index(r) == 3][0])  # as an old build wrote it
text1, recs1 = read_journal(OLD_JOURNAL)
check(text1.startswith("format=pdla-ensemble-journal 1\n") and [r[:8] for r in recs1] == [b"PDLAREC1"] * 4 and
      sorted(record_index(r) for r in recs1) == [0, 1, 2, 3], "the fixture is not a format-1 journal of 4 clusters")


def old_dir(name, recs_v1):
    os.makedirs(name)
    write_journal(os.path.join(name, "clusters.journal"), text1, recs_v1)


# Whole: nothing to grow, nothing written to the journal.
os.makedirs("v1all")
shutil.copy(OLD_JOURNAL, "v1all/clusters.journal")
rc, err = pdla("ensemble", "--resume", "v1all", "-q")
check(rc == 0 and same_all("v1ref", "v1all"), "the whole format-1 journal resumed: %d %r" % (rc, err))
check(open("v1all/clusters.journal", "rb").read() == open(OLD_JOURNAL, "rb").read(),
      "resuming a complete format-1 journal changed it")
# Cluster 2 cut: it grows, and comes with a fingerprint (this build's join first).
old_dir("v1miss", [r for r in recs1 if record_index(r) != 2])
rc, err = pdla("ensemble", "--resume", "v1miss", "-q")
check(rc == 0 and same_all("v1ref", "v1miss"), "a format-1 journal with cluster 2 cut, resumed: %d %r" % (rc, err))
t2, r2 = read_journal("v1miss/clusters.journal")
check(t2 == text1 and r2[:3] == [r for r in recs1 if record_index(r) != 2],
      "resuming a format-1 journal changed its header or its old records")
check([r[:8] for r in r2[3:] if r[:8] != b"PDLABLD1"] == [b"PDLAREC2"] and record_index(r2[-1]) == 2 and
      fingerprint(r2[-1]) == fingerprint(new_recs[0]),
      "the record appended to a format-1 journal: %r (want a build record, then cluster 2 with this "
      "ensemble's fingerprint)" % [r[:8] for r in r2[3:]])
# A format-1 record after that first record with a fingerprint: refused.
if r2[-1][:8] == b"PDLAREC2":
    old_dir("v1after", [r for r in recs1 if record_index(r) < 2] + r2[3:] + [alien3])
    rc, err = pdla("ensemble", "--resume", "v1after")
    check(rc == 0 and "cluster 3: it has no parameter fingerprint" in err and "3 of 4 clusters recorded" in err and
          same_all("v1ref", "v1after"),
          "a format-1 --eps 2 record after a fingerprinted one in an old journal: %d %r" % (rc, err))
# A format-1 record in a journal of this build's format: refused.
shutil.copytree("v1ref", "v1new")
os.remove("v1new/ensemble.h5")
tn, rn = read_journal("v1new/clusters.journal")
write_journal("v1new/clusters.journal", tn, [r for r in rn if record_index(r) != 3] + [alien3])
rc, err = pdla("ensemble", "--resume", "v1new")
check(rc == 0 and "cluster 3: it has no parameter fingerprint" in err and same_all("v1ref", "v1new"),
      "a format-1 --eps 2 record in a new journal: %d %r" % (rc, err))

print("%s (%d failures)" % ("ok" if not failures else "FAILED", len(failures)))
sys.exit(1 if failures else 0)
