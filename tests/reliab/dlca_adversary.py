#!/usr/bin/env python3
"""dlca_adversary.py PDLA WORKDIR - what an adversarial test of the DLCA
model found (session 23), each case as it was found:

- a checkpoint whose /snapshots link exists but is not a group (one flipped
  bit did it) resumed with exit 0 and wrote no snapshots, old or new;
- --resume --snapshot-every T2 took the new period without a word
  (/snapshots then said `every` T2 of snapshots taken at T);
- --start FILE refused on a box under 50 sites for the default --fill's 0
  monomers, which a start file does not use;
- --start given a FIFO (and a checkpoint.h5 that is a FIFO) blocked for
  ever; a directory as --start was "read error", exit 1;
- (session 27) a checkpoint's forged /snapshots resumed and were written
  back: a site copied onto another, cluster numbers that are not 0, 1, ...
  in monomer order, a count below the snapshots held, a snapshot dropped
  (the later ones renumbered) or moved in time; each now refused, the run
  directory unchanged.
Each refusal: one line, exit 2, within TIME_LIMIT.
"""
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

PDLA = os.path.abspath(sys.argv[1])
WORK = os.path.abspath(sys.argv[2])
TIME_LIMIT = 30
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
fails = 0


def check(cond, msg):
    global fails
    if not cond:
        print("FAIL: " + msg)
        fails += 1
    return cond


def run(args):
    try:
        p = subprocess.run([PDLA] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=TIME_LIMIT,
                           cwd=WORK)
    except subprocess.TimeoutExpired:
        return None, []
    err = p.stderr.decode("utf-8", "replace").rstrip("\n")
    return p.returncode, err.split("\n") if err else []


def refused(tag, args, want):
    rc, err = run(args)
    check(rc == 2 and len(err) == 1 and want in err[0], "%s: want one line with '%s', exit 2; got %s %s"
          % (tag, want, rc, err))


DL = ["--model", "dlca", "-q"]
base = DL + ["--box", "128x128", "--fill", "0.03", "--seed", "2", "--snapshot-every", "50"]
rc, err = run(base + ["--max-attempts", "20000", "--checkpoint", "--out", "snp"])
check(rc == 0, "checkpointed run with snapshots: %s %s" % (rc, err))

# a different period on resume
refused("--snapshot-every changed on resume", DL + ["--resume", "snp", "--snapshot-every", "7", "--max-attempts",
                                                    "40000"], "different --snapshot-every")

# /snapshots replaced by a dataset: damage, not "no snapshots"
shutil.copytree(os.path.join(WORK, "snp"), os.path.join(WORK, "snp2"))
with h5py.File(os.path.join(WORK, "snp2", "checkpoint.h5"), "r+") as f:
    nsnap = int(f["snapshots"].attrs["count"])
    del f["snapshots"]
    f.create_dataset("snapshots", data=[1, 2, 3])
check(nsnap > 0, "the checkpoint held no snapshots to lose")
rc, err = run(DL + ["--resume", "snp2", "--max-attempts", "40000"])
check(rc != 0 and rc is not None and len(err) == 1 and "snapshots" in err[0],
      "/snapshots not a group: want one line naming the snapshots, got %s %s" % (rc, err))
# the untouched copy resumes, keeping its snapshots and taking more
rc, err = run(DL + ["--resume", "snp", "--max-attempts", "40000"])
with h5py.File(os.path.join(WORK, "snp", "cluster.h5"), "r") as f:
    got = int(f["snapshots"].attrs["count"]) if "snapshots" in f else 0
check(rc == 0 and got > nsnap, "resumed run: %s %s, %d snapshots (checkpoint %d)" % (rc, err, got, nsnap))

# (session 27 review) forged /snapshots that --resume took and wrote back:
# a copied site and every cluster number 0 under n_clusters 34 (exit 0, the
# duplicate in the output); count set to 0 (exit 0, the first snapshot gone
# and the later ones renumbered). Now each is refused with one line naming
# the snapshots, exit 2, and the run directory left as it was.
rc, err = run(DL + ["--box", "64", "--fill", "0.05", "--seed", "3", "--until-clusters", "20", "--snapshot-every",
                    "25", "--checkpoint", "--out", "fs"])
with h5py.File(os.path.join(WORK, "fs", "checkpoint.h5"), "r") as f:
    nfs = int(f["snapshots"].attrs["count"]) if "snapshots" in f else 0
check(rc == 0 and nfs >= 3, "run for the forged snapshots: %s %s, %d snapshots (want 3 or more)" % (rc, err, nfs))


def snap_array(i, name, fn):
    """Snapshot i's dataset name set to fn(its values)."""
    def forge(f):
        d = f["snapshots/%d/%s" % (i, name)]
        d[...] = fn(d[...])
    return forge


def snap_drop(i):
    """Snapshot i deleted, the later ones renumbered, count made to agree."""
    def forge(f):
        g = f["snapshots"]
        n = int(g.attrs["count"])
        del g[str(i)]
        for j in range(i + 1, n):
            g.move(str(j), str(j - 1))
        g.attrs["count"] = np.uint64(n - 1)
    return forge


def dup_site(a):
    a[1] = a[0]
    return a


def site_and_clusters(f):
    snap_array(0, "site", dup_site)(f)
    snap_array(0, "cluster", lambda a: a * 0)(f)


