#!/usr/bin/python3
"""faults.py PDLA SHIM WORKDIR - the write-fault suite (issue 10).

Runs pdla with failures injected into its writes and checks what is left:
  - LD_PRELOAD faultshim.so: the k-th write/pwrite (ENOSPC, EIO, EDQUOT, a
    short write), fsync, fallocate or stdio flush fails (faultshim.c);
  - RLIMIT_FSIZE with SIGXFSZ ignored: every write past byte offset X of any
    file fails (EFBIG), including stdio's internal writes.
Outputs: cluster.h5 + summary.txt (a --force run over an earlier one),
checkpoints (then a resume), analyze's CSV files and render's PNG (both
--force over earlier ones). Every faulted run must exit 0 or 1 (never a
signal) with at most one line on stderr (exactly one when it fails), leave
no temporary file, and leave each output either as it was before or
complete and equal to a clean run's; a resume from what a faulted
checkpoint run left must give a cluster bit-identical to an uninterrupted
run. Offsets are sampled (all of them for the rare calls) to keep CI short.
"""
import os
import resource
import shutil
import sys

import h5py
import numpy as np

from reliab_util import check, failures, run_faulted, shim_preload

PDLA, SHIM, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
runs = 0


PRELOAD = shim_preload(PDLA, SHIM)


def pdla(args, fault=None, fsize=None, count=None):
    """Run pdla; fault: dict of FAULT_* settings; fsize: RLIMIT_FSIZE bytes."""
    global runs
    runs += 1
    env = dict(os.environ)
    if fault is not None or count:
        env["LD_PRELOAD"] = PRELOAD
        env.update(fault or {})
        if count:
            env["FAULT_COUNT"] = count
    return run_faulted(PDLA, args, env, fsize)


def calls(args, op):
    c = os.path.join(WORK, "count")
    pdla(args, fault={"FAULT_OP": op}, count=c)
    return int(open(c).read())


