#!/usr/bin/python3
"""models_faults.py PDLA SHIM WORKDIR - write faults and kill -9 for the DLCA
and event models (faults.py and ens_adversary.py do the same for the DLA
command and the ensembles).

For a small 2D and 3D system of each model, a `--force` run with frequent
checkpoints (DLCA --checkpoint-attempts, event --checkpoint-every of a
nanosecond: a checkpoint at every tick of the event loop, so that a run
makes the same calls every time) over an earlier complete run with
checkpoints, under
  - faultshim.so failing the k-th write/pwrite (ENOSPC, EIO, EDQUOT, a short
    write; sampled k), and every fsync, rename/link and directory fsync such
    a run makes (and every fallocate and stdio flush: these writers make
    none today);
  - RLIMIT_FSIZE with SIGXFSZ ignored, at sampled byte offsets;
  - kill -9 just before the k-th write (sampled), fsync and rename/link
    (every one; FAULT_SIGNAL=9).
A faulted run must exit 0, 1 or 2 (never a signal), with nothing on stderr
when it succeeds and exactly one line when it fails, and leave no temporary
file (a killed one: none once the directory is next taken); cluster.h5 is
the earlier run's, untouched, the new run's complete, or (the run stopped
at a failed checkpoint) a readable one saying it stopped early; its XDMF
sidecars are absent or describe the cluster.h5 beside them. A `--resume` of
whatever is left must succeed when a checkpoint is there (else be refused
with one line, and a new run then take the directory) and give every
dataset and attribute of the uninterrupted run's cluster.h5 bit for bit
(/Code, wall_s, model_bytes and DLCA's /parameters count aside) and its
sidecars. Faults in a resumed run (from a checkpoint half way), then a
resume, the same.
kill -9 chains: a longer 2D run of each model with a checkpoint every few
milliseconds is SIGKILLed at random moments (seeded: MODELS_FAULTS_SEED)
several times in a row, each time resumed (or started again when no
checkpoint was written yet), until it finishes: every resume succeeds, the
result is the uninterrupted run's, no temporary file is left.
"""
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import time

import h5py

from reliab_util import check, failures, run_faulted, shim_preload

PDLA, SHIM, WORK = (os.path.abspath(a) for a in sys.argv[1:4])
PRELOAD = shim_preload(PDLA, SHIM)
rng = random.Random(int(os.environ.get("MODELS_FAULTS_SEED", "20261129")))
# 0 (the slow test models-faults-all): fault every fsync, rename/link and
# directory sync of a run, and the sampled writes below; N > 0 (the fast test:
# 6 in the release build, 3 in the sanitizer builds, tests/reliab/meson.build):
# N of each rarer call, sampled as the writes are, and half the sampled writes.
RARE = int(os.environ.get("MODELS_FAULTS_RARE", "0"))


