#!/usr/bin/python3
"""test_bind.py PDLA - `--bind core` and `--bind none` (README, Threads).

README: "`--bind core` pins one worker per physical core with hwloc; the
binding and the topology (cores, packages, caches) go into the file's
provenance", `/results` holds `binding`, `/parameters` `bind` as a string,
and `--bind none` is the default. Checked on 2-3 worker runs of a few
thousand particles (a serial phase of 300, smaller than the target, so the
workers run):

- default (no --bind): /parameters bind "none", /results binding "none",
  the summary's threads line "binding none", --stats-json "binding": "none";
- --bind core with 3 workers: bind "core", binding "core: 0 1 2" with each
  worker's core the hwloc logical index i mod the machine's cores (on a
  2-core machine "core: 0 1 0": more workers than cores share cores in
  turn), the cores read from /Code topology ("P packages, C cores, U PUs,
  L3 ..."), in the summary and --stats-json too;
- the pinning itself (Linux /proc): while 2 bound workers run, exactly two
  threads of the process have a CPU mask of their own, each no larger than
  one core's PUs, disjoint when the machine has 2 cores or more; with
  --bind none every thread keeps the process's mask. Skipped where this
  process cannot change its own CPU mask (then no binding can work).
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

TALLY = Tally()
check = TALLY.check
PDLA = os.path.abspath(sys.argv[1])
SMALL = ["--dim", "2", "--serial-until", "300", "--target", "3000", "--seed", "5", "-q"]
TOPOLOGY = re.compile(r"^(\d+) packages?, (\d+) cores?, (\d+) PUs?, L3 (none|\d+ x \d+ (B|KiB|MiB|GiB))$")


def s(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def grown(tmp, name, extra):
    """Runs a small threaded growth; (its cluster.h5 attributes, summary text, stats JSON) or None."""
    d = os.path.join(tmp, name)
    js = os.path.join(tmp, name + ".json")
    p = subprocess.run([PDLA] + SMALL + extra + ["--out", d, "--stats-json", js], capture_output=True, text=True,
                       timeout=120)
    if not check(p.returncode == 0, "%s: exit %d: %s" % (name, p.returncode, p.stderr.strip()[-300:])):
        return None
    with h5py.File(os.path.join(d, "cluster.h5"), "r") as f:
        attrs = {g: {k: s(v) for k, v in f[g].attrs.items()} for g in ("parameters", "results", "Code")}
    with open(os.path.join(d, "summary.txt")) as fh:
        summary = fh.read()
    with open(js) as fh:
        stats = json.load(fh)
    return attrs, summary, stats


def masks(pid):
    """{tid: frozenset of CPUs} of a live process's threads (Linux /proc)."""
    out = {}
    for tid in os.listdir("/proc/%d/task" % pid):
        try:
            with open("/proc/%d/task/%s/status" % (pid, tid)) as fh:
                for line in fh:
                    if line.startswith("Cpus_allowed_list:"):
                        cpus = set()
                        for part in line.split(":", 1)[1].strip().split(","):
                            a, _, b = part.partition("-")
                            cpus.update(range(int(a), int(b or a) + 1))
                        out[int(tid)] = frozenset(cpus)
        except (FileNotFoundError, ProcessLookupError):
            pass
    return out


