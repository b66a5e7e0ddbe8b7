#!/usr/bin/python3
"""ckpt_fallback.py PDLA SHIM WORKDIR - the DLA checkpoint generations after a
`--resume DIR` that fell back past a damaged checkpoint.h5 (README
"Checkpoints and resume", Files).

Before the fix the first write after such a resume hard-linked the damaged
checkpoint.h5 as checkpoint.1.h5 and the second kept it as checkpoint.2.h5,
having pushed out the checkpoint the run had resumed from, and the new file
took the damaged one's generation number. Checked here:

  - past a truncated checkpoint.h5, a checksum-damaged one (with a forged
    higher generation, which the next writes must pass) and both
    checkpoint.h5 and checkpoint.1.h5 damaged: after two more checkpoint
    writes every generation name present passes `pdla check`, the run's
    generations increase past every generation seen, the file resumed from
    is kept as the oldest, each damaged file is kept byte for byte as
    checkpoint.damaged.h5 and a second fallback's as checkpoint.damaged.2.h5
    (the first is not replaced);
  - a truncated file kept aside before a kill: the generation names still
    increase (its own number may be taken again: it no longer reads);
  - a file kept under both names by a crash inside the set-aside is kept
    once; no directory resume reads a kept file; the set-aside and each
    rename are followed by a directory sync (faultshim counts them);
  - a failed rename while the generations move: exit 1, one line, and the
    directory still resumes;
  - kill -9 (faultshim) before each rename of a checkpoint name in the
    resume and its first write, and at the directory sync after the
    set-aside: every generation name present passes `pdla check`, the
    damaged bytes are still in the directory once, and a plain resume then
    completes with every name sound and the generations past the damaged
    file's;
  - a --force run removes the older run's checkpoint.damaged*.h5;
  - a checkpoint FILE named in the directory (--resume D/checkpoint.1.h5,
    D/checkpoint.2.h5, a copy D/save.h5): damaged generation names ahead of
    it go aside and the generations move to the front as above (also under
    the kill -9 cases), a valid one ahead refuses the resume with one line,
    exit 2, the directory untouched;
  - DLCA (one checkpoint.h5): `--model dlca --resume D/save.h5` beside a
    valid checkpoint.h5 (newer or older, also with --out D --force), a DLA
    checkpoint or another model's file there: refused with one line, exit 2,
    D untouched (before session 31 the first write replaced it); past a
    truncated or empty one: kept aside as checkpoint.damaged.h5, the file
    named kept, the run ends with the straight run's monomers (and past one
    whose snapshots a directory resume refuses: aside too); checkpoint.h5
    named or hard-linked resumes as before; --out another directory needs
    --force (without: refused, kept; with: replaced).
  - event: a fallback's promotion, the promotion of checkpoint.prev.h5
    named, or the sync after a set-aside that fails (EIO) is one line, exit
    1 (2 before session 31), and the directory resumes after.
  - every model: a checkpoint name (DLA checkpoint.h5 or checkpoint.1.h5,
    event checkpoint.h5 or checkpoint.prev.h5, DLCA checkpoint.h5) that is
    a symbolic link, or a chain of two, to a file of its folder under a
    temporary name (.checkpoint.h5.tmp.1234), resumed as a directory or
    named: refused in one line, exit 2, the folder as it was (before, the
    sweep of leftovers removed the file: the event resume fell back to
    checkpoint.prev.h5, the DLA and DLCA resumes loaded through the link and
    then lost the file); a hard link under the name, or a link to another
    name, resumes; so does a DLCA resume into --out elsewhere (--force),
    whose sweep is that directory's, not the folder's. Also refused: such a
    name as a directory step (checkpoint.h5 -> .checkpoint.h5.new/real.h5,
    .checkpoint.h5.new a link to a folder; through "..", a subfolder's link
    or an absolute path), a chain of 46 links to a temporary name or a loop
    through one, a chain of 1002 links, a path that grows
    past 8191 bytes as it is followed, and a 600-byte relative link under a
    3900-byte run directory (the check passed each; the sweep removed the
    name and the link dangled), the folder and its subfolders untouched;
    and the run directory named through a temporary name of its own
    (D/.checkpoint.h5.new a link to ".", D/.cluster.h5.new/.. with that a
    link to a subfolder, also as a DLCA --out): the sweep removed the link
    and the writes after it failed (DLA, DLCA exit 1; event exit 2 with
    the link gone); a link to the run directory, or D/sub/.., resumes. A
    link named with a newline is named in the one line as \012. A link
    loop that meets no temporary name (junk -> junk, a -> b -> a, deep ->
    deep/x), the ensemble's too: resumes, the links kept (it was refused,
    "does not resolve within 40 links").
  - a new run's --out (--force) named through a temporary name of its
    own folder (D/.checkpoint.h5.new a link to "." or to D; a DLCA resume
    into --out elsewhere; the ensemble's ensemble.h5.tmp.7): refused in one
    line, exit 2, the folder as it was (the sweep removed the link and the
    run failed, exit 1); the same through a name of the older run's that
    --force removes (checkpoint.h5, checkpoint.prev.h5, summary.txt,
    checkpoint.damaged.h5; the ensemble's clusters.journal, ensemble.h5,
    ensemble.xdmf2); a real folder under the name is written into.
  - `pdla ensemble --resume`: clusters.journal a link to
    clusters.journal.tmp.5, or the folder named through its own
    ensemble.h5.tmp.7 (a link to "."): refused in one line, exit 2, the
    folder as it was (the sweep removed the journal); a plain resume goes on.
  - DLA: a run directory of 3900 bytes whose every generation is damaged:
    the one line names each generation file with its reason; the event
    model's checkpoint.h5 and checkpoint.prev.h5 likewise.
The pdla runs are counted and printed (211; about 3 s of CPU in release).
"""
import glob
import os
import resource
import re
import shutil
import subprocess
import sys

import h5py

from reliab_util import check, failures, run_faulted, runner, shim_preload

PDLA, SHIM, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
_pdla = runner(PDLA, 120)
runs = 0


def pdla(*args):
    global runs
    runs += 1
    return _pdla(*args)


def faulted(args, env):
    global runs
    runs += 1
    return run_faulted(PDLA, args, env)


NAMES = ["checkpoint.h5", "checkpoint.1.h5", "checkpoint.2.h5"]

shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
W = lambda *p: os.path.join(WORK, *p)


def generation(path):
    """The root's generation, or None where the file does not open."""
    try:
        with h5py.File(path, "r") as f:
            return int(f.attrs["generation"])
    except (OSError, KeyError):
        return None


def read(path):
    with open(path, "rb") as f:
        return f.read()


passed = set()  # the bytes of files `pdla check` passed: each is checked once


def sound(d, tag):
    """Every generation name in d passes `pdla check` (a checkpoint loaded and
    verified as --resume loads it: exit 0). The names present."""
    present = [n for n in NAMES if os.path.lexists(os.path.join(d, n))]
    for n in present:
        data = read(os.path.join(d, n))
        if data in passed:
            continue
        rc, err = pdla("check", os.path.join(d, n))
        check(rc == 0, "%s: %s does not pass pdla check (exit %s): %s" % (tag, n, rc, err.strip()[-300:]))
        if rc == 0:
            passed.add(data)
    return present