def sample(n, k):
    """Up to k of 1..n: the ends and evenly between."""
    if n <= k:
        return list(range(1, n + 1))
    return sorted({1, 2, n - 1, n} | {1 + (n - 1) * i // (k - 1) for i in range(k)})


ERRS = [("ENOSPC", "1"), ("EIO", "0"), ("EDQUOT", "1"), ("SHORT", "0"), ("EIO", "1"), ("ENOSPC", "0")]


def faults(args):
    """(description, fault, fsize) for one command: sampled offsets."""
    out = []
    nw = calls(args, "write")
    for i, k in enumerate(sample(nw, 8)):
        e, sticky = ERRS[i % len(ERRS)]
        out.append(("write #%d/%d %s%s" % (k, nw, e, " sticky" if sticky == "1" else ""),
                    {"FAULT_OP": "write", "FAULT_AT": str(k), "FAULT_ERR": e, "FAULT_STICKY": sticky}, None))
    for op in ("fsync", "fallocate", "stdio"):
        n = calls(args, op)
        for i, k in enumerate(sample(n, 4)):
            e = ("EIO", "ENOSPC", "EDQUOT")[i % 3]
            out.append(("%s #%d/%d %s" % (op, k, n, e), {"FAULT_OP": op, "FAULT_AT": str(k), "FAULT_ERR": e}, None))
    for x in (0, 1000, 5000, 20000):
        out.append(("file size limit %d" % x, None, x))
    return out


def tmp_left(d):
    return [f for f in os.listdir(d) if ".tmp." in f or f.startswith(".cluster.h5.new")]


def judge(tag, rc, err, dirs):
    check(rc is not None, tag + ": did not end")
    if rc is None:
        return
    check(rc in (0, 1), tag + ": exit %d %r" % (rc, err[:2]))
    check(len(err) <= 1 and (rc == 0 or len(err) == 1), tag + ": stderr %r" % err[:3])
    for d in dirs:
        left = tmp_left(d) if os.path.isdir(d) else []
        check(not left, tag + ": left %r" % left)


def read(path):
    return open(path, "rb").read() if os.path.exists(path) else None


def positions(path):
    with h5py.File(path, "r") as f:
        return f["/cluster/positions"][...]


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
W = lambda *p: os.path.join(WORK, *p)

# ---- cluster.h5 and summary.txt: a --force run over an earlier run -------
RUN = ["--target", "400", "--seed", "3", "-q"]
pdla(RUN + ["--out", W("ref")])
pdla(["--target", "200", "--seed", "8", "-q", "--out", W("old")])
ref_pos = positions(W("ref", "cluster.h5"))
old_h5, old_sum = read(W("old", "cluster.h5")), read(W("old", "summary.txt"))
for desc, fault, fsize in faults(RUN + ["--out", W("probe"), "--force"]):
    d = W("run")
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(W("old"), d)
    rc, err = pdla(RUN + ["--out", d, "--force"], fault, fsize)
    tag = "cluster " + desc
    judge(tag, rc, err, [d])
    h5 = read(os.path.join(d, "cluster.h5"))
    if h5 != old_h5:  # replaced: must be complete and the new run's
        try:
            check(np.array_equal(positions(os.path.join(d, "cluster.h5")), ref_pos), tag + ": wrong new cluster.h5")
        except OSError as e:
            check(False, tag + ": cluster.h5 unreadable: %s" % e)
    s = read(os.path.join(d, "summary.txt"))
    check(s == old_sum or (s is not None and s.startswith(b"pdla ") and b"R_ext" in s),
          tag + ": summary.txt partial: %r" % (s[:80] if s else s))
    if rc == 0:
        check(h5 != old_h5 and s != old_sum, tag + ": exit 0 but the old files are still there")

# ---- the --force rename of cluster.h5 is made durable ----------------------
# The library writes .cluster.h5.new (synced, renamed, its directory synced);
# the command then renamed it over cluster.h5 and synced nothing, so a crash
# just after a --force run that said "wrote" could leave the older file. One
# of the run's directory syncs must follow that rename: failed, the run exits
# 1 with one line and the new cluster.h5 in place.
n_dirsync = calls(RUN + ["--out", W("probe"), "--force"], "dirsync")
found = 0
for k in range(1, n_dirsync + 1):
    d = W("run")
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(W("old"), d)
    rc, err = pdla(RUN + ["--out", d, "--force"], {"FAULT_OP": "dirsync", "FAULT_AT": str(k)})
    judge("cluster dirsync #%d/%d" % (k, n_dirsync), rc, err, [d])
    if rc == 1 and len(err) == 1 and "replaced" in err[0] and "cannot sync its directory" in err[0]:
        found += 1
        check(read(os.path.join(d, "cluster.h5")) != old_h5, "cluster dirsync #%d: the old cluster.h5 is there" % k)
        check(read(os.path.join(d, "summary.txt")) not in (None, old_sum),
              "cluster dirsync #%d: the older run's summary.txt beside the new cluster.h5" % k)
        check(np.array_equal(positions(os.path.join(d, "cluster.h5")), ref_pos),
              "cluster dirsync #%d: wrong new cluster.h5" % k)
check(found == 1, "cluster.h5's --force rename: %d of the run's %d directory syncs follow it (want 1)"
      % (found, n_dirsync))

# ---- checkpoints, then a resume -------------------------------------------
CK = ["--target", "900", "--seed", "4", "-q", "--checkpoint-particles", "300"]
pdla(CK + ["--out", W("ckref")])
ck_ref = positions(W("ckref", "cluster.h5"))
for desc, fault, fsize in faults(CK + ["--out", W("ckprobe")]):
    d = W("ck")
    shutil.rmtree(d, ignore_errors=True)
    rc, err = pdla(CK + ["--out", d], fault, fsize)
    tag = "checkpoint " + desc
    judge(tag, rc, err, [d])
    if rc == 0:
        check(np.array_equal(positions(os.path.join(d, "cluster.h5")), ck_ref), tag + ": cluster differs")
        continue
    if not any(f.startswith("checkpoint") for f in os.listdir(d)):
        continue  # failed before the first checkpoint: nothing to resume
    rc2, err2 = pdla(["--resume", d, "--target", "900", "-q"])
    check(rc2 == 0, tag + ": resume failed: %r" % err2)
    if rc2 == 0:
        check(np.array_equal(positions(os.path.join(d, "cluster.h5")), ck_ref),
              tag + ": resumed cluster not bit-identical to the uninterrupted run")

# ---- analyze --csv and render -o, --force over earlier outputs ------------
REF = W("ref", "cluster.h5")
pdla(["analyze", REF, "--csv", W("csvref")])
pdla(["analyze", W("old", "cluster.h5"), "--csv", W("csvold")])
pdla(["render", REF, "-o", W("ref.png")])
pdla(["render", W("old", "cluster.h5"), "-o", W("old.png")])
for tool, args, outs, refs, olds in (
        ("csv", ["analyze", REF, "--csv", W("csv"), "--force"], [W("csv", n) for n in ("rg.csv", "mass_radius.csv")],
         [W("csvref", n) for n in ("rg.csv", "mass_radius.csv")], [W("csvold", n) for n in ("rg.csv", "mass_radius.csv")]),
        ("png", ["render", REF, "-o", W("png", "x.png"), "--force"], [W("png", "x.png")], [W("ref.png")], [W("old.png")])):
    for desc, fault, fsize in faults(args):
        d = os.path.dirname(outs[0])
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        for o, old in zip(outs, olds):
            shutil.copy(old, o)
        rc, err = pdla(args, fault, fsize)
        tag = tool + " " + desc
        judge(tag, rc, err, [d])
        for o, r, old in zip(outs, refs, olds):
            got = read(o)
            check(got in (read(r), read(old)), tag + ": %s partial (%s bytes)" % (os.path.basename(o),
                                                                                len(got) if got else got))
            if rc == 0:
                check(got == read(r), tag + ": exit 0 but %s is not the new output" % os.path.basename(o))

print("faults: %d runs, %d failures" % (runs, len(failures)))
_ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print("children's CPU time: %.1f s user, %.1f s system" % (_ru.ru_utime, _ru.ru_stime))
sys.exit(1 if failures else 0)
