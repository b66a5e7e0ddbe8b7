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

print("models-cli: %d failures" % len(failures))
sys.exit(1 if failures else 0)
