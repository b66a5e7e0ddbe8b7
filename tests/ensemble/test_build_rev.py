#!/usr/bin/python3
"""test_build_rev.py - builds made outside a git checkout tell themselves apart.

Usage: test_build_rev.py SOURCE_ROOT

The source tree as this checkout has it (git ls-files: tracked and new
files, not the ignored build folders) is copied to a temporary folder
outside any git repository and built there (pdla only, -O0, no MPI):
 - `pdla --version` reports "unknown-src-" and 12 hex digits, and
   scripts/build-revision run on the copy agrees (before, every such build
   was "unknown");
 - an ensemble grown by that build, its last record torn (the journal cut
   by one byte), is resumed by a second build of the copy with one source
   file changed: the two revisions differ, the resume notes both, and
   ensemble.h5 /ensemble builds lists them in order (before: "unknown",
   the same for both builds, so the journal could not tell them apart);
 - ninja with nothing changed keeps the revision (no spurious change).
Skipped (77) without git or meson/ninja, as in a release tarball.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import check, failures  # noqa: E402

ROOT = os.path.abspath(sys.argv[1])
MESON, NINJA, GIT = shutil.which("meson"), shutil.which("ninja"), shutil.which("git")
if not (MESON and NINJA and GIT):
    print("skipped: needs meson, ninja and git")
    sys.exit(77)
listed = subprocess.run([GIT, "-C", ROOT, "ls-files", "-z", "-co", "--exclude-standard"], capture_output=True)
if listed.returncode != 0:
    print("skipped: %s is not a git checkout" % ROOT)
    sys.exit(77)

work = tempfile.mkdtemp(prefix="pdla-build-rev-")
src, bld = os.path.join(work, "src"), os.path.join(work, "build")


def sh(*cmd, quiet=False):
    p = subprocess.run(list(cmd), capture_output=True, text=True)
    if p.returncode != 0 and not quiet:
        print("$ %s\n%s%s" % (" ".join(cmd), p.stdout[-3000:], p.stderr[-3000:]), flush=True)
    return p


def version():
    out = sh(os.path.join(bld, "pdla"), "--version").stdout
    return next((ln.split(None, 1)[1] for ln in out.splitlines() if ln.startswith("revision ")), "")


def build():
    return sh(NINJA, "-C", bld, "pdla").returncode == 0


try:
    # The copy: outside any repository (GIT_CEILING_DIRECTORIES keeps git
    # from looking above the temporary folder, wherever TMPDIR is).
    os.environ["GIT_CEILING_DIRECTORIES"] = work
    for rel in listed.stdout.decode().split("\0"):
        if rel and os.path.isfile(os.path.join(ROOT, rel)):
            os.makedirs(os.path.dirname(os.path.join(src, rel)), exist_ok=True)
            shutil.copy2(os.path.join(ROOT, rel), os.path.join(src, rel))
    check(sh(GIT, "-C", src, "rev-parse", quiet=True).returncode != 0, "the copy is inside a git repository")
    ok = sh(MESON, "setup", bld, src, "--buildtype=plain", "-Doptimization=0", "-Dmpi=disabled").returncode == 0
    check(ok and build(), "first build of the copy")
    rev_a = version()
    check(re.fullmatch(r"unknown-src-[0-9a-f]{12}", rev_a) is not None, "first build's revision %r" % rev_a)
    said = sh(sys.executable, os.path.join(src, "scripts", "build-revision"), src).stdout.strip()
    check(said == rev_a, "scripts/build-revision says %r, the build %r" % (said, rev_a))

    ens = os.path.join(work, "ens")
    p = sh(os.path.join(bld, "pdla"), "ensemble", "--clusters", "3", "--target", "1000", "--seed", "4", "-q",
           "--out", ens)
    check(p.returncode == 0, "ensemble by the first build")
    journal = os.path.join(ens, "clusters.journal")
    os.truncate(journal, os.path.getsize(journal) - 1)  # the last record torn: one cluster to grow again
    os.remove(os.path.join(ens, "ensemble.h5"))

    # One source changed: a new revision, and ninja picks it up.
    with open(os.path.join(src, "src", "core", "util.c"), "a") as f:
        f.write("/* a local change */\n")
    check(build(), "second build of the copy")
    rev_b = version()
    check(re.fullmatch(r"unknown-src-[0-9a-f]{12}", rev_b) is not None and rev_b != rev_a,
          "a changed source kept the revision: %r then %r" % (rev_a, rev_b))
    check(build() and version() == rev_b, "a build with nothing changed changed the revision")

    p = sh(os.path.join(bld, "pdla"), "ensemble", "--resume", ens, "-q")
    note = [ln for ln in p.stderr.splitlines() if "note:" in ln and "build" in ln]
    check(p.returncode == 0 and len(note) == 1 and rev_a in note[0] and rev_b in note[0],
          "resume by the second build: %d %r" % (p.returncode, p.stderr))
    with h5py.File(os.path.join(ens, "ensemble.h5"), "r") as f:
        b = f["ensemble"].attrs["builds"]
        builds = b.decode() if isinstance(b, bytes) else str(b)
    check(builds == rev_a + " " + rev_b, "/ensemble builds %r, want %r" % (builds, rev_a + " " + rev_b))
finally:
    shutil.rmtree(work, ignore_errors=True)

print("%s (%d failures)" % ("ok" if not failures else "FAILED", len(failures)))
sys.exit(1 if failures else 0)
