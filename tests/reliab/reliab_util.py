"""reliab_util.py - the helpers the reliab scripts share (imported by
models_cli.py, cli_items.py, faults.py, hostile.py, hostile_models.py,
ens_adversary.py, scene_models.py and models_faults.py; each runs as
`python3 SCRIPT.py`, so this file, beside them, is on sys.path;
tests/ensemble/test_ens_builds.py, test_ens_json.py, tests/formats/test_xdmf_text.py
and the `pdla check` tests tests/tools/test_check*.py put this folder on
their path)."""
import os
import shutil
import subprocess
import time

# What failed, in the order seen; a script exits 1 when it is not empty.
failures = []


class Tally:
    """Counted checks for scripts that end with "N checks, N failed"
    (tests/formats/test_xdmf_text.py, tests/ensemble/test_ens_json.py)."""

    def __init__(self):
        self.checks = self.fails = 0

    def check(self, ok, what):
        self.checks += 1
        if not ok:
            self.fails += 1
            print("FAIL:", what, flush=True)
        return ok

    def done(self):
        import sys
        print("%d checks, %d failed" % (self.checks, self.fails))
        sys.exit(1 if self.fails else 0)


def check(ok, what):
    """Record and print a failure unless ok."""
    if not ok:
        failures.append(what)
        print("FAIL:", what, flush=True)


def runner(exe, timeout):
    """pdla(*ARGS) -> (exit status, stderr text), or (None, "timeout") when it
    ran past `timeout` seconds (then it is killed)."""
    default = timeout

    def pdla(*args, env=None, timeout=default, cwd=None):
        e = dict(os.environ)
        e.update(env or {})
        try:
            p = subprocess.run([exe] + list(args), capture_output=True, timeout=timeout, env=e, cwd=cwd)
        except subprocess.TimeoutExpired:
            return None, "timeout"
        return p.returncode, p.stderr.decode("utf-8", "replace")
    return pdla


def shim_preload(exe, shim):
    """LD_PRELOAD value for faultshim under `exe`: an ASan build needs its
    runtime loaded before the shim."""
    ldd = subprocess.run(["ldd", exe], capture_output=True, text=True).stdout
    asan = [ln.split("=>")[1].split()[0] for ln in ldd.splitlines() if "libasan" in ln and "=>" in ln]
    return ":".join(asan + [shim])


def run_faulted(exe, args, env, fsize=None, timeout=120):
    """Run EXE ARGS in environment env (faultshim's FAULT_* and LD_PRELOAD
    set by the caller), with RLIMIT_FSIZE fsize bytes when given (SIGXFSZ
    ignored: EFBIG instead of a core dump). (exit status or -signal, stderr
    lines), or (None, ["timeout"])."""
    import resource
    import signal

    def limit():
        if fsize is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    try:
        p = subprocess.run([exe] + args, capture_output=True, env=env, preexec_fn=limit, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, ["timeout"]
    err = p.stderr.decode("utf-8", "replace").rstrip("\n")
    return p.returncode, err.split("\n") if err else []


def one_line(err):
    """Is the stderr text one line?"""
    return len(err.rstrip("\n").split("\n")) == 1


def run_rss(exe, args, limit, errf, env=None):
    """Run EXE ARGS with stderr into the open binary file errf; (exit status
    or -signal, stderr bytes, peak RSS in KB of this run alone - wait4 gives
    each child's own rusage), or (None, b"", None) when it did not end within
    `limit` seconds (then it is killed)."""
    rc, err, ru = run_usage(exe, args, limit, errf, env)
    return rc, err, ru.ru_maxrss if ru else None


def run_usage(exe, args, limit, errf, env=None):
    """As run_rss, with the run's whole rusage (CPU times, peak RSS) in
    place of its peak RSS."""
    pid = os.fork()
    if pid == 0:
        try:
            os.dup2(errf.fileno(), 2)
            devnull = os.open(os.devnull, os.O_RDWR)
            os.dup2(devnull, 0)
            os.dup2(devnull, 1)
            os.execve(exe, [exe] + args, env if env is not None else os.environ)
        finally:
            os._exit(127)
    t0 = time.monotonic()
    while True:
        wpid, status, ru = os.wait4(pid, os.WNOHANG)
        if wpid == pid:
            break
        if time.monotonic() - t0 > limit:
            os.kill(pid, 9)
            os.wait4(pid, 0)
            return None, b"", None
        time.sleep(0.01)
    errf.seek(0)
    err = errf.read()
    rc = os.WEXITSTATUS(status) if os.WIFEXITED(status) else -os.WTERMSIG(status)
    return rc, err, ru


def run_text(args, timeout=120):
    """Run args with stdin from /dev/null: (exit status, stdout text, stderr
    text), bytes that are not UTF-8 replaced (tests/tools/test_check*.py)."""
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                       timeout=timeout)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


def forged_copy(src, tmp, name, fn):
    """A copy of the HDF5 file src as TMP/NAME.h5, changed by fn(f) with f
    the copy opened by h5py in r+ mode: the copy's path."""
    import h5py
    dst = os.path.join(tmp, name + ".h5")
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        fn(f)
    return dst


def child_peak_rss(args, timeout):
    """Run args from a fresh python, whose RUSAGE_CHILDREN is then that run's
    alone: (exit status, its stderr text, its peak RSS in KB)."""
    import sys
    code = ("import resource, subprocess, sys\n"
            "p = subprocess.run(sys.argv[1:], capture_output=True)\n"
            "sys.stderr.write(p.stderr.decode(errors='replace'))\n"
            "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n")
    p = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, timeout=timeout)
    rc, kb = p.stdout.decode().split()
    return int(rc), p.stderr.decode(errors="replace"), int(kb)
