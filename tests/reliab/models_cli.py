#!/usr/bin/python3
"""models_cli.py PDLA WORKDIR - run-directory safety of the DLCA and event
commands (session 11; the DLA and ensemble commands are covered by
cli_items.py and tests/ensemble).

Two processes on one run directory: while a run with --checkpoint holds
DIR, a second `--force` run into DIR and a `--resume DIR` must be refused
with one line (exit 2) and the first run, stopped by SIGTERM, must leave a
checkpoint that resumes. Before the fix neither model locked its directory:
the second run wrote over the first's temporary files, the DLCA survivor
reported a 179-byte checkpoint.h5 that no resume could open, and both event
runs lost cluster.h5.

Also: a --force run over an older run removes the older run's checkpoints
(as the DLA command does), and the temporary files of a killed event writer
go when the directory is next taken.
"""
import fcntl
import os
import shutil
import signal
import subprocess
import sys
import time

PDLA, WORK = sys.argv[1], sys.argv[2]
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what, flush=True)


def pdla(*args, timeout=120):
    try:
        p = subprocess.run([PDLA] + list(args), capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, "timeout"
    return p.returncode, p.stderr.decode("utf-8", "replace")


def one_line(err):
    return len(err.rstrip("\n").split("\n")) == 1


def locked(d):
    """Does some process hold the flock of directory d?"""
    try:
        fd = os.open(d, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return False
    except BlockingIOError:
        return True
    finally:
        os.close(fd)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

MODELS = {
    # long runs (minutes) that a SIGTERM ends; the resume stops at once
    "dlca": (["--model", "dlca", "--dim", "2", "--box", "1024", "--fill", "0.05", "--until-clusters", "2",
              "--seed", "1", "--checkpoint", "-q"], ["--max-attempts", "1", "-q"]),
    "event": (["--model", "event", "--dim", "2", "--particles", "50000", "--packing", "0.2", "--t-max", "1e6",
               "--seed", "1", "--checkpoint", "--quiet"], ["--t-max", "1e-9", "--quiet"]),
}
for model, (run, stop_now) in MODELS.items():
    d = os.path.join(WORK, model)
    first = subprocess.Popen([PDLA] + run + ["--out", d], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    t0 = time.monotonic()
    while not locked(d) and first.poll() is None and time.monotonic() - t0 < 60:
        time.sleep(0.02)
    check(locked(d), "%s: the run does not lock its directory" % model)
    rc, err = pdla(*(run + ["--out", d, "--force"]))
    check(rc == 2 and one_line(err) and "in use by another pdla process" in err,
          "%s: a second --force run on a directory in use: exit %r, %r" % (model, rc, err[-300:]))
    rc, err = pdla("--model", model, "--resume", d, *stop_now)
    check(rc == 2 and one_line(err) and "in use by another pdla process" in err,
          "%s: --resume of a directory in use: exit %r, %r" % (model, rc, err[-300:]))
    first.send_signal(signal.SIGTERM)
    try:
        _, ferr = first.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        first.kill()
        _, ferr = first.communicate()
    check(first.returncode == 0, "%s: the first run after SIGTERM: exit %r, %r" % (model, first.returncode,
                                                                                   ferr[-300:]))
    rc, err = pdla("--model", model, "--resume", d, *stop_now)
    check(rc == 0, "%s: resume of the first run's checkpoint: exit %r, %r" % (model, rc, err[-300:]))

# --force over an older run that has checkpoints: they go with it. Before,
# a later --resume grew the old run (another box, other particles) and wrote
# it over the new run's cluster.h5 (exit 0, not a word).
OLDNEW = {
    "dlca": (["--model", "dlca", "--dim", "2", "--box", "48", "--fill", "0.05", "--until-clusters", "20", "--seed", "4",
              "--checkpoint", "-q"],
             ["--model", "dlca", "--dim", "2", "--box", "64", "--fill", "0.05", "--until-clusters", "20", "--seed",
              "5", "--force", "-q"], ["--until-clusters", "10", "-q"]),
    "event": (["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--t-max", "2", "--seed",
               "3", "--checkpoint", "--quiet"],
              ["--model", "event", "--dim", "2", "--particles", "500", "--packing", "0.1", "--t-max", "2", "--seed",
               "4", "--force", "--quiet"], ["--t-max", "3", "--quiet"]),
}
for model, (old, new, more) in OLDNEW.items():
    d = os.path.join(WORK, model + "-force")
    rc, err = pdla(*(old + ["--out", d]))
    check(rc == 0, "%s: the older run: %r" % (model, err))
    rc, err = pdla(*(new + ["--out", d]))
    check(rc == 0, "%s: the --force run: %r" % (model, err))
    with open(os.path.join(d, "cluster.h5"), "rb") as fh:
        written = fh.read()
    rc, err = pdla("--model", model, "--resume", d, *more)
    check(rc == 2 and one_line(err), "%s: --resume after --force over an older run: exit %r, %r" % (model, rc, err))
    with open(os.path.join(d, "cluster.h5"), "rb") as fh:
        check(fh.read() == written, "%s: the --force run's cluster.h5 was replaced" % model)

# What an event writer killed with -9 leaves (.checkpoint.h5.tmp.PID, as
# large as a checkpoint, one per kill) goes when the directory is next
# taken; before, such files piled up for the life of the run.
d = os.path.join(WORK, "event-stale")
rc, err = pdla(*(OLDNEW["event"][0] + ["--out", d]))
check(rc == 0, "event-stale base run: %r" % err)
for name in (".checkpoint.h5.tmp.999999", "cluster.h5.tmp"):
    with open(os.path.join(d, name), "wb") as fh:
        fh.write(b"x" * 4096)
rc, err = pdla("--model", "event", "--resume", d, "--t-max", "3", "--quiet")
check(rc == 0, "event-stale resume: %r" % err)
left = sorted(n for n in os.listdir(d) if "tmp" in n)
check(not left, "event: temporary files of a killed writer left after a resume: %r" % left)

print("models-cli: %d failures" % len(failures))
sys.exit(1 if failures else 0)