def nw_samples(n):
    """How many writes to sample where the release build samples n."""
    return max(3, n // 2) if RARE else n
T0 = time.monotonic()
counts = {"runs": 0, "faulted": 0, "killed": 0, "resumes": 0, "chain kills": 0, "mid-write kills": 0}


def section(name):
    print("%6.1f s  %s" % (time.monotonic() - T0, name), flush=True)


def pdla(args, fault=None, fsize=None):
    """Run pdla; fault: FAULT_* settings for faultshim; fsize: RLIMIT_FSIZE
    in bytes. (exit status or -signal, stderr lines), or (None, ["timeout"])."""
    counts["runs"] += 1
    env = dict(os.environ)
    if fault is not None:
        env["LD_PRELOAD"] = PRELOAD
        env.update(fault)
    return run_faulted(PDLA, args, env, fsize)


def calls(args, op, prepare):
    """How many `op` calls faultshim counts in a run of args (after prepare())."""
    prepare()
    c = os.path.join(WORK, "count")
    if os.path.exists(c):
        os.unlink(c)
    pdla(args, fault={"FAULT_OP": op, "FAULT_COUNT": c})
    return int(open(c).read())


def sample(n, k):
    """Up to k of 1..n: the ends and evenly between."""
    if n <= k:
        return list(range(1, n + 1))
    return sorted({1, 2, n - 1, n} | {1 + (n - 1) * i // (k - 1) for i in range(k)})


def result(path):
    """What defines a run's result: every dataset and every attribute of
    cluster.h5 outside /Code, less /results' wall_s and model_bytes (a DLCA
    resume's /parameters count is the run's own too: it was set to N before).
    None when the file is not there; a string when it cannot be read."""
    if not os.path.exists(path):
        return None
    out = {}
    try:
        with h5py.File(path, "r") as f:
            def visit(name, obj):
                if name == "Code" or name.startswith("Code/"):
                    return
                if isinstance(obj, h5py.Dataset):
                    out[name] = obj[()].tobytes()
                for k, v in obj.attrs.items():
                    if (name, k) not in (("results", "wall_s"), ("results", "model_bytes")):
                        out[name + "@" + k] = repr(v)
            visit("", f)
            f.visititems(visit)
    except Exception as e:  # noqa: BLE001 - any failure to read is damage
        return "unreadable: %s" % e
    return out


def differs(a, b):
    """The first key where results a and b differ (None when equal)."""
    if not isinstance(a, dict) or not isinstance(b, dict):
        return None if a == b else "%.80r vs %.80r" % (a, b)
    for k in sorted(set(a) | set(b)):
        if a.get(k) != b.get(k):
            return k
    return None


def read(path):
    return open(path, "rb").read() if os.path.exists(path) else None


# What a run directory may hold once no pdla runs in it; anything else is a
# temporary file left behind.
OUTPUTS = {"cluster.h5", "cluster.xdmf2", "cluster-free.xdmf2", "checkpoint.h5", "checkpoint.prev.h5",
           "checkpoint.damaged.h5"}
SIDECARS = ("cluster.xdmf2", "cluster-free.xdmf2")


def left(d):
    return sorted(n for n in os.listdir(d) if n not in OUTPUTS) if os.path.isdir(d) else []


def writing(d):
    """Names of a checkpoint being written (what a kill mid-write leaves)."""
    return [n for n in left(d) if n.startswith(".checkpoint.h5.")]


def sidecar_bad(side, h5):
    """Does the XDMF sidecar `side` describe the datasets of h5 (each
    DataItem's Dimensions the dataset's shape)? None when it does or is
    not there, else what is wrong."""
    text = read(side)
    if text is None:
        return None
    items = re.findall(rb'<DataItem Dimensions="([0-9 ]+)"[^>]*Format="HDF">([^<:]+):([^<]+)</DataItem>', text)
    if not items:
        return "no HDF data items"
    try:
        with h5py.File(h5, "r") as f:
            for dims, name, ds in items:
                shape = tuple(int(x) for x in dims.split())
                if name != b"cluster.h5" or ds.decode() not in f or f[ds.decode()].shape != shape:
                    return "%s:%s %s" % (name.decode(), ds.decode(), shape)
    except (OSError, KeyError) as e:
        return "cluster.h5 unreadable: %s" % e
    return None


def has_checkpoint(d):
    return os.path.exists(os.path.join(d, "checkpoint.h5")) or os.path.exists(os.path.join(d, "checkpoint.prev.h5"))


class Case:
    """One model and system: the run, an older run it is --forced over, and
    the reference (the run never disturbed)."""

    def __init__(self, name, model, base, stop, old, ck, quiet):
        self.name, self.model, self.quiet = name, model, quiet
        # what /results says in a cluster.h5 of a run stopped before its end
        self.stop_key, self.stopped = (("results@stop", repr(b"running")) if model == "dlca" else
                                       ("results@stop_reason", repr(b"interrupted")))
        self.run = base + stop + ck + [quiet]
        self.resume_args = stop + ck + [quiet]
        self.ref_dir, self.old_dir = W(name + "-ref"), W(name + "-old")
        rc, err = pdla(self.run + ["--out", self.ref_dir])
        check(rc == 0 and not err, "%s: reference run: %s %r" % (name, rc, err[:2]))
        rc, err = pdla(old + [quiet, "--checkpoint", "--out", self.old_dir])
        check(rc == 0 and not err, "%s: older run: %s %r" % (name, rc, err[:2]))
        self.ref = result(os.path.join(self.ref_dir, "cluster.h5"))
        self.old_h5 = read(os.path.join(self.old_dir, "cluster.h5"))
        self.side = {w: {n: read(os.path.join(dd, n)) for n in SIDECARS}
                     for w, dd in (("new", self.ref_dir), ("old", self.old_dir))}

    def fresh(self, d):
        """d: a copy of the older run, for a --force run over it."""
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(self.old_dir, d)

    def resume(self, d, fault=None, fsize=None):
        counts["resumes"] += 1
        return pdla(["--model", self.model, "--resume", d] + self.resume_args, fault, fsize)

    def judge(self, tag, rc, err):
        """What a faulted run returned."""
        check(rc is not None, tag + ": did not end")
        if rc is None:
            return False
        check(rc in (0, 1, 2), "%s: exit %d %r" % (tag, rc, err[:2]))
        check(len(err) == (0 if rc == 0 else 1), "%s: exit %d with %d stderr lines %r" % (tag, rc, len(err), err[:3]))
        return True

    def outputs(self, tag, d, rc, killed=False):
        """cluster.h5: the older run's untouched, the new one complete, or
        (a run stopped by a failed checkpoint) a valid one of the stopped
        run; each sidecar absent or describing the cluster.h5 beside it (not
        looked at after a kill -9: between the two renames the older sidecar
        may still be there; the resume's are)."""
        path = os.path.join(d, "cluster.h5")
        h5 = read(path)
        which = "old" if h5 == self.old_h5 else "new"
        if which == "new":
            got = result(path)
            bad = differs(got, self.ref)
            if bad is not None and isinstance(got, dict) and got.get(self.stop_key) == self.stopped:
                which = "stopped"
            else:
                check(bad is None, "%s: cluster.h5 neither the older run's nor the new one (%s)" % (tag, bad))
        if rc == 0:
            check(which == "new", tag + ": exit 0 but cluster.h5 is not the new run's (%s)" % which)
            check(os.path.exists(os.path.join(d, "checkpoint.h5")), tag + ": exit 0 but no checkpoint.h5")
            for n in SIDECARS:
                check(read(os.path.join(d, n)) == self.side["new"][n], "%s: exit 0 but %s is not the new one" % (tag, n))
        if killed:
            return
        for n in SIDECARS:
            bad = sidecar_bad(os.path.join(d, n), path)
            check(bad is None, "%s: %s does not describe the %s cluster.h5 beside it: %s" % (tag, n, which, bad))

    def finish(self, tag, d, was_ck):
        """Resume what a faulted or killed run left: to the end and the
        reference's result when a checkpoint was there, else refused."""
        rc, err = self.resume(d)
        if not was_ck:  # refused; a new run then takes the directory
            check(rc == 2 and len(err) == 1, "%s: resume without a checkpoint: exit %s %r" % (tag, rc, err[:2]))
            rc, err = pdla(self.run + ["--out", d, "--force"])
        check(rc == 0 and not err, "%s: %s failed: exit %s %r" % (tag, "resume" if was_ck else "the next run",
                                                                  rc, err[:2]))
        if rc == 0:
            bad = differs(result(os.path.join(d, "cluster.h5")), self.ref)
            check(bad is None, "%s: the result not bit-identical to the uninterrupted run (%s)" % (tag, bad))
            for n in SIDECARS:
                check(read(os.path.join(d, n)) == self.side["new"][n], "%s: the end's %s differs" % (tag, n))
        check(not left(d), "%s: left when the directory was next taken: %r" % (tag, left(d)))


ERRS = [("ENOSPC", "1"), ("EIO", "0"), ("EDQUOT", "1"), ("SHORT", "0"), ("EIO", "1"), ("ENOSPC", "0")]


def fault_list(args, prepare, nwrites, small):
    """(description, fault, fsize) for one command: sampled write offsets,
    every rarer call, sampled file size limits."""
    out, seen = [], []
    nw = calls(args, "write", prepare)
    seen.append("%d writes" % nw)
    for i, k in enumerate(sample(nw, nwrites)):
        e, sticky = ERRS[i % len(ERRS)]
        out.append(("write #%d/%d %s%s" % (k, nw, e, " sticky" if sticky == "1" else ""),
                    {"FAULT_OP": "write", "FAULT_AT": str(k), "FAULT_ERR": e, "FAULT_STICKY": sticky}, None))
    for op in ("fsync", "fallocate", "stdio", "rename", "dirsync"):
        n = calls(args, op, prepare)
        seen.append("%d %s" % (n, op))
        for i, k in enumerate(sample(n, RARE) if RARE else range(1, n + 1)):
            e = ("EIO", "ENOSPC", "EDQUOT")[i % 3]
            out.append(("%s #%d/%d %s" % (op, k, n, e), {"FAULT_OP": op, "FAULT_AT": str(k), "FAULT_ERR": e}, None))
    for x in ((0, 30000) if small else (0, 4096, 20000, 45000)):
        out.append(("file size limit %d" % x, None, x))
    print("  counted: %s; %d faulted runs" % (", ".join(seen), len(out)), flush=True)
    return out


def kill_list(args, prepare, nwrites):
    """kill -9 just before the k-th write (sampled), and every fsync and
    rename/link."""
    out = []
    nw = calls(args, "write", prepare)
    for k in sample(nw, nwrites):
        out.append(("kill -9 at write #%d/%d" % (k, nw), {"FAULT_OP": "write", "FAULT_AT": str(k), "FAULT_SIGNAL": "9"}))
    for op in ("fsync", "rename"):
        n = calls(args, op, prepare)
        for k in sample(n, RARE) if RARE else range(1, n + 1):
            out.append(("kill -9 at %s #%d/%d" % (op, k, n), {"FAULT_OP": op, "FAULT_AT": str(k), "FAULT_SIGNAL": "9"}))
    return out


def faulted_runs(c, small):
    """Faults in a --force run with checkpoints over the older run."""
    d = W(c.name + "-f")
    args = c.run + ["--out", d, "--force"]
    for desc, fault, fsize in fault_list(args, lambda: c.fresh(d), nw_samples(5 if small else 10), small):
        tag = "%s %s" % (c.name, desc)
        c.fresh(d)
        counts["faulted"] += 1
        rc, err = pdla(args, fault, fsize)
        if not c.judge(tag, rc, err):
            continue
        c.outputs(tag, d, rc)
        check(not left(d), "%s: left %r" % (tag, left(d)))
        c.finish(tag, d, has_checkpoint(d))


def killed_runs(c):
    """kill -9 at exact calls of the --force run, then a resume."""
    d = W(c.name + "-k")
    args = c.run + ["--out", d, "--force"]
    for desc, fault in kill_list(args, lambda: c.fresh(d), nw_samples(8)):
        tag = "%s %s" % (c.name, desc)
        c.fresh(d)
        counts["killed"] += 1
        rc, err = pdla(args, fault)
        check(rc == -signal.SIGKILL, "%s: exit %s %r, not killed" % (tag, rc, err[:2]))
        if writing(d):
            counts["mid-write kills"] += 1
        c.outputs(tag, d, rc, killed=True)
        c.finish(tag, d, has_checkpoint(d))


def faulted_resumes(c, half):
    """Faults in a resumed run (from a checkpoint half way, made by `half`),
    then a resume of what it left."""
    src = W(c.name + "-half")
    rc, err = pdla(half + [c.quiet, "--out", src])
    check(rc == 0 and not err, "%s: half-way run: %s %r" % (c.name, rc, err[:2]))
    d = W(c.name + "-rf")

    def fresh():
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(src, d)
    faults = fault_list(["--model", c.model, "--resume", d] + c.resume_args, fresh, nw_samples(6), True)
    for desc, fault, fsize in faults:
        tag = "%s resumed, %s" % (c.name, desc)
        fresh()
        counts["faulted"] += 1
        rc, err = c.resume(d, fault, fsize)
        if not c.judge(tag, rc, err):
            continue
        check(not left(d), "%s: left %r" % (tag, left(d)))
        if rc == 0:
            bad = differs(result(os.path.join(d, "cluster.h5")), c.ref)
            check(bad is None, "%s: exit 0 but not the uninterrupted run's result (%s)" % (tag, bad))
        check(has_checkpoint(d), tag + ": no checkpoint left")
        c.finish(tag, d, True)


def checkpoint_id(d):
    """Which checkpoint.h5 is in d (each write renames a new file there)."""
    try:
        st = os.stat(os.path.join(d, "checkpoint.h5"))
        return st.st_ino, st.st_mtime_ns
    except OSError:
        return None


def kill_later(p, d, j, extra):
    """SIGKILL p once j more checkpoints have appeared in d, `extra` seconds
    after the last (its next one may then be half written). The exit status."""
    seen, got, t0 = checkpoint_id(d), 0, time.monotonic()
    while got < j and p.poll() is None and time.monotonic() - t0 < 60:
        time.sleep(0.002)
        now = checkpoint_id(d)
        if now != seen:
            seen, got = now, got + 1
    time.sleep(extra)
    if p.poll() is None:
        p.send_signal(signal.SIGKILL)
    return p.wait()


def chain(c, kills):
    """kill -9 at random moments (a random count of checkpoints, 0 to 3, then
    up to 20 ms: the same spread of kills on a fast or a loaded machine),
    resumed each time, until the run ends."""
    d = W(c.name + "-chain")
    shutil.rmtree(d, ignore_errors=True)
    args = [PDLA] + c.run + ["--out", d]
    n, mid, ended, had_ck = 0, 0, False, False
    while n < kills:
        p = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        counts["runs"] += 1
        rc = kill_later(p, d, rng.choice((0, 1, 1, 2, 3)), rng.uniform(0, 0.02))
        err = p.stderr.read().decode("utf-8", "replace").strip()
        p.stderr.close()
        if rc != -signal.SIGKILL:  # it ended first: it must have succeeded
            check(rc == 0 and not err, "%s chain: run %d (%s) ended with %s %r" % (c.name, n, args[1:4], rc, err[:200]))
            ended = True
            break
        n += 1
        counts["chain kills"] += 1
        if writing(d):
            mid += 1
            counts["mid-write kills"] += 1
        check(has_checkpoint(d) or not had_ck, "%s chain: kill %d left no checkpoint, where one was" % (c.name, n))
        had_ck = has_checkpoint(d)
        if had_ck:
            args = [PDLA, "--model", c.model, "--resume", d] + c.resume_args
            counts["resumes"] += 1
        else:  # killed before its first checkpoint: start again
            args = [PDLA] + c.run + ["--out", d, "--force"]
    if not ended:
        rc, err = c.resume(d)
        check(rc == 0 and not err, "%s chain: final resume: exit %s %r" % (c.name, rc, err[:2]))
    bad = differs(result(os.path.join(d, "cluster.h5")), c.ref)
    check(bad is None, "%s chain (%d kills): result not the uninterrupted run's (%s)" % (c.name, n, bad))
    check(not left(d), "%s chain: left %r" % (c.name, left(d)))
    print("  %s: %d kills, %d during a checkpoint write%s" % (c.name, n, mid, ", then it ended" if ended else ""))


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
W = lambda *p: os.path.join(WORK, *p)  # noqa: E731

D2 = ["--model", "dlca", "--dim", "2", "--box", "96", "--fill", "0.05"]
D3 = ["--model", "dlca", "--dim", "3", "--box", "16", "--fill", "0.05"]
E2 = ["--model", "event", "--dim", "2", "--particles", "600", "--packing", "0.15", "--stick-p", "0.5",
      "--seed-radius", "2", "--seed", "3"]
E3 = ["--model", "event", "--dim", "3", "--particles", "500", "--packing", "0.1", "--stick-p", "0.5",
      "--seed-radius", "1.5", "--seed", "3"]
EVERY_TICK = ["--checkpoint-every", "0.000000001"]  # every tick of the event loop

section("cases: reference and older runs")
cases = [  # (case, a run that stops half way with a checkpoint, small)
    (Case("dlca-2d", "dlca", D2 + ["--seed", "2"], ["--until-clusters", "3"],
          ["--model", "dlca", "--dim", "2", "--box", "64", "--fill", "0.05", "--until-clusters", "5", "--seed", "1"],
          ["--checkpoint-attempts", "4000"], "-q"), D2 + ["--seed", "2", "--until-clusters", "12", "--checkpoint"],
     False),
    (Case("event-2d", "event", E2, ["--t-max", "6"],
          ["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--t-max", "2", "--seed", "1"],
          EVERY_TICK, "--quiet"), E2 + ["--t-max", "3", "--checkpoint"], False),
    (Case("dlca-3d", "dlca", D3 + ["--seed", "2"], ["--until-clusters", "2"],
          ["--model", "dlca", "--dim", "3", "--box", "12", "--fill", "0.05", "--until-clusters", "2", "--seed", "1"],
          ["--checkpoint-attempts", "200"], "-q"), None, True),
    (Case("event-3d", "event", E3, ["--t-max", "3"],
          ["--model", "event", "--dim", "3", "--particles", "200", "--packing", "0.1", "--t-max", "3", "--seed", "1"],
          EVERY_TICK, "--quiet"), None, True),
]
for c, half, small in cases:
    section("%s: write faults in a --force run with checkpoints, then resume" % c.name)
    faulted_runs(c, small)
    if half:
        section("%s: write faults in a resumed run, then resume" % c.name)
        faulted_resumes(c, half)
    if not small:
        section("%s: kill -9 at exact calls, then resume" % c.name)
        killed_runs(c)

section("event: cluster.h5's rename is made durable (its directory synced)")
# Before, the event writer renamed cluster.h5 into place and never synced
# the directory, so a crash just after a run that said "wrote" could leave
# the older file or none (DLA and DLCA sync it). The last directory sync of
# a run without checkpoints is that one: failed, the run exits 1 with one
# line, the new cluster.h5 in place with its sidecars. One of the run's
# directory syncs must be that one.
d_sync = os.path.join(WORK, "event-dirsync")
sync_args = ["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--t-max", "1",
             "--seed", "4", "--out", d_sync, "--force", "--quiet"]
n_sync = calls(sync_args, "dirsync", lambda: shutil.rmtree(d_sync, ignore_errors=True))
found = 0
for k in range(1, n_sync + 1):
    shutil.rmtree(d_sync, ignore_errors=True)
    rc, lines = pdla(sync_args, fault={"FAULT_OP": "dirsync", "FAULT_AT": str(k)})
    if not (rc == 1 and len(lines) == 1 and "could not be synced" in lines[0]):
        continue
    found += 1
    h5, side = os.path.join(d_sync, "cluster.h5"), os.path.join(d_sync, "cluster-free.xdmf2")
    check(os.path.exists(h5) and os.path.exists(side) and not sidecar_bad(side, h5),
          "event, cluster.h5's directory sync failed: cluster.h5 not in place or its sidecar missing or not its")
check(found == 1, "event: %d of the run's %d directory syncs follow cluster.h5's rename (want 1)" % (found, n_sync))

section("kill -9 chains")
CHAINS = [
    Case("dlca-chain", "dlca", ["--model", "dlca", "--dim", "2", "--box", "384", "--fill", "0.05", "--seed", "3"],
         ["--until-clusters", "5"], D2 + ["--seed", "1", "--until-clusters", "3"], ["--checkpoint-attempts", "5000"],
         "-q"),
    Case("event-chain", "event", ["--model", "event", "--dim", "2", "--particles", "6000", "--packing", "0.2",
                                  "--stick-p", "0.5", "--seed-radius", "2", "--series-dt", "0.5", "--seed", "3"],
         ["--t-max", "40"],
         E2 + ["--t-max", "6"], EVERY_TICK, "--quiet"),
]
for c in CHAINS:
    chain(c, 10)

section("done")
print("models-faults: %s; %d failures" % (", ".join("%d %s" % (v, k) for k, v in counts.items()), len(failures)))
_ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print("children's CPU time: %.1f s user, %.1f s system" % (_ru.ru_utime, _ru.ru_stime))
sys.exit(1 if failures else 0)