def truncate(path):
    os.truncate(path, os.path.getsize(path) // 2)


def flip_data(path, forged_generation=None):
    """A checksum error in /tree/chunks_packed (bytes of its first chunk
    inverted); the root, and a forged generation written there, still read."""
    with h5py.File(path, "r+") as f:
        if forged_generation is not None:
            f.attrs.modify("generation", forged_generation)
        d = f["/tree/chunks_packed"]
        off = d.id.get_chunk_info(0).byte_offset if d.chunks else d.id.get_offset()
    with open(path, "r+b") as f:
        f.seek(off + 16)
        b = f.read(8)
        f.seek(off + 16)
        f.write(bytes(x ^ 0xFF for x in b))


# The template: generations 2, 3, 4 (1000 particles each) in checkpoint.2.h5,
# checkpoint.1.h5, checkpoint.h5.
T = W("T")
rc, err = pdla("--target", "4000", "--out", T, "--checkpoint-particles", "1000", "-q")
check(rc == 0, "template run: %s" % err)
check([generation(os.path.join(T, n)) for n in NAMES] == [4, 3, 2], "template generations")


def fresh(name):
    d = W(name)
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(T, d)
    return d


def resume(d, target):
    """A bare resume: the schedule, every 1000 particles, is kept."""
    return pdla("--resume", d, "--target", str(target), "-q")


def after(d, tag, want_gens, kept):
    """d after its fallback resume and two writes: every name sound, the
    generations want_gens (newest first), kept {aside name: bytes}."""
    present = sound(d, tag)
    gens = [generation(os.path.join(d, n)) for n in present]
    check(gens == want_gens, "%s: generations %r, want %r" % (tag, gens, want_gens))
    for name, data in kept.items():
        p = os.path.join(d, name)
        check(os.path.exists(p) and read(p) == data, "%s: the damaged file is not kept as %s" % (tag, name))
    extra = sorted(set(os.path.basename(p) for p in glob.glob(os.path.join(d, "checkpoint.damaged*"))) - set(kept))
    check(not extra, "%s: unexpected kept files %r" % (tag, extra))


# --- a truncated checkpoint.h5 (generation 4, unreadable): resumed from
# generation 3 (3000 particles); the writes at 4000 and 5000 are 5 and 6,
# past the damaged one's place.
A = fresh("A")
truncate(os.path.join(A, "checkpoint.h5"))
badA = read(os.path.join(A, "checkpoint.h5"))
goodA = read(os.path.join(A, "checkpoint.1.h5"))
rc, err = resume(A, 5000)
check(rc == 0, "truncated: resume: %s" % err)
check("note: skipped %s/checkpoint.h5: damaged checkpoint (truncated); resuming from %s/checkpoint.1.h5" % (A, A) in err,
      "truncated: no fallback note: %s" % err)
check("note: %s/checkpoint.h5 set aside as %s/checkpoint.damaged.h5; %s/checkpoint.1.h5 is now %s/checkpoint.h5; "
      "the next checkpoint is generation 5" % (A, A, A, A) in err, "truncated: no set-aside note: %s" % err)
after(A, "truncated", [6, 5, 3], {"checkpoint.damaged.h5": badA})
check(read(os.path.join(A, "checkpoint.2.h5")) == goodA, "truncated: the checkpoint resumed from is not kept")

# --- then a checksum error in the new checkpoint.h5, whose (forged) root
# generation 40 still reads: the second fallback keeps it as
# checkpoint.damaged.2.h5 beside the first, and the writes go on from 41.
flip_data(os.path.join(A, "checkpoint.h5"), forged_generation=40)
badB = read(os.path.join(A, "checkpoint.h5"))
rc, err = resume(A, 6000)
check(rc == 0, "checksum: resume: %s" % err)
check("checksum or I/O error" in err and "set aside as %s/checkpoint.damaged.2.h5" % A in err and
      "the next checkpoint is generation 41" in err, "checksum: notes: %s" % err)
after(A, "checksum", [42, 41, 5], {"checkpoint.damaged.h5": badA, "checkpoint.damaged.2.h5": badB})

# --- both newer names damaged: resumed from checkpoint.2.h5 (generation 2);
# checkpoint.1.h5's root reads (3), checkpoint.h5's does not (its place: 4).
C = fresh("C")
truncate(os.path.join(C, "checkpoint.h5"))
flip_data(os.path.join(C, "checkpoint.1.h5"))
bad0, bad1 = read(os.path.join(C, "checkpoint.h5")), read(os.path.join(C, "checkpoint.1.h5"))
rc, err = resume(C, 4000)
check(rc == 0 and "resuming from %s/checkpoint.2.h5 (generation 2)" % C in err, "two damaged: resume: %s" % err)
after(C, "two damaged", [6, 5, 2], {"checkpoint.damaged.h5": bad0, "checkpoint.damaged.2.h5": bad1})

# --- a truncated file already kept aside (a kill between the set-aside and
# the first write) has no place any more: its number, 4, may be taken again
# (README), while the generation names still increase.
G = fresh("G")
truncate(os.path.join(G, "checkpoint.h5"))
os.rename(os.path.join(G, "checkpoint.h5"), os.path.join(G, "checkpoint.damaged.h5"))
rc, err = resume(G, 5000)
check(rc == 0, "kept before the kill: resume: %s" % err)
after(G, "kept before the kill", [5, 4, 3], {"checkpoint.damaged.h5": read(os.path.join(G, "checkpoint.damaged.h5"))})

# --- an intact checkpoint.h5 whose root generation is forged to 2^64 - 1:
# it loaded and the next write's generation wrapped to 0, so the next resume
# took the forged file (then checkpoint.2.h5) as the newest and went back.
# Now damaged (generations stop at 2^62 - 1): resumed from generation 3,
# the forged file kept aside, and the writes are 5, 6, 7.
H = fresh("H")
with h5py.File(os.path.join(H, "checkpoint.h5"), "r+") as f:
    f.attrs.modify("generation", 2**64 - 1)
badH = read(os.path.join(H, "checkpoint.h5"))
rc, err = resume(H, 6000)
check(rc == 0 and "root generation 18446744073709551615 out of range" in err and
      "the next checkpoint is generation 5" in err, "generation 2^64 - 1: %s %s" % (rc, err))
after(H, "generation 2^64 - 1", [7, 6, 5], {"checkpoint.damaged.h5": badH})

# --- the last generation there may be, 2^62 - 1 (forged): it loads, but the
# writes after it were 2^62 and on, which the loader takes as damaged, so
# the next resume set the run's own checkpoints aside and went back to the
# forged file. No later generation is written: exit 1, the names as they were.
H2 = fresh("H2")
with h5py.File(os.path.join(H2, "checkpoint.h5"), "r+") as f:
    f.attrs.modify("generation", 2**62 - 1)
beforeH2 = {n: read(os.path.join(H2, n)) for n in NAMES}
rc, err = resume(H2, 6000)
check(rc == 1 and "generation 4611686018427387903 is the last there may be" in err,
      "generation 2^62 - 1: exit %s: %s" % (rc, err))
check({n: read(os.path.join(H2, n)) for n in NAMES} == beforeH2 and
      not glob.glob(os.path.join(H2, "checkpoint.damaged*")), "generation 2^62 - 1: the names changed")
sound(H2, "generation 2^62 - 1")

# --- no resume of the directory reads a kept file: with only those left
# there is no checkpoint to resume.
os.mkdir(W("D"))
shutil.copy(os.path.join(C, "checkpoint.damaged.2.h5"), W("D", "checkpoint.damaged.h5"))
rc, err = pdla("--resume", W("D"), "-q")
check(rc == 2 and "no checkpoint in this directory" in err, "kept files only: exit %s: %s" % (rc, err))

# --- a --force run over it removes the kept files with the checkpoints.
rc, err = pdla("--target", "500", "--out", C, "--force", "-q")
check(rc == 0 and not glob.glob(os.path.join(C, "checkpoint*")), "--force: left %r" % os.listdir(C))

# --- the rename to the front fails (EIO): one line, exit 1; what moved stays
# moved and the directory resumes, numbering past the kept file's generation
# (4: its root reads), though no generation name holds it any more.
PRELOAD = shim_preload(PDLA, SHIM)


def dirsyncs(d):
    """Directory syncs of a resume of d to 4000 (one write), counted by faultshim."""
    n = W("count")
    rc, lines = faulted(["--resume", d, "--target", "4000", "-q"],
                        dict(os.environ, LD_PRELOAD=PRELOAD, FAULT_OP="dirsync", FAULT_COUNT=n))
    check(rc == 0, "counting %s: %r" % (d, lines))
    return int(read(n))


# --- the set-aside and each rename to the front are synced: three directory
# syncs more than a plain resume from the same file (3000 particles).
S = fresh("S")
flip_data(os.path.join(S, "checkpoint.h5"))
P = fresh("P")  # its cluster.h5 too: a first cluster.h5 is published with one sync fewer
shutil.copy(os.path.join(T, "checkpoint.1.h5"), os.path.join(P, "checkpoint.h5"))
shutil.copy(os.path.join(T, "checkpoint.2.h5"), os.path.join(P, "checkpoint.1.h5"))
os.unlink(os.path.join(P, "checkpoint.2.h5"))
ns, np_ = dirsyncs(S), dirsyncs(P)
check(ns == np_ + 3, "directory syncs: %d after a fallback, %d without" % (ns, np_))
# The shim counts the set-aside's renameat2 (RENAME_NOREPLACE) as rename #1
# (before session 33 it did not reach renameat2, so no fault hit it): failed,
# exit 1, the note and one line, and nothing moved.
E1 = fresh("E1")
flip_data(os.path.join(E1, "checkpoint.h5"))
beforeE1 = {n: read(os.path.join(E1, n)) for n in sorted(os.listdir(E1))}
env = dict(os.environ, LD_PRELOAD=PRELOAD, FAULT_OP="rename", FAULT_AT="1", FAULT_ERR="EIO")
rc, lines = faulted(["--resume", E1, "--target", "5000", "-q"], env)
check(rc == 1 and len(lines) == 2 and lines[-1] == "pdla: cannot resume: cannot set %s/checkpoint.h5 aside as "
      "%s/checkpoint.damaged.h5: Input/output error" % (E1, E1), "failed set-aside: exit %s: %r" % (rc, lines))
check({n: read(os.path.join(E1, n)) for n in sorted(os.listdir(E1))} == beforeE1, "failed set-aside: the folder changed")
rc, err = resume(E1, 5000)
check(rc == 0, "after the failed set-aside: %s" % err)
after(E1, "after the failed set-aside", [6, 5, 3], {"checkpoint.damaged.h5": beforeE1["checkpoint.h5"]})
# rename #2: the move of checkpoint.1.h5 to the front
env = dict(os.environ, LD_PRELOAD=PRELOAD, FAULT_OP="rename", FAULT_AT="2", FAULT_ERR="EIO")
E = fresh("E")
flip_data(os.path.join(E, "checkpoint.h5"))
badE = read(os.path.join(E, "checkpoint.h5"))
rc, lines = faulted(["--resume", E, "--target", "5000", "-q"], env)
check(rc == 1 and lines[-1:] == ["pdla: cannot resume: cannot rename %s/checkpoint.1.h5 to %s/checkpoint.h5: "
                                 "Input/output error" % (E, E)] and len(lines) == 2,
      "failed rename: exit %s: %r" % (rc, lines))
sound(E, "failed rename")
rc, err = resume(E, 5000)
check(rc == 0, "after the failed rename: %s" % err)
after(E, "after the failed rename", [6, 5, 3], {"checkpoint.damaged.h5": badE})


# --- a crash between the hard link and the unlink of the set-aside (its
# fallback where renameat2 RENAME_NOREPLACE is missing) leaves the damaged
# file under both names: the next fallback resume drops checkpoint.h5 and
# keeps the one file once, not again as checkpoint.damaged.2.h5.
L = fresh("L")
flip_data(os.path.join(L, "checkpoint.h5"))
badL = read(os.path.join(L, "checkpoint.h5"))
os.link(os.path.join(L, "checkpoint.h5"), os.path.join(L, "checkpoint.damaged.h5"))
rc, err = resume(L, 5000)
check(rc == 0, "linked twice: resume: %s" % err)
after(L, "linked twice", [6, 5, 3], {"checkpoint.damaged.h5": badL})

# --- kill -9 before each rename of a checkpoint name (the two to the front,
# then the first write's three) and before the directory sync that follows
# the set-aside (for kill -9 a sync changes nothing, so the renames' kills
# cover the other syncs); later writes are a plain rotation, which test
# checkpoint-kill covers. The damaged file's
# generation, 4, reads: no later write may take it, wherever the kill left
# the file. A kill past the last counted call lets the run end (exit 0).
def killed(op, last, path=None, name=None):
    """name: the resume names that file of the directory (--resume
    D/name), else the directory itself."""
    for k in range(1, last + 1):
        d = fresh("K")
        flip_data(os.path.join(d, "checkpoint.h5"))
        bad = read(os.path.join(d, "checkpoint.h5"))
        good = read(os.path.join(d, "checkpoint.1.h5"))  # the one resumed from
        env = dict(os.environ, LD_PRELOAD=PRELOAD, FAULT_OP=op, FAULT_AT=str(k), FAULT_SIGNAL="9")
        if path:
            env["FAULT_PATH"] = path
        before = {n: read(os.path.join(d, n)) for n in sorted(os.listdir(d))}
        rc, lines = faulted(["--resume", os.path.join(d, name) if name else d, "--target", "4000", "-q"], env)
        tag = "kill -9 at %s #%d%s" % (op, k, " (--resume D/%s)" % name if name else "")
        check(rc == -9, "%s: not killed (exit %s): %r" % (tag, rc, lines))
        # killed before the set-aside (rename #1): the folder as it was, the
        # damaged checkpoint.h5 still there for the next resume to skip
        untouched = {n: read(os.path.join(d, n)) for n in sorted(os.listdir(d))} == before
        check(untouched or bool(sound(d, tag)), "%s: no generation name left" % tag)
        kept = [p for p in glob.glob(os.path.join(d, "checkpoint*")) if read(p) == bad]
        check(len(kept) == 1, "%s: the damaged bytes are under %r" % (tag, kept))
        check(any(read(os.path.join(d, n)) == good for n in NAMES if os.path.exists(os.path.join(d, n))),
              "%s: the checkpoint resumed from is under no generation name" % tag)
        rc, err = resume(d, 5000)
        check(rc == 0, "%s: the resume after: %s" % (tag, err))
        present = sound(d, tag + ", resumed")
        gens = [generation(os.path.join(d, n)) for n in present]
        check(None not in gens and gens == sorted(gens, reverse=True) and gens[0] >= 6 and
              all(g in (2, 3) or g > 4 for g in gens), "%s, resumed: generations %r" % (tag, gens))


killed("rename", 6, "/checkpoint")
killed("dirsync", 1)


# --- a checkpoint FILE named inside the run directory (--resume
# D/checkpoint.1.h5): its resume writes into D's generations as well, so
# the generation names ahead of the file are verified as a directory resume
# verifies them. Damaged ones go aside and the file and the older names
# move to the front, as after a directory's fallback (before session 31 the
# folder was left as it was: the writes rotated the damaged checkpoint.h5
# into the generations, as checkpoint.1.h5 then checkpoint.2.h5, pushed out
# the file resumed from and numbered past it, not past the damaged one).
# A valid one ahead refuses the resume with one line naming it and the two
# ways on, exit 2, the directory untouched: the writes would rotate it out.
def named(d, name, target):
    return pdla("--resume", os.path.join(d, name), "--target", str(target), "-q")


def snapshot(d):
    return {n: read(os.path.join(d, n)) for n in sorted(os.listdir(d))}


N = fresh("N1")
truncate(os.path.join(N, "checkpoint.h5"))
badN, goodN = read(os.path.join(N, "checkpoint.h5")), read(os.path.join(N, "checkpoint.1.h5"))
rc, err = named(N, "checkpoint.1.h5", 5000)
check(rc == 0, "named .1 past a truncated checkpoint.h5: resume: %s" % err)
check("note: skipped %s/checkpoint.h5: damaged checkpoint (truncated); resuming from %s/checkpoint.1.h5 "
      "(generation 3)" % (N, N) in err and
      "note: %s/checkpoint.h5 set aside as %s/checkpoint.damaged.h5; %s/checkpoint.1.h5 is now %s/checkpoint.h5; "
      "the next checkpoint is generation 5" % (N, N, N, N) in err, "named .1: notes: %s" % err)
after(N, "named .1", [6, 5, 3], {"checkpoint.damaged.h5": badN})
check(read(os.path.join(N, "checkpoint.2.h5")) == goodN, "named .1: the checkpoint resumed from is not kept")

# both newer names damaged, checkpoint.2.h5 named
N = fresh("N2")
truncate(os.path.join(N, "checkpoint.h5"))
flip_data(os.path.join(N, "checkpoint.1.h5"))
bad0, bad1 = read(os.path.join(N, "checkpoint.h5")), read(os.path.join(N, "checkpoint.1.h5"))
rc, err = named(N, "checkpoint.2.h5", 4000)
check(rc == 0 and "resuming from %s/checkpoint.2.h5 (generation 2)" % N in err, "named .2: resume: %s" % err)
after(N, "named .2", [6, 5, 2], {"checkpoint.damaged.h5": bad0, "checkpoint.damaged.2.h5": bad1})


def refused(d, name, ahead, newer):
    before = snapshot(d)
    rc, err = named(d, name, 6000)
    want = ("pdla: cannot resume: %s/%s: %s/%s is a %svalid checkpoint (generation %d, %d particles) that the "
            "checkpoints of this resume would rotate out; resume the newest with --resume %s, or move %s/%s out of "
            "%s to go on from %s/%s" % (d, name, d, ahead, "newer " if newer else "",
                                        generation(os.path.join(d, ahead)), 1000 * generation(os.path.join(d, ahead)),
                                        d, d, ahead, d, d, name))
    check(rc == 2 and err.strip() == want, "named %s behind a valid %s: exit %s: %r" % (name, ahead, rc, err))
    check(snapshot(d) == before, "named %s behind a valid %s: the directory changed" % (name, ahead))


# a valid newer generation ahead: refused, whether the one between is damaged
N = fresh("N3")
refused(N, "checkpoint.1.h5", "checkpoint.h5", True)
refused(N, "checkpoint.2.h5", "checkpoint.h5", True)
flip_data(os.path.join(N, "checkpoint.h5"))
refused(N, "checkpoint.2.h5", "checkpoint.1.h5", True)

# a file under another name (a copy of generation 3): every generation name
# is ahead of it; a valid one, even an older one, refuses the resume (the
# writes would rotate it out), damaged ones go aside, and the file stays
N = fresh("N4")
shutil.copy(os.path.join(N, "checkpoint.1.h5"), os.path.join(N, "save.h5"))
saveN = read(os.path.join(N, "save.h5"))
os.unlink(os.path.join(N, "checkpoint.h5"))
os.unlink(os.path.join(N, "checkpoint.1.h5"))
refused(N, "save.h5", "checkpoint.2.h5", False)
flip_data(os.path.join(N, "checkpoint.2.h5"), forged_generation=9)
badN = read(os.path.join(N, "checkpoint.2.h5"))
rc, err = named(N, "save.h5", 5000)
check(rc == 0 and "note: %s/checkpoint.2.h5 set aside as %s/checkpoint.damaged.h5; the next checkpoint is "
      "generation 10" % (N, N) in err, "named save.h5: resume: %s" % err)
after(N, "named save.h5", [11, 10], {"checkpoint.damaged.h5": badN})
check(read(os.path.join(N, "save.h5")) == saveN, "named save.h5: the file named changed")

# checkpoint.h5 named, all sound: as a directory resume
N = fresh("N5")
rc, err = named(N, "checkpoint.h5", 6000)
check(rc == 0 and not err.strip(), "named checkpoint.h5: %s" % err)
after(N, "named checkpoint.h5", [6, 5, 4], {})

killed("rename", 6, "/checkpoint", "checkpoint.1.h5")
killed("dirsync", 1, None, "checkpoint.1.h5")



# --- DLCA (one checkpoint.h5, no generations): --resume D/save.h5, a copy
# in the run directory D, writes D/checkpoint.h5, so that name is loaded
# first, as `--resume D` loads it (session 31; before, the first write
# replaced a newer valid checkpoint.h5 silently: its 5000 attempts by the
# 3000 of the copy). A valid one refuses the resume with one line, exit 2,
# D untouched, whether or not --out names D (--force there changes
# nothing: a resume in its own folder always writes there); so does another
# model's file there. A damaged one goes aside, kept byte for byte, and the
# run ends as one never stopped. checkpoint.h5 named itself, or a hard link
# of it, is the normal resume; --out into another directory still needs
# --force, which replaces that directory's run (session 30).
DLCA = ["--model", "dlca", "--box", "64x48", "--fill", "0.05", "--seed", "3"]


def dlca_run(d, attempts):
    """The run to `attempts` into d; its summary's "t = T; clusters N"."""
    p = subprocess.run([PDLA] + DLCA + ["--max-attempts", str(attempts), "--out", d, "--checkpoint", "--force"],
                       capture_output=True, text=True, timeout=120)
    m = re.search(r"; t = (\S+); clusters (\d+);", p.stdout)
    check(p.returncode == 0 and m, "dlca run to %d attempts: %s" % (attempts, p.stderr))
    return "t = %s, %s clusters" % m.groups() if m else "?"


def dlca_resume(path, attempts, *more):
    return pdla("--model", "dlca", "--resume", path, "--max-attempts", str(attempts), "-q", *more)


def sites(d):
    """The monomers' sites and the last series row's attempts (a resumed run
    has one row more than the straight run: its first stop's, README DLCA)."""
    with h5py.File(os.path.join(d, "cluster.h5"), "r") as f:
        return f["/monomers/site"][()].tolist(), int(f["/series/attempts"][-1])


C3, C5, C6 = W("dlca3"), W("dlca5"), W("dlca6")
dlca_run(C3, 3000)
at5 = dlca_run(C5, 5000)
dlca_run(C6, 6000)


def dlca_dir(name, ahead):
    """A run directory holding save.h5 (the 3000-attempt checkpoint) and,
    as checkpoint.h5, a copy of `ahead` (None: none)."""
    d = W(name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    shutil.copy(os.path.join(C3, "checkpoint.h5"), os.path.join(d, "save.h5"))
    if ahead:
        shutil.copy(ahead, os.path.join(d, "checkpoint.h5"))
    return d


def dlca_refused(d, what, way, *more):
    before = snapshot(d)
    rc, err = dlca_resume(os.path.join(d, "save.h5"), 6000, *more)
    want = ("pdla: cannot resume: %s/save.h5: %s/checkpoint.h5 is %s that the checkpoints of this resume would "
            "replace; %smove %s/checkpoint.h5 out of %s to go on from %s/save.h5" % (d, d, what, way, d, d, d))
    check(rc == 2 and err.strip() == want, "dlca save.h5 %s behind %s: exit %s: %r" % (more, what, rc, err))
    check(snapshot(d) == before, "dlca save.h5 %s behind %s: the directory changed" % (more, what))


# the fault: a newer valid checkpoint.h5 (5000 attempts) beside the copy
Dv = dlca_dir("dlca-valid", os.path.join(C5, "checkpoint.h5"))
valid5 = "a valid checkpoint (5000 attempts, %s)" % at5
dlca_refused(Dv, valid5, "resume it with --resume %s, or " % Dv)
dlca_refused(Dv, valid5, "resume it with --resume %s, or " % Dv, "--out", Dv + "/", "--force")
# an older valid one refuses too (what it would replace is the user's to move)
Do = dlca_dir("dlca-older", os.path.join(C3, "checkpoint.h5"))
shutil.copy(os.path.join(C5, "checkpoint.h5"), os.path.join(Do, "save.h5"))
before = snapshot(Do)
rc, err = dlca_resume(os.path.join(Do, "save.h5"), 6000)
check(rc == 2 and "checkpoint.h5 is a valid checkpoint (3000 attempts" in err and snapshot(Do) == before,
      "dlca save.h5 (5000) beside an older valid checkpoint.h5: exit %s: %r" % (rc, err))
# another model's checkpoint there: a DLA one (no model attribute) and an
# event one's model attribute
Dd = dlca_dir("dlca-dla", os.path.join(T, "checkpoint.h5"))
dlca_refused(Dd, "a DLA checkpoint (generation 4, 4000 particles)", "")
Dm = dlca_dir("dlca-model", None)
with h5py.File(os.path.join(Dm, "checkpoint.h5"), "w") as f:
    f.attrs["model"] = b"event-checkpoint"
dlca_refused(Dm, "another model's file (model 'event-checkpoint')", "")

# a damaged checkpoint.h5 (truncated): kept aside, the run goes on from the
# copy and ends as the straight run to 6000
for name, damage in (("dlca-trunc", truncate), ("dlca-empty", lambda p: os.truncate(p, 0))):
    Dt = dlca_dir(name, os.path.join(C5, "checkpoint.h5"))
    damage(os.path.join(Dt, "checkpoint.h5"))
    bad, save = read(os.path.join(Dt, "checkpoint.h5")), read(os.path.join(Dt, "save.h5"))
    rc, err = dlca_resume(os.path.join(Dt, "save.h5"), 6000)
    check(rc == 0 and "pdla: note: skipped %s/checkpoint.h5: damaged checkpoint (" % Dt in err and
          "resuming from %s/save.h5\npdla: note: %s/checkpoint.h5 set aside as %s/checkpoint.damaged.h5" % (Dt, Dt, Dt)
          in err, "dlca %s: resume: exit %s: %r" % (name, rc, err))
    check(os.path.exists(os.path.join(Dt, "checkpoint.damaged.h5")) and
          read(os.path.join(Dt, "checkpoint.damaged.h5")) == bad, "dlca %s: the damaged bytes not kept" % name)
    check(read(os.path.join(Dt, "save.h5")) == save, "dlca %s: the file named changed" % name)
    rc, err = pdla("check", os.path.join(Dt, "checkpoint.h5"))
    check(rc == 0, "dlca %s: the new checkpoint.h5 does not pass pdla check: %s" % (name, err.strip()[-300:]))
    check(sites(Dt) == sites(C6), "dlca %s: not the straight run's monomers" % name)

# snapshots a directory resume refuses (the state sound): damaged too
Ds = W("dlca-snaps")
shutil.rmtree(Ds, ignore_errors=True)
rc, err = pdla(*DLCA, "--max-attempts", "3000", "--out", Ds, "--checkpoint", "--snapshot-every", "50", "-q")
shutil.copy(os.path.join(Ds, "checkpoint.h5"), os.path.join(Ds, "save.h5"))
rc2, err2 = dlca_resume(Ds, 5000)
check(rc == 0 and rc2 == 0, "dlca snapshots runs: %r %r" % (err, err2))
with h5py.File(os.path.join(Ds, "checkpoint.h5"), "r+") as f:
    f["snapshots"].attrs.modify("count", 1000)
rc, err = dlca_resume(os.path.join(Ds, "save.h5"), 6000)
check(rc == 0 and "pdla: note: skipped %s/checkpoint.h5: damaged checkpoint (cannot read the snapshots of "
      "%s/checkpoint.h5: /snapshots count 1000, but it holds " % (Ds, Ds) in err and
      os.path.exists(os.path.join(Ds, "checkpoint.damaged.h5")), "dlca forged snapshots: exit %s: %r" % (rc, err))

# the normal resume: checkpoint.h5 named, or a hard link of it
for how in ("named", "link"):
    Dn = dlca_dir("dlca-" + how, os.path.join(C5, "checkpoint.h5"))
    path = os.path.join(Dn, "checkpoint.h5")
    if how == "link":
        os.unlink(os.path.join(Dn, "save.h5"))
        os.link(path, os.path.join(Dn, "save.h5"))
        path = os.path.join(Dn, "save.h5")
    rc, err = dlca_resume(path, 6000)
    check(rc == 0 and not err.strip() and sites(Dn) == sites(C6), "dlca %s checkpoint.h5: %s: %r" % (how, rc, err))

# --out another directory: refused without --force (its checkpoint kept),
# replaced with it (session 30)
Dx = dlca_dir("dlca-out", os.path.join(C5, "checkpoint.h5"))
O = W("dlca-other")
shutil.rmtree(O, ignore_errors=True)
shutil.copytree(C5, O)
before = snapshot(O)
rc, err = dlca_resume(os.path.join(Dx, "save.h5"), 6000, "--out", O)
check(rc == 2 and err.strip() == "pdla: run directory '%s' already exists (use --force to write into it)" % O and
      snapshot(O) == before, "dlca --out another directory without --force: exit %s: %r" % (rc, err))
rc, err = dlca_resume(os.path.join(Dx, "save.h5"), 6000, "--out", O, "--force")
check(rc == 0 and sites(O) == sites(C6), "dlca --out another directory --force: exit %s: %r" % (rc, err))

# --- event: a set-aside or promotion that fails for the disk (EIO) is one
# line and exit 1, as the DLA recovery's (README, Limits: 2 is for bad use);
# until session 31 the event command exited 2 there. The directory still
# resumes afterwards.
EV = ["--model", "event", "--dim", "2", "--particles", "2000", "--packing", "0.2", "--seed-radius", "1", "--seed", "3"]


def event_dir(name):
    d = W(name)
    shutil.rmtree(d, ignore_errors=True)
    rc, err = pdla(*EV, "--t-max", "4", "--checkpoint", "--out", d)
    rc2, err2 = pdla("--model", "event", "--resume", d, "--t-max", "6")
    check(rc == 0 and rc2 == 0, "event run %s: %r %r" % (name, err, err2))
    truncate(os.path.join(d, "checkpoint.h5"))
    return d


for name, op, what, last in (("ev-dir", "rename", None, "cannot make %s/checkpoint.prev.h5 the current checkpoint"),
                             ("ev-prev", "rename", "checkpoint.prev.h5",
                              "cannot make %s/checkpoint.prev.h5 the current checkpoint"),
                             ("ev-save", "dirsync", "save.h5", "cannot sync directory %s")):
    d = event_dir(name)
    if what == "save.h5":
        shutil.copy(os.path.join(d, "checkpoint.prev.h5"), os.path.join(d, what))
        os.unlink(os.path.join(d, "checkpoint.prev.h5"))
    # rename #1 is the set-aside (renameat2), which succeeds; the fault hits
    # what follows it
    at = "2" if op == "rename" else "1"
    env = dict(os.environ, LD_PRELOAD=PRELOAD, FAULT_OP=op, FAULT_AT=at, FAULT_STICKY="1", FAULT_ERR="EIO")
    rc, lines = faulted(["--model", "event", "--resume", os.path.join(d, what) if what else d, "--t-max", "8"], env)
    check(rc == 1 and len(lines) >= 1 and lines[-1].startswith("pdla: ") and (last % d) in lines[-1] and
          lines[-1].endswith("Input/output error"), "%s: failed %s: exit %s: %r" % (name, op, rc, lines))
    rc, err = pdla("--model", "event", "--resume", os.path.join(d, what) if what else d, "--t-max", "8")
    check(rc == 0, "%s: the resume after the failed %s: exit %s: %r" % (name, op, rc, err))

# --- a directory (with a file in it) under the name checkpoint.h5 is the
# user's, not a damaged write: the DLA, event and DLCA resumes each refuse
# in one line, exit 2, and leave the folder as it was (the DLA and event
# recoveries renamed it aside as checkpoint.damaged.h5 and fell back).


def dir_in_place(d, tag, *args, name="checkpoint.h5"):
    os.replace(os.path.join(d, name), os.path.join(d, "moved.h5"))
    os.mkdir(os.path.join(d, name))
    with open(os.path.join(d, name, "notes.txt"), "w") as f:
        f.write("mine\n")
    before = sorted(os.listdir(d))
    rc, err = pdla(*args)
    lines = err.strip().split("\n")
    check(rc == 2 and len(lines) == 1 and name in lines[0] and "directory" in lines[0],
          "%s: a directory %s: exit %s: %r" % (tag, name, rc, err))
    check(sorted(os.listdir(d)) == before and os.path.exists(os.path.join(d, name, "notes.txt")),
          "%s: the folder changed: %r" % (tag, sorted(os.listdir(d))))


J = fresh("J")
dir_in_place(J, "DLA", "--resume", J, "--target", "5000", "-q")
Je = W("Je")
shutil.rmtree(Je, ignore_errors=True)
rc, err = pdla(*EV, "--t-max", "4", "--checkpoint", "--out", Je)
rc2, err2 = pdla("--model", "event", "--resume", Je, "--t-max", "6")
check(rc == 0 and rc2 == 0, "event run Je: %r %r" % (err, err2))
dir_in_place(Je, "event", "--model", "event", "--resume", Je, "--t-max", "8")
Jd = W("Jd")
shutil.rmtree(Jd, ignore_errors=True)
dlca_run(Jd, 20000)
dir_in_place(Jd, "DLCA", "--model", "dlca", "--resume", Jd, "--max-attempts", "40000")

# --- the same under an older generation name, behind the one that loads:
# the rotation of the resume's writes renamed the DLA directory
# checkpoint.1.h5 to checkpoint.2.h5 and then failed at every write, and
# the event write failed to remove a directory checkpoint.prev.h5, each
# after the whole run (exit 1). Refused before, in one line, exit 2.
K = fresh("K")
dir_in_place(K, "DLA, older name", "--resume", K, "--target", "5000", "-q", name="checkpoint.1.h5")
K2 = fresh("K2")
dir_in_place(K2, "DLA, file named", "--resume", os.path.join(K2, "checkpoint.h5"), "--target", "5000", "-q",
             name="checkpoint.2.h5")
Ke = W("Ke")
shutil.rmtree(Ke, ignore_errors=True)
rc, err = pdla(*EV, "--t-max", "4", "--checkpoint", "--out", Ke)
rc2, err2 = pdla("--model", "event", "--resume", Ke, "--t-max", "6")
check(rc == 0 and rc2 == 0, "event run Ke: %r %r" % (err, err2))
dir_in_place(Ke, "event, previous name", "--model", "event", "--resume", Ke, "--t-max", "8",
             name="checkpoint.prev.h5")

# --- a DLA checkpoint copied under a name the sweep of leftovers removes
# (.cluster.h5.new, cluster.h5.tmp.PID), named by --resume: it loaded, and
# the sweep then removed the file named (a kill before the first checkpoint
# lost it). Refused in one line, exit 2, and kept.
L = W("L")
shutil.rmtree(L, ignore_errors=True)
os.makedirs(L)
for n in (".cluster.h5.new", "cluster.h5.tmp.77"):
    shutil.copy(os.path.join(T, "checkpoint.h5"), os.path.join(L, n))
    rc, err = pdla("--resume", os.path.join(L, n), "--target", "5000", "-q")
    check(rc == 2 and len(err.strip().split("\n")) == 1 and "unfinished temporary file" in err,
          "DLA resume from %s: exit %s: %r" % (n, rc, err))
    check(sorted(os.listdir(L)) == [n], "DLA resume from %s: the folder changed: %r" % (n, sorted(os.listdir(L))))
    os.remove(os.path.join(L, n))

# --- every generation unusable in a run directory with a long path (up to
# the 4000 bytes a run directory may have): the one line names each
# generation file with its reason (it was cut at 1023 bytes, the CLI's
# buffer, so past a run directory of about 330 bytes the oldest
# generation went unnamed; each reason at 1023, the library's)
LD = W("long")
shutil.rmtree(LD, ignore_errors=True)
while len(LD) < 3900:
    LD = os.path.join(LD, "d" * min(200, 3900 - len(LD)))
shutil.copytree(T, LD)
for n in NAMES:
    truncate(os.path.join(LD, n))
rc, err = resume(LD, 5000)
lines = err.strip().split("\n")
check(rc == 2 and len(lines) == 1 and all("%s/%s: damaged checkpoint" % (LD, n) in lines[0] for n in NAMES),
      "long run directory, every generation truncated: exit %s, %d lines, names %r" % (
          rc, len(lines), [n for n in NAMES if "%s/%s: " % (LD, n) in err]))
shutil.rmtree(W("long"))
# The same for the event model: checkpoint.h5 and checkpoint.prev.h5 both
# damaged under a run directory of 3900 bytes (each reason was held in 600
# bytes, so past ~580 bytes neither was named whole).
LE = W("long-ev")
shutil.rmtree(LE, ignore_errors=True)
while len(LE) < 3900:
    LE = os.path.join(LE, "e" * min(200, 3900 - len(LE)))
rc, err = pdla(*EV, "--t-max", "4", "--checkpoint", "--out", LE)
rc2, err2 = pdla("--model", "event", "--resume", LE, "--t-max", "6")
check(rc == 0 and rc2 == 0, "long event run directory: %r %r" % (err, err2))
for n in ("checkpoint.h5", "checkpoint.prev.h5"):
    truncate(os.path.join(LE, n))
rc, err = pdla("--model", "event", "--resume", LE, "--t-max", "8")
lines = err.strip().split("\n")
check(rc == 2 and len(lines) == 1 and all("%s/%s: " % (LE, n) in lines[0] for n in ("checkpoint.h5", "checkpoint.prev.h5")),
      "long event run directory, both checkpoints truncated: exit %s, %d lines, %r" % (rc, len(lines), err[-300:]))
shutil.rmtree(W("long-ev"))

# --- a checkpoint name that is a symbolic link to a file of its folder
# under a temporary name (checkpoint.h5 -> .checkpoint.h5.tmp.1234): the
# resume's sweep of leftovers removed the file and the link dangled. The
# event resume then fell back to checkpoint.prev.h5 and set the dangling
# link aside; the DLA and DLCA resumes loaded through the link, then the
# sweep removed the file (a kill before the first write lost it). Every
# model refuses in one line, exit 2, the folder as it was (links and
# bytes); a hard link under the name, and a link to another name, resume.
def linked(d):
    """d's names: each link's target, each file's bytes."""
    return {n: ("->", os.readlink(os.path.join(d, n))) if os.path.islink(os.path.join(d, n))
            else read(os.path.join(d, n)) for n in sorted(os.listdir(d))}


def temp_link(d, name, tag, args, chain=False):
    """name in d moved to a temporary name and linked to it (chain: through
    mine.h5), then --resume with args; d then made again as it was."""
    shutil.rmtree(d + ".0", ignore_errors=True)
    shutil.copytree(d, d + ".0")
    tmp = os.path.join(d, ".checkpoint.h5.tmp.1234")
    os.replace(os.path.join(d, name), tmp)
    via = os.path.join(d, "mine.h5")
    if chain:
        os.symlink(".checkpoint.h5.tmp.1234", via)
    os.symlink("mine.h5" if chain else ".checkpoint.h5.tmp.1234", os.path.join(d, name))
    before = linked(d)
    rc, err = pdla(*args)
    lines = err.strip().split("\n")
    want = "pdla: cannot resume: %s/%s is a symbolic link to %s, a temporary name" % (
        d, "mine.h5" if chain else name, tmp)
    check(rc == 2 and len(lines) == 1 and lines[0].startswith(want),
          "%s: %s linked to a temporary name: exit %s: %r" % (tag, name, rc, err))
    check(linked(d) == before, "%s: %s linked to a temporary name: the folder changed: %r"
          % (tag, name, sorted(os.listdir(d))))
    shutil.rmtree(d)
    os.replace(d + ".0", d)


Q = fresh("Q")
temp_link(Q, "checkpoint.h5", "DLA", ("--resume", Q, "--target", "5000", "-q"))
temp_link(Q, "checkpoint.1.h5", "DLA, older name", ("--resume", Q, "--target", "5000", "-q"))
temp_link(Q, "checkpoint.h5", "DLA, link named", ("--resume", os.path.join(Q, "checkpoint.h5"), "--target", "5000",
                                                  "-q"))
temp_link(Q, "checkpoint.h5", "DLA, chain", ("--resume", Q, "--target", "5000", "-q"), chain=True)
Qe = event_dir("Qe")
os.replace(os.path.join(Qe, "checkpoint.prev.h5"), os.path.join(Qe, "checkpoint.h5"))
rc, err = pdla("--model", "event", "--resume", Qe, "--t-max", "6")
check(rc == 0, "event run Qe: %r" % err)
EVR = ("--model", "event", "--resume", Qe, "--t-max", "8")
temp_link(Qe, "checkpoint.h5", "event", EVR)
temp_link(Qe, "checkpoint.prev.h5", "event, previous name", EVR)
temp_link(Qe, "checkpoint.h5", "event, chain", EVR, chain=True)
temp_link(Qe, "checkpoint.h5", "event, previous named",
          ("--model", "event", "--resume", os.path.join(Qe, "checkpoint.prev.h5"), "--t-max", "8"))
Qd = W("Qd")
dlca_run(Qd, 3000)
temp_link(Qd, "checkpoint.h5", "DLCA", ("--model", "dlca", "--resume", Qd, "--max-attempts", "6000", "-q"))
temp_link(Qd, "checkpoint.h5", "DLCA, link named",
          ("--model", "dlca", "--resume", os.path.join(Qd, "checkpoint.h5"), "--max-attempts", "6000", "-q"))
# --- links the check above let through (session 35). A temporary name as a
# directory step: the sweep unlinks .checkpoint.h5.new, a link to a folder,
# and checkpoint.h5 -> .checkpoint.h5.new/real.h5 (or ./.checkpoint.h5.new
# /../mine.h5, or sub/d/real.h5 with sub/d -> ../.checkpoint.h5.new, or the
# same by an absolute path) dangles; only the last name was looked at. A
# chain of more than 40 links (to a temporary name, or a loop): the check
# stopped at 40 and passed it, and the sweep removed the temporary file at
# its end. A relative target followed under a run directory of 3900 bytes:
# the joined path outgrew its 4400 bytes and the link was passed (the sweep
# removed the file). And a link whose path outgrows what the check holds
# (8191 bytes as it is followed): passed unchecked, now refused. Each is
# refused in one line, exit 2, the folder (links, files, subfolders) as it
# was, in every model.
def tree(d):
    """d's names, subfolders' too: each link's target, each file's bytes."""
    out = {}
    for root, dirs, files in os.walk(d):
        for n in dirs + files:
            p = os.path.join(root, n)
            out[os.path.relpath(p, d)] = (("->", os.readlink(p)) if os.path.islink(p) else
                                          "dir" if os.path.isdir(p) else read(p))
    return out


def moved(d, to):
    """checkpoint.h5 of d moved to d/to (its folder made)."""
    os.makedirs(os.path.dirname(os.path.join(d, to)), exist_ok=True)
    os.replace(os.path.join(d, "checkpoint.h5"), os.path.join(d, to))


def step_link(d):
    moved(d, "sub/real.h5")
    os.symlink("sub", os.path.join(d, ".checkpoint.h5.new"))
    os.symlink(".checkpoint.h5.new/real.h5", os.path.join(d, "checkpoint.h5"))


def dotdot_link(d):
    moved(d, "mine.h5")
    os.mkdir(os.path.join(d, "sub"))
    os.symlink("sub", os.path.join(d, ".checkpoint.h5.new"))
    os.symlink("./.checkpoint.h5.new/../mine.h5", os.path.join(d, "checkpoint.h5"))


def nested_link(d):
    moved(d, "sub2/real.h5")
    os.mkdir(os.path.join(d, "sub"))
    os.symlink("../.checkpoint.h5.new", os.path.join(d, "sub", "d"))
    os.symlink("sub2", os.path.join(d, ".checkpoint.h5.new"))
    os.symlink("sub/d/real.h5", os.path.join(d, "checkpoint.h5"))


def absolute_link(d):
    moved(d, "sub/real.h5")
    os.symlink("sub", os.path.join(d, ".checkpoint.h5.new"))
    os.symlink(os.path.join(os.path.abspath(d), ".checkpoint.h5.new", "real.h5"), os.path.join(d, "checkpoint.h5"))


def chain_link(d):
    """checkpoint.h5 -> chain/l0 -> ... -> chain/l44 -> ../.checkpoint.h5.tmp.1234: 46 links."""
    moved(d, ".checkpoint.h5.tmp.1234")
    os.mkdir(os.path.join(d, "chain"))
    for i in range(45):
        os.symlink("l%d" % (i + 1) if i < 44 else "../.checkpoint.h5.tmp.1234", os.path.join(d, "chain", "l%d" % i))
    os.symlink("chain/l0", os.path.join(d, "checkpoint.h5"))


def loop_link(d):
    """checkpoint.h5 -> loop/a -> b -> ../.checkpoint.h5.new/a, .checkpoint.h5.new -> loop: a loop (the
    kernel fails, ELOOP) through a temporary name, refused where the walk meets the name (an unrelated
    loop, one that meets none, resumes: below)."""
    moved(d, "mine.h5")
    os.mkdir(os.path.join(d, "loop"))
    os.symlink("loop", os.path.join(d, ".checkpoint.h5.new"))
    os.symlink("b", os.path.join(d, "loop", "a"))
    os.symlink("../.checkpoint.h5.new/a", os.path.join(d, "loop", "b"))
    os.symlink("loop/a", os.path.join(d, "checkpoint.h5"))


def long_chain_link(d):
    """checkpoint.h5 -> chain/l0 -> ... -> chain/l1000 -> ../mine.h5: 1002 links, no loop."""
    moved(d, "mine.h5")
    os.mkdir(os.path.join(d, "chain"))
    for i in range(1001):
        os.symlink("l%d" % (i + 1) if i < 1000 else "../mine.h5", os.path.join(d, "chain", "l%d" % i))
    os.symlink("chain/l0", os.path.join(d, "checkpoint.h5"))


def long_target_link(d):
    moved(d, ".checkpoint.h5.tmp.1234")
    os.symlink("./" * 300 + ".checkpoint.h5.tmp.1234", os.path.join(d, "checkpoint.h5"))


def grown_link(d):
    """checkpoint.h5 -> L/b/././.../mine.h5, L/b -> a/././..., L/a -> ./././../..:
    each target under 4096 bytes, the kernel resolves it to mine.h5; followed,
    the path held grows past 12000 bytes."""
    moved(d, "mine.h5")
    os.mkdir(os.path.join(d, "L"))
    os.symlink("./" * 2045 + "..", os.path.join(d, "L", "a"))
    os.symlink("a/" + "./" * 2040 + ".", os.path.join(d, "L", "b"))
    os.symlink("L/b/" + "./" * 2040 + "mine.h5", os.path.join(d, "checkpoint.h5"))


THROUGH = "pdla: cannot resume: %(d)s/checkpoint.h5 is a symbolic link through %(d)s/.checkpoint.h5.new, a temporary name"
TO_TMP = "pdla: cannot resume: %(d)s/checkpoint.h5 is a symbolic link to %(d)s/.checkpoint.h5.tmp.1234, a temporary name"
HOPS = "pdla: cannot resume: %(d)s/checkpoint.h5 is a symbolic link that does not end within 1000 links"
GROWN = "pdla: cannot resume: %(d)s/checkpoint.h5 is a symbolic link whose path grows past 8191 bytes"
LINK_CASES = (("a temporary name as a directory step", step_link, THROUGH),
              ("through ./.checkpoint.h5.new/..", dotdot_link, THROUGH),
              ("through a link of a subfolder to a temporary name", nested_link, THROUGH),
              ("an absolute path through a temporary name", absolute_link, THROUGH),
              ("a chain of 46 links to a temporary name", chain_link, TO_TMP),
              ("a loop through a temporary name", loop_link, THROUGH),
              ("a chain of 1002 links", long_chain_link, HOPS),
              ("a path outgrowing 8191 bytes", grown_link, GROWN))


def link_refused(d, tag, args, make, want):
    """make(d) run on d, then the resume args(d): refused with want, d as
    it was; d then made again as it was."""
    shutil.rmtree(d + ".0", ignore_errors=True)
    shutil.copytree(d, d + ".0", symlinks=True)
    make(d)
    before = tree(d)
    rc, err = pdla(*args(d))
    lines = err.strip().split("\n")
    check(rc == 2 and len(lines) == 1 and lines[0].startswith(want % {"d": d}),
          "%s: exit %s: %r" % (tag, rc, err[-600:]))
    check(tree(d) == before, "%s: the folder changed: %r" % (tag, sorted(tree(d))))
    shutil.rmtree(d)
    os.replace(d + ".0", d)


for model, d, args in (("DLA", Q, lambda d: ("--resume", d, "--target", "5000", "-q")),
                       ("event", Qe, lambda d: ("--model", "event", "--resume", d, "--t-max", "8")),
                       ("DLCA", Qd, lambda d: ("--model", "dlca", "--resume", d, "--max-attempts", "6000", "-q"))):
    for what, make, want in LINK_CASES:
        link_refused(d, "%s: %s" % (model, what), args, make, want)
    # a run directory of 3900 bytes: the check's joined path had 4400
    LQ = W("long-link")
    shutil.rmtree(LQ, ignore_errors=True)
    while len(LQ) < 3900:
        LQ = os.path.join(LQ, "q" * min(200, 3900 - len(LQ)))
    shutil.copytree(d, LQ)
    link_refused(LQ, "%s: a 600-byte link to a temporary name in a 3900-byte run directory" % model, args,
                 long_target_link, TO_TMP)
    shutil.rmtree(W("long-link"))
# --- the run directory itself named through a temporary name of its own
# (--resume D/.checkpoint.h5.new with that a link to ".", D/.cluster.h5.new/..
# with that a link to a subfolder, a DLCA --out so named): the sweep unlinks
# D/NAME by that path, so it removed the link the path went through; the DLA
# and DLCA resumes then loaded and failed every write after it (exit 1), the
# event resume failed "takes no files" with the link gone. Refused in one
# line, exit 2, the folder as it was; a plain link to the run directory, or a
# path through a subfolder and "..", still resumes.
SELF = "pdla: cannot resume: the run directory %(p)s is named through its own %(n)s, a temporary name"


def self_link_refused(d, tag, args, name, target, via):
    shutil.rmtree(d + ".0", ignore_errors=True)
    shutil.copytree(d, d + ".0", symlinks=True)
    if target != ".":
        os.mkdir(os.path.join(d, target))
    os.symlink(target, os.path.join(d, name))
    p = os.path.join(d, name, via) if via else os.path.join(d, name)
    before = tree(d)
    rc, err = pdla(*args(d, p))
    lines = err.strip().split("\n")
    check(rc == 2 and len(lines) == 1 and lines[0].startswith(SELF % {"p": p, "n": name}),
          "%s: exit %s: %r" % (tag, rc, err[-600:]))
    check(tree(d) == before, "%s: the folder changed: %r" % (tag, sorted(tree(d))))
    shutil.rmtree(d)
    os.replace(d + ".0", d)


for model, d, args in (("DLA", Q, lambda d, p: ("--resume", p, "--target", "5000", "-q")),
                       ("DLA, file", Q, lambda d, p: ("--resume", os.path.join(p, "checkpoint.h5"), "--target",
                                                      "5000", "-q")),
                       ("event", Qe, lambda d, p: ("--model", "event", "--resume", p, "--t-max", "8")),
                       ("DLCA", Qd, lambda d, p: ("--model", "dlca", "--resume", p, "--max-attempts", "6000", "-q")),
                       ("DLCA, --out", Qd, lambda d, p: ("--model", "dlca", "--resume", os.path.join(d, "checkpoint.h5"),
                                                         "--max-attempts", "6000", "-q", "--out", p))):
    self_link_refused(d, "%s: the run directory through its own link to ." % model, args, ".checkpoint.h5.new",
                      ".", "")
    self_link_refused(d, "%s: the run directory through its own link to a subfolder, then .." % model, args,
                      ".cluster.h5.new", "sub", "..")
# --- a new run's --out named through a temporary name of the folder it
# names (--force --out D/.checkpoint.h5.new with that a link to "." or to
# D; a DLCA resume into --out elsewhere so named): the sweep of leftovers
# removed the link, and the run failed with the link gone (DLA, DLCA: every
# write after it, exit 1; event: "cannot read run directory", exit 1).
# Refused in one line, exit 2, before anything is written or removed, the
# folder as it was (its older run kept); the ensemble's --out through its
# own ensemble.h5.tmp.7 too. A real folder under the name is a run
# directory like any other.
NEW = "%(w)s: cannot start a new run: the run directory %(p)s is named through its own %(n)s, %(k)s"


def new_run_refused(d, tag, args, name, target, who="pdla", also=None, kind="a temporary name"):
    shutil.rmtree(d + ".0", ignore_errors=True)
    shutil.copytree(d, d + ".0", symlinks=True)
    os.symlink(target, os.path.join(d, name))
    p = os.path.join(d, name)
    before = tree(d)
    also_before = tree(also) if also else None
    rc, err = pdla(*args(p))
    lines = err.strip().split("\n")
    check(rc == 2 and len(lines) == 1 and lines[0].startswith(NEW % {"w": who, "p": p, "n": name, "k": kind}),
          "%s: exit %s: %r" % (tag, rc, err[-600:]))
    check(tree(d) == before, "%s: the folder changed: %r" % (tag, sorted(tree(d))))
    check(also is None or tree(also) == also_before, "%s: the folder resumed from changed" % tag)
    shutil.rmtree(d)
    os.replace(d + ".0", d)


for model, d, args in (("DLA", Q, lambda p: ("--target", "500", "-q", "--force", "--out", p)),
                       ("event", Qe, lambda p: tuple(EV) + ("--t-max", "1", "--force", "--out", p)),
                       ("DLCA", Qd, lambda p: tuple(DLCA) + ("--max-attempts", "100", "-q", "--force", "--out", p))):
    new_run_refused(d, "%s: a new run's --out through its own link to ." % model, args, ".checkpoint.h5.new", ".")
    new_run_refused(d, "%s: a new run's --out through its own link to the folder" % model, args, ".cluster.h5.new",
                    os.path.join("..", os.path.basename(d)))
Qx = W("Qx")
shutil.rmtree(Qx, ignore_errors=True)
os.mkdir(Qx)
new_run_refused(Qx, "DLCA: a resume into --out elsewhere through its own link to .",
                lambda p: ("--model", "dlca", "--resume", os.path.join(Qd, "checkpoint.h5"), "--max-attempts", "6000",
                           "-q", "--force", "--out", p), ".checkpoint.h5.new", ".", also=Qd)
# The same through a name of the older run's, which --force removes
# (checkpoint.h5, checkpoint.prev.h5, summary.txt, a set-aside
# checkpoint.damaged.h5): the removal took the link, and the run failed
# "cannot sync run directory" (exit 1), the link gone.
for model, args in (("DLA", lambda p: ("--target", "500", "-q", "--force", "--out", p)),
                    ("event", lambda p: tuple(EV) + ("--t-max", "1", "--force", "--out", p)),
                    ("DLCA", lambda p: tuple(DLCA) + ("--max-attempts", "100", "-q", "--force", "--out", p))):
    for name in ("checkpoint.h5", "checkpoint.prev.h5", "summary.txt", "checkpoint.damaged.h5"):
        new_run_refused(Qx, "%s: a new run's --out through its own link %s to ." % (model, name), args, name, ".",
                        kind="a name of the older run's")
shutil.rmtree(Qx)
os.mkdir(Qx)
os.mkdir(os.path.join(Qx, ".checkpoint.h5.new"))
rc, err = pdla("--target", "500", "-q", "--force", "--out", os.path.join(Qx, ".checkpoint.h5.new"))
check(rc == 0 and os.path.isfile(os.path.join(Qx, ".checkpoint.h5.new", "cluster.h5")),
      "DLA: a new run into a real folder named .checkpoint.h5.new: exit %s: %r" % (rc, err))
shutil.rmtree(Qx)
# A link named with a newline (and a tab) to a temporary name: the line
# named it as it was, so the one line was two; now each control byte is
# shown as \ooo, in one line.
os.replace(os.path.join(Q, "checkpoint.1.h5"), os.path.join(Q, ".checkpoint.h5.tmp.1234"))
os.symlink(".checkpoint.h5.tmp.1234", os.path.join(Q, "my\nlink\t"))
before = linked(Q)
rc, err = resume(Q, 5000)
check(rc == 2 and err.endswith("\n") and err.count("\n") == 1 and
      err.startswith("pdla: cannot resume: %s/my\\012link\\011 is a symbolic link to %s/.checkpoint.h5.tmp.1234"
                     % (Q, Q)) and linked(Q) == before,
      "DLA: a link named with a newline: exit %s: %r" % (rc, err))
os.unlink(os.path.join(Q, "my\nlink\t"))
os.replace(os.path.join(Q, ".checkpoint.h5.tmp.1234"), os.path.join(Q, "checkpoint.1.h5"))
os.symlink(os.path.basename(Q), W("Q-link"))
os.mkdir(os.path.join(Q, "sub"))
rc, err = resume(W("Q-link"), 4500)
rc2, err2 = resume(os.path.join(Q, "sub", ".."), 4600)
check(rc == 0 and rc2 == 0, "DLA: the run directory by a link, and by sub/..: exit %s %s: %r %r" % (rc, rc2, err, err2))
os.rmdir(os.path.join(Q, "sub"))
os.unlink(W("Q-link"))
# A DLCA link to a temporary name is not refused with --out elsewhere
# (--force): the sweep is that directory's, the folder resumed from is left
# as it is, so the link loses nothing (it was refused, "the resume
# removes", while the folder was never swept)
os.replace(os.path.join(Qd, "checkpoint.h5"), os.path.join(Qd, ".checkpoint.h5.tmp.1234"))
os.symlink(".checkpoint.h5.tmp.1234", os.path.join(Qd, "checkpoint.h5"))
before = linked(Qd)
Qo = W("Qo")
shutil.rmtree(Qo, ignore_errors=True)
rc, err = pdla("--model", "dlca", "--resume", os.path.join(Qd, "checkpoint.h5"), "--max-attempts", "6000", "-q",
               "--out", Qo, "--force")
check(rc == 0 and linked(Qd) == before and os.path.isfile(os.path.join(Qo, "checkpoint.h5")),
      "DLCA: a link to a temporary name, resumed into --out elsewhere: exit %s: %r, folder %r" % (rc, err,
                                                                                                sorted(os.listdir(Qd))))
shutil.rmtree(Qo, ignore_errors=True)
os.remove(os.path.join(Qd, "checkpoint.h5"))
os.replace(os.path.join(Qd, ".checkpoint.h5.tmp.1234"), os.path.join(Qd, "checkpoint.h5"))
# not refused: a hard link under a temporary name (its sweep loses nothing),
# and a link to a name of the user's
os.link(os.path.join(Qe, "checkpoint.h5"), os.path.join(Qe, ".checkpoint.h5.tmp.1234"))
os.replace(os.path.join(Qe, "checkpoint.prev.h5"), os.path.join(Qe, "mine.h5"))
os.symlink("mine.h5", os.path.join(Qe, "checkpoint.prev.h5"))
rc, err = pdla(*EVR)
check(rc == 0 and not os.path.lexists(os.path.join(Qe, ".checkpoint.h5.tmp.1234")),
      "event: a hard link under a temporary name, a link to mine.h5: exit %s: %r" % (rc, err))
os.link(os.path.join(Qd, "checkpoint.h5"), os.path.join(Qd, ".checkpoint.h5.tmp.1234"))
rc, err = dlca_resume(Qd, 6000)
check(rc == 0 and not os.path.lexists(os.path.join(Qd, ".checkpoint.h5.tmp.1234")),
      "DLCA: a hard link under a temporary name: exit %s: %r" % (rc, err))
os.replace(os.path.join(Q, "checkpoint.h5"), os.path.join(Q, "mine.h5"))
os.symlink("mine.h5", os.path.join(Q, "checkpoint.h5"))
rc, err = resume(Q, 5000)
check(rc == 0, "DLA: checkpoint.h5 a link to mine.h5: exit %s: %r" % (rc, err))

# --- a symbolic link loop in the run directory that meets no temporary
# name (junk -> junk, a -> b -> a, deep -> deep/x, sub/l -> ../sub/l): the
# sweep loses nothing through it (the kernel fails, ELOOP, before and after
# it), yet every model's resume was refused "does not resolve within 40
# links" (session 35). Each resumes now, the links left as they were.
LOOPS = (("junk", "junk"), ("a", "b"), ("b", "a"), ("deep", "deep/x"), ("sub/l", "../sub/l"))


def unrelated_loops(d, tag, args):
    os.mkdir(os.path.join(d, "sub"))
    for name, target in LOOPS:
        os.symlink(target, os.path.join(d, name))
    rc, err = pdla(*args)
    check(rc == 0, "%s: unrelated link loops in the run directory: exit %s: %r" % (tag, rc, err[-600:]))
    check(all(os.readlink(os.path.join(d, n)) == t for n, t in LOOPS),
          "%s: unrelated link loops: the links changed: %r" % (tag, sorted(os.listdir(d))))
    for name, _ in LOOPS:
        os.unlink(os.path.join(d, name))
    os.rmdir(os.path.join(d, "sub"))


unrelated_loops(Q, "DLA", ("--resume", Q, "--target", "5500", "-q"))
unrelated_loops(Q, "DLA, file named", ("--resume", os.path.join(Q, "checkpoint.h5"), "--target", "6000", "-q"))
unrelated_loops(Qe, "event", ("--model", "event", "--resume", Qe, "--t-max", "10"))
unrelated_loops(Qd, "DLCA", ("--model", "dlca", "--resume", Qd, "--max-attempts", "8000", "-q"))
# A DLCA resume in its own folder, named through a link of it under an
# older run's name (D/summary.txt -> .): it removes no older run (only a
# new run and a resume into --out elsewhere do), so it resumes, the link kept.
os.symlink(".", os.path.join(Qd, "summary.txt"))
rc, err = dlca_resume(os.path.join(Qd, "summary.txt"), 9000)
check(rc == 0 and os.readlink(os.path.join(Qd, "summary.txt")) == ".",
      "DLCA: a resume in its own folder through its link summary.txt -> .: exit %s: %r" % (rc, err))
os.unlink(os.path.join(Qd, "summary.txt"))

# --- `pdla ensemble --resume`: its sweep removes clusters.journal.tmp.*,
# ensemble.h5.tmp.*, ensemble.xdmf2.tmp.*; with clusters.journal a link to
# clusters.journal.tmp.5 the resume opened the journal, the sweep removed
# the file (every cluster recorded in it) and the resume failed, "cannot
# open E/clusters.journal for writing". Refused as the models' resumes
# are, in one line, exit 2, the folder as it was; so is the ensemble's
# folder named through such a name of its own; a plain resume goes on.
EN = W("ens")
shutil.rmtree(EN, ignore_errors=True)
shutil.rmtree(EN + ".0", ignore_errors=True)
rc, err = pdla("ensemble", "--clusters", "3", "--target", "200", "--out", EN, "-q")
check(rc == 0, "ensemble run: %r" % err)
shutil.copytree(EN, EN + ".0")
os.replace(os.path.join(EN, "clusters.journal"), os.path.join(EN, "clusters.journal.tmp.5"))
os.symlink("clusters.journal.tmp.5", os.path.join(EN, "clusters.journal"))
before = linked(EN)
rc, err = pdla("ensemble", "--resume", EN, "--clusters", "4", "-q")
check(rc == 2 and err.count("\n") == 1 and err.startswith(
    "pdla ensemble: cannot resume: %s/clusters.journal is a symbolic link to %s/clusters.journal.tmp.5, a temporary "
    "name" % (EN, EN)) and linked(EN) == before, "ensemble: the journal a link to a temporary name: exit %s: %r"
      % (rc, err))
shutil.rmtree(EN)
shutil.copytree(EN + ".0", EN)
os.symlink(".", os.path.join(EN, "ensemble.h5.tmp.7"))
before = linked(EN)
rc, err = pdla("ensemble", "--resume", os.path.join(EN, "ensemble.h5.tmp.7"), "--clusters", "4", "-q")
check(rc == 2 and err.count("\n") == 1 and err.startswith(
    "pdla ensemble: cannot resume: the run directory %s/ensemble.h5.tmp.7 is named through its own "
    "ensemble.h5.tmp.7, a temporary name" % EN) and linked(EN) == before,
      "ensemble: the folder named through its own temporary name: exit %s: %r" % (rc, err))
shutil.rmtree(EN)
os.replace(EN + ".0", EN)
rc, err = pdla("ensemble", "--resume", EN, "--clusters", "4", "-q")
check(rc == 0, "ensemble: a plain resume: exit %s: %r" % (rc, err))
unrelated_loops(EN, "ensemble", ("ensemble", "--resume", EN, "--clusters", "5", "-q"))
new_run_refused(EN, "ensemble: a new ensemble's --out through its own link to .",
                lambda p: ("ensemble", "--clusters", "2", "--target", "100", "-q", "--force", "--out", p),
                "ensemble.h5.tmp.7", ".", who="pdla ensemble")
ENx = W("ensx")
shutil.rmtree(ENx, ignore_errors=True)
os.mkdir(ENx)
for name in ("clusters.journal", "ensemble.h5", "ensemble.xdmf2"):
    new_run_refused(ENx, "ensemble: a new ensemble's --out through its own link %s to ." % name,
                    lambda p: ("ensemble", "--clusters", "2", "--target", "100", "-q", "--force", "--out", p),
                    name, ".", who="pdla ensemble", kind="a name of the older run's")
shutil.rmtree(ENx)

print("ckpt_fallback: %d pdla runs, %d failures" % (runs, len(failures)))
_ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print("children's CPU time: %.1f s user, %.1f s system" % (_ru.ru_utime, _ru.ru_stime))
sys.exit(1 if failures else 0)