snap_forgeries = {
    "site copied, every cluster 0": (site_and_clusters, "snapshot 0"),
    "site copied": (snap_array(0, "site", dup_site), "on one site"),
    "every cluster 0": (snap_array(0, "cluster", lambda a: a * 0), "n_clusters"),
    "clusters reversed": (snap_array(1, "cluster", lambda a: a[::-1].copy()), "in monomer order"),
    "count 0": (lambda f: f["snapshots"].attrs.__setitem__("count", np.uint64(0)), "count 0"),
    "first dropped": (snap_drop(0), "snapshot 0 at t"),
    "last dropped": (snap_drop(nfs - 1), "was due"),
    "t later by 5": (lambda f: f["snapshots/1"].attrs.__setitem__("t", f["snapshots/1"].attrs["t"] + 5),
                     "snapshot 1 at t"),
}
for i, (tag, (forge, want)) in enumerate(snap_forgeries.items()):
    d = "fs%d" % i
    shutil.copytree(os.path.join(WORK, "fs"), os.path.join(WORK, d))
    with h5py.File(os.path.join(WORK, d, "checkpoint.h5"), "r+") as f:
        forge(f)
    before = {n: open(os.path.join(WORK, d, n), "rb").read() for n in os.listdir(os.path.join(WORK, d))}
    refused("--resume, snapshots forged: " + tag, DL + ["--resume", d, "--until-clusters", "10"], want)
    after = {n: open(os.path.join(WORK, d, n), "rb").read() for n in os.listdir(os.path.join(WORK, d))}
    check(after == before, "--resume, snapshots forged: %s: the run directory changed" % tag)
rc, err = run(DL + ["--resume", "fs", "--until-clusters", "10"])
check(rc == 0, "--resume of the unforged snapshots: %s %s" % (rc, err))

# --start on a small box, no --fill
with open(os.path.join(WORK, "start2.txt"), "w") as f:
    f.write("0 0\n2 2\n")
rc, err = run(DL + ["--box", "4x4", "--start", "start2.txt", "--no-output"])
check(rc == 0, "--start on a 4x4 box without --fill: %s %s" % (rc, err))
refused("--start, --until-clusters above the file's count", DL + ["--box", "4x4", "--start", "start2.txt",
                                                                  "--until-clusters", "5", "--no-output"],
        "more than the 2 monomers")

# FIFOs and a directory
fifo = os.path.join(WORK, "fifo")
os.mkfifo(fifo)
refused("--start FIFO", DL + ["--box", "16x16", "--start", fifo, "--no-output"], "not a regular file")
refused("--start directory", DL + ["--box", "16x16", "--start", WORK, "--no-output"], "not a regular file")
os.makedirs(os.path.join(WORK, "ff"))
shutil.copy(os.path.join(WORK, "snp", "checkpoint.h5"), os.path.join(WORK, "ff", "keep.h5"))
os.mkfifo(os.path.join(WORK, "ff", "checkpoint.h5"))
rc, err = run(DL + ["--resume", os.path.join(WORK, "ff", "checkpoint.h5")])
check(rc is not None and rc != 0 and len(err) == 1, "--resume of a FIFO checkpoint: %s %s" % (rc, err))
# (session 26) the DLCA message named a FIFO "no such file"; the event model
# opened it and blocked in open() past SIGTERM (only kill -9 ended it)
refused("--resume FIFO, DLCA", DL + ["--resume", os.path.join(WORK, "ff")], "not a regular file")
refused("--resume FIFO, event", ["--model", "event", "--resume", os.path.join(WORK, "ff")], "not a regular file")
refused("--resume FIFO file, event", ["--model", "event", "--resume", os.path.join(WORK, "ff", "checkpoint.h5")],
        "not a regular file")

# (session 26) --resume A --out B wrote over another run in B without --force
small = DL + ["--box", "32x32", "--fill", "0.05", "--checkpoint"]
rc, err = run(small + ["--until-clusters", "20", "--seed", "1", "--out", "ra"])
rc2, err2 = run(small + ["--until-clusters", "30", "--seed", "2", "--out", "rb"])
if check(rc == 0 and rc2 == 0, "runs for --resume --out: %s %s %s %s" % (rc, err, rc2, err2)):
    def digest(d):
        return {n: open(os.path.join(WORK, d, n), "rb").read() for n in ("cluster.h5", "checkpoint.h5")}
    before = digest("rb")
    refused("--resume ra --out rb (rb exists)", DL + ["--resume", "ra", "--until-clusters", "10", "--out", "rb"],
            "use --force")
    check(digest("rb") == before, "--resume ra --out rb without --force changed rb")
    rc, err = run(DL + ["--resume", "ra", "--until-clusters", "10", "--out", "rb", "--force"])
    check(rc == 0 and digest("rb") != before, "--resume ra --out rb --force: %s %s" % (rc, err))
    rc, err = run(DL + ["--resume", "ra", "--until-clusters", "15", "--out", os.path.join(WORK, "ra") + "/"])
    check(rc == 0, "--resume ra --out ra/ (its own directory): %s %s" % (rc, err))
    rc, err = run(DL + ["--resume", "ra/checkpoint.h5", "--until-clusters", "12", "--out", "rc"])
    check(rc == 0 and os.path.exists(os.path.join(WORK, "rc", "cluster.h5")),
          "--resume ra --out rc (new): %s %s" % (rc, err))

# (session 26) a second, other --model was ignored after --model event
refused("--model event --model dlca", ["--model", "event", "--model", "dlca", "--particles", "10", "--out", "mm"],
        "runs model event")
check(not os.path.exists(os.path.join(WORK, "mm")), "--model event --model dlca made a run directory")

shutil.rmtree(WORK, ignore_errors=True)
print("%d failures" % fails)
sys.exit(1 if fails else 0)