def running_masks(tmp, name, bind):
    """Starts 2 workers that would run long, waits (up to 20 s) until the
    process has at least 3 threads and its threads and their masks have not
    changed for a second (under ThreadSanitizer its background thread makes
    3 before the second worker exists: CI, session 31), reads every thread's
    CPU mask, kills the run. (main mask, [worker masks])."""
    p = subprocess.Popen([PDLA, "--dim", "2", "--threads", "2", "--serial-until", "300", "--target", "1e8",
                          "--no-output", "-q"] + bind, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        t0, got, since = time.time(), {}, time.time()
        while p.poll() is None and time.time() < t0 + 20:
            now = masks(p.pid)
            if now != got:
                got, since = now, time.time()
            elif len(got) >= 3 and time.time() > since + 1.0:
                break
            time.sleep(0.02)
        alive = p.poll() is None
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    # 3 threads: main and 2 workers; a sanitizer's runtime adds its own
    # (ThreadSanitizer's background thread, with the process's mask), so
    # at least 3, and the workers are told apart by the caller
    if not check(alive and len(got) >= 3 and p.pid in got, "%s: want 3 threads of a live run, saw %d (alive %s): %s" %
                 (name, len(got), alive, p.stderr.read().decode(errors="replace")[-300:])):
        return None, []
    main = got.pop(p.pid)
    return main, list(got.values())


def can_pin():
    """Whether a process here may set its own CPU mask to one CPU."""
    r = subprocess.run([sys.executable, "-c", "import os; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})"],
                       capture_output=True)
    return r.returncode == 0


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-bind.")
    try:
        run_checks(tmp)
    finally:
        subprocess.run(["rm", "-rf", tmp])
    TALLY.done()


def run_checks(tmp):
    # ---- the default: no binding ---------------------------------------------------------
    r = grown(tmp, "none", ["--threads", "2"])
    if r:
        a, summary, stats = r
        check(a["parameters"].get("bind") == "none", "default: /parameters bind %r, want 'none'" %
              a["parameters"].get("bind"))
        check(a["results"].get("binding") == "none", "default: /results binding %r, want 'none'" %
              a["results"].get("binding"))
        check(a["results"].get("threads") == "2", "default: /results threads %r, want 2" % a["results"].get("threads"))
        check(re.search(r"^threads +2 after 300 serial particles .*binding none\)$", summary, re.M) is not None,
              "default: summary.txt has no 'binding none' threads line:\n%s" % summary)
        check(stats.get("binding") == "none", "default: --stats-json binding %r" % stats.get("binding"))

    # ---- --bind core, 3 workers: one core each, in turn ----------------------------------
    r = grown(tmp, "core", ["--threads", "3", "--bind", "core"])
    cores = pus = None
    if r:
        a, summary, stats = r
        topo = a["Code"].get("topology", "")
        m = TOPOLOGY.match(topo)
        if check(m is not None, "/Code topology %r is not 'P packages, C cores, U PUs, L3 ...'" % topo):
            packages, cores, pus = int(m.group(1)), int(m.group(2)), int(m.group(3))
            check(1 <= packages <= cores <= pus <= (os.cpu_count() or pus),
                  "/Code topology %r: want 1 <= packages <= cores <= PUs <= %s (os.cpu_count)" %
                  (topo, os.cpu_count()))
        check(a["parameters"].get("bind") == "core", "--bind core: /parameters bind %r" % a["parameters"].get("bind"))
        if cores:
            want = "core: " + " ".join(str(i % cores) for i in range(3))
            check(a["results"].get("binding") == want, "--bind core, 3 workers, %d cores: /results binding %r, "
                  "want %r" % (cores, a["results"].get("binding"), want))
            check(("binding %s)" % want) in summary, "--bind core: summary.txt lacks 'binding %s':\n%s" %
                  (want, summary))
            check(stats.get("binding") == want, "--bind core: --stats-json binding %r, want %r" %
                  (stats.get("binding"), want))

    # ---- --threads 0: one worker per physical core (README, Threads) --------------------
    r = grown(tmp, "zero", ["--threads", "0"])
    if r and cores:
        a, summary, stats = r
        check(a["results"].get("threads") == str(cores), "--threads 0: /results threads %r, want %d (the cores of "
              "/Code topology)" % (a["results"].get("threads"), cores))
        check(re.search(r"^threads +%d after 300 serial particles" % cores, summary, re.M) is not None,
              "--threads 0: summary.txt threads line, want %d:\n%s" % (cores, summary))
        # the same count from Linux: distinct (package, core) of the CPUs this process may use
        try:
            seen = set()
            for c in os.sched_getaffinity(0):
                t = "/sys/devices/system/cpu/cpu%d/topology/" % c
                with open(t + "physical_package_id") as fp, open(t + "core_id") as fc:
                    seen.add((fp.read().strip(), fc.read().strip()))
        except OSError:
            seen = None
            print("skipping the /sys core count: no CPU topology there")
        if seen:
            check(len(seen) == cores, "--threads 0: %d cores in /Code topology, %d (package, core) pairs in /sys" %
                  (cores, len(seen)))

    # ---- the pinning, seen from outside ---------------------------------------------------
    if not os.path.isdir("/proc/self/task"):
        print("skipping the pinning check: no /proc")
        return
    if not can_pin():
        print("skipping the pinning check: this process may not set its CPU mask")
        return
    main_mask, workers = running_masks(tmp, "--bind none", [])
    if main_mask is not None:
        check(all(w == main_mask for w in workers), "--bind none: worker masks %s, the process's %s: want the same" %
              ([sorted(w) for w in workers], sorted(main_mask)))
    main_mask, workers = running_masks(tmp, "--bind core", ["--bind", "core"])
    extra = len(workers) - 2  # a sanitizer runtime's threads keep the process's mask
    if main_mask is not None and extra > 0:
        kept = [w for w in workers if w == main_mask]
        check(len(kept) >= extra, "--bind core: %d threads beyond the 2 workers, only %d of all with the process's "
              "mask" % (extra, len(kept)))
        for _ in range(min(extra, len(kept))):
            workers.remove(main_mask)
    if main_mask is not None and cores:
        per_core = -(-pus // cores)
        check(all(0 < len(w) <= per_core for w in workers),
              "--bind core: worker masks %s, want at most one core's %d PU(s) each (process: %s)" %
              ([sorted(w) for w in workers], per_core, sorted(main_mask)))
        if cores >= 2:
            check(len(workers) == 2 and not (workers[0] & workers[1]),
                  "--bind core, %d cores: the 2 workers' masks %s overlap" % (cores, [sorted(w) for w in workers]))
        if len(main_mask) > per_core:
            check(all(w != main_mask for w in workers), "--bind core: a worker kept the process's mask %s" %
                  sorted(main_mask))


if __name__ == "__main__":
    main()
