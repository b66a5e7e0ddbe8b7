#!/usr/bin/python3
"""late_signal.py - SIGTERM or SIGINT that arrives after the work is done,
while the final file is being written.

Usage: late_signal.py PDLA FAULTSHIM WORKDIR

A signal stops the growth: pdla writes what it has and ends by that signal
(exit 130/143, "stopped by signal"), so a calling shell or a batch script
sees an interrupted command. A signal that arrives once every particle or
cluster is grown interrupts nothing: the final write completes and pdla
reports success and exits 0 (the rule in src/cli/main.c, ens_cmd.c and
dlca_cmd.c). Before, the write completed, success was printed, and then pdla
ended by the signal (143): a batch script resubmitted a finished job, and
the output said "done" while the status said "killed".

The signal is made deterministic with faultshim: FAULT_PATH picks the
final file's temporary name, FAULT_SIGNAL raises the signal during the
first write to it (or during the k-th fdatasync of the ensemble journal).
For every case: exit 0 <=> success printed and the file complete (equal to
a run without the signal); exit by the signal <=> no success claimed and a
resume gives the uninterrupted result.
"""
import os
import shutil
import signal
import subprocess
import sys

import h5py
import numpy as np

from reliab_util import check, failures, shim_preload

PDLA, SHIM, WORK = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2]), sys.argv[3]
PRELOAD = shim_preload(PDLA, SHIM)


def run(*args, env=None):
    """(exit status, or -signal; stdout; stderr)."""
    e = dict(os.environ)
    e.update(env or {})
    p = subprocess.run([PDLA] + list(args), capture_output=True, timeout=300, env=e)
    return p.returncode, p.stdout.decode("utf-8", "replace"), p.stderr.decode("utf-8", "replace")


def shim(path_part, sig, at=1, op="write", count=None):
    env = {"LD_PRELOAD": PRELOAD, "FAULT_PATH": path_part, "FAULT_OP": op, "FAULT_AT": str(at),
           "FAULT_SIGNAL": str(int(sig))}
    if count:
        env["FAULT_COUNT"] = count
    return env


def fired(count):
    """How many calls the shim counted on the chosen file (the signal went
    off when this reaches FAULT_AT)."""
    try:
        return int(open(count).read())
    except (OSError, ValueError):
        return -1


def same_h5(a, b, names):
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        return all(np.array_equal(fa[n][()], fb[n][()]) for n in names)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
os.chdir(WORK)

# ---- pdla ensemble: the signal during the write of ensemble.h5 ------------
ENS = ["--clusters", "3", "--target", "1500", "--seed", "5"]
ENS_DATA = ["/clusters/rg_diam", "/clusters/seed", "/clusters/jumps", "/clusters/rg_final_diam"]
rc, out, err = run("ensemble", *ENS, "--out", "ens-ref")
check(rc == 0 and "ensemble: 3 clusters" in out, "reference ensemble: %d %r" % (rc, err))
for sig in (signal.SIGTERM, signal.SIGINT):
    d, cnt = "ens-late-%d" % sig, "count-ens-%d" % sig
    rc, out, err = run("ensemble", *ENS, "--out", d, env=shim("ensemble.h5.tmp.", sig, count=cnt))
    what = "ensemble, signal %d during the write of ensemble.h5" % sig
    check(fired(cnt) >= 1, "%s: the shim never saw the write (%d)" % (what, fired(cnt)))
    check(rc == 0, "%s: exit %d, want 0 (all clusters were recorded): %r" % (what, rc, err))
    check("ensemble: 3 clusters" in out, "%s: no success line: %r" % (what, out))
    check("stopped" not in err and "resume with" not in err, "%s: claims an interruption: %r" % (what, err))
    check("signal received after every cluster was recorded" in err, "%s: no note of the late signal: %r" % (what, err))
    check(os.path.exists(d + "/ensemble.h5") and same_h5(d + "/ensemble.h5", "ens-ref/ensemble.h5", ENS_DATA),
          "%s: ensemble.h5 missing or not the uninterrupted one" % what)

