#!/usr/bin/python3
"""test_ens_extend_build.py - one place lists a build: the join.

Usage: test_ens_extend_build.py PDLA WORKDIR

Extending an ensemble (`--resume DIR --clusters M2`) rewrites its journal
with M2 in the header. The rewrite keeps the journal's list of builds as it
was; the build that extends is added by the build record every resume by
another build appends (pdla_ens_journal_join), so there is one code path
that adds builds. Checked on the bytes of the journal, for a journal whose
header names another build and for one from before builds were recorded:
 - the new header's build lines are the old list, unchanged, and only the
   clusters count changed;
 - after the copied records comes a build record ("unrecorded" first for
   the old journal) and then this build's record, then the new clusters;
 - the list seen by ensemble.h5 /ensemble builds is what it was before the
   simplification (test ensemble-builds checks that too).
Before, the rewrite put this build (and "unrecorded") into the header and
the join wrote nothing.
"""
import os
import shutil
import subprocess
import sys

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import check, failures, runner  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from journal_util import read_journal, write_journal  # noqa: E402

PDLA, WORK = os.path.abspath(sys.argv[1]), sys.argv[2]
pdla = runner(PDLA, 300)


def builds_attr(d):
    with h5py.File(os.path.join(d, "ensemble.h5"), "r") as f:
        b = f["ensemble"].attrs["builds"]
        return b.decode() if isinstance(b, bytes) else str(b)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)
out = subprocess.run([PDLA, "--version"], capture_output=True, text=True).stdout
rev = next(line.split(None, 1)[1] for line in out.splitlines() if line.startswith("revision "))
rc, err = pdla("ensemble", "--clusters", "3", "--target", "1000", "--seed", "8", "-q", "--out", "ref")
check(rc == 0, "reference: %d %r" % (rc, err))
text, recs = read_journal("ref/clusters.journal")

for tag, line, listed in (("other", "build=v0.0.9-other\n", ["v0.0.9-other"]), ("old", "", ["unrecorded"])):
    shutil.copytree("ref", tag)
    os.remove(os.path.join(tag, "ensemble.h5"))
    old_text = text.replace("build=%s\n" % rev, line)
    write_journal(os.path.join(tag, "clusters.journal"), old_text, recs)
    rc, err = pdla("ensemble", "--resume", tag, "--clusters", "5", "-q")
    check(rc == 0, "%s: extend: %d %r" % (tag, rc, err))
    t2, r2 = read_journal(os.path.join(tag, "clusters.journal"))
    check(t2 == old_text.replace("clusters=3\n", "clusters=5\n") and t2 != old_text,
          "%s: the header changed beyond its count: %r" % (tag, t2))
    names = [r[16:-8].decode() for r in r2 if r[:8] == b"PDLABLD1"]
    added = [n for n in listed if n == "unrecorded"] + [rev]
    check(names == added, "%s: build records %r, want %r" % (tag, names, added))
    check(r2[:3] == recs and [r[:8] for r in r2[3:]] == [b"PDLABLD1"] * len(added) + [b"PDLAREC2"] * 2,
          "%s: records %r" % (tag, [r[:8] for r in r2]))
    check(builds_attr(tag) == " ".join(listed + [rev]), "%s: /ensemble builds %r" % (tag, builds_attr(tag)))

print("%s (%d failures)" % ("ok" if not failures else "FAILED", len(failures)))
sys.exit(1 if failures else 0)