# ---- the signal at each fdatasync of the journal --------------------------
# The last one is the last cluster's record: every cluster is recorded, so
# the run completes (exit 0, ensemble.h5); an earlier one stops the run
# (exit by the signal, no success line) and a resume completes it.
cnt = "count-journal"
rc, out, err = run("ensemble", *ENS, "--out", "ens-count", env=shim("clusters.journal", 0, at=0, op="fsync",
                                                                    count=cnt))
n_sync = fired(cnt)
check(rc == 0 and n_sync >= 3, "counting the journal's syncs: %d, %d %r" % (n_sync, rc, err))
for k in range(1, n_sync + 1):
    d = "ens-sync-%d" % k
    rc, out, err = run("ensemble", *ENS, "--out", d, env=shim("clusters.journal", signal.SIGTERM, at=k, op="fsync"))
    what = "ensemble, SIGTERM at journal sync %d of %d" % (k, n_sync)
    success = "ensemble: 3 clusters" in out
    if rc == 0:
        check(success and same_h5(d + "/ensemble.h5", "ens-ref/ensemble.h5", ENS_DATA),
              "%s: exit 0 without the complete ensemble: %r" % (what, out))
    else:
        check(rc == -signal.SIGTERM, "%s: exit %d, want 0 or the signal: %r" % (what, rc, err))
        check(not success and "stopped by signal" in err, "%s: ended by the signal but %r / %r" % (what, out, err))
        check(not os.path.exists(d + "/ensemble.h5"), "%s: ended by the signal but wrote ensemble.h5" % what)
        rc2, _, err2 = run("ensemble", "--resume", d, "-q")
        check(rc2 == 0 and same_h5(d + "/ensemble.h5", "ens-ref/ensemble.h5", ENS_DATA),
              "%s: the resume after it: %d %r" % (what, rc2, err2))
    if k == n_sync:
        check(rc == 0, "%s: the last record was synced, yet exit %d: %r" % (what, rc, err))

# ---- pdla (DLA), DLCA and the event model: the signal during cluster.h5 ----
MODELS = {
    "dla": (["--dim", "2", "--target", "3000", "--seed", "3"], "particles"),
    "dlca": (["--model", "dlca", "--dim", "2", "--box", "64", "--fill", "0.05", "--until-clusters", "20",
              "--seed", "3"], "model dlca"),
    "event": (["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--t-max", "2",
               "--seed", "3"], "model event"),
}
for model, (args, said) in MODELS.items():
    ref = model + "-ref"
    rc, out, err = run(*args, "--out", ref)
    check(rc == 0 and said in out, "%s reference: %d %r" % (model, rc, err))
    for sig in (signal.SIGTERM, signal.SIGINT):
        d, cnt = "%s-late-%d" % (model, sig), "count-%s-%d" % (model, sig)
        rc, out, err = run(*args, "--out", d, env=shim("cluster.h5.", sig, count=cnt))
        what = "%s, signal %d during the write of cluster.h5" % (model, sig)
        check(fired(cnt) >= 1, "%s: the shim never saw the write (%d)" % (what, fired(cnt)))
        check(rc == 0, "%s: exit %d, want 0 (the run had finished): %r" % (what, rc, err))
        check(said in out and "cluster.h5" in out, "%s: no summary naming cluster.h5: %r" % (what, out))
        check("stopped by signal" not in err and "stop: signal" not in out and "interrupt" not in out,
              "%s: claims an interruption: %r / %r" % (what, out, err))
        check(os.path.exists(d + "/cluster.h5"), "%s: no cluster.h5" % what)
        note = ("signal received after growth had finished" if model == "dla" else
                "signal received after the run had finished")
        lines = err.splitlines()
        check(len(lines) == 1 and note + "; output complete" in lines[0], "%s: no note of the late signal: %r" % (what, err))
        if model == "dla":
            check(same_h5(d + "/cluster.h5", ref + "/cluster.h5", ["/cluster/positions"]),
                  "%s: cluster.h5 is not the uninterrupted one" % what)

print("%s (%d failures)" % ("ok" if not failures else "FAILED", len(failures)))
sys.exit(1 if failures else 0)
