#!/usr/bin/env python3
"""drive16.py - the 16-core device run of issue 8, one call, under a deadline.

Runs, in this order (most wanted first), writing each result as it comes to
$OUT so a call cut short still returns what it measured:

  1. thread scaling, 2D: serial 1e5 then on to 5e6 with 1, 2, 4, 8, 16
     workers (--bind core), same seed; 3D: serial 1e5 then to 1e6 with
     1, 4, 16 workers. One process at a time on the otherwise idle machine.
  2. the PDLA bias with free cores: 16 workers (one run at a time, so the 16
     threads have the 16 cores) against the race-free reference of 16
     walkers and against serial DLA, paired by seed (same serial prefix
     2e3, then on to 2e4), as the slow test pdla-vs-reference-2e4; seeds
     from 1001 until the arm's deadline, then the other two arms for the
     same seeds, 16 processes at a time.
  3. a big 2D run with 16 workers: serial 1e6 then to 1e8 (peak RSS and
     time), killed at the deadline if it has not finished.

usage (on the device, repo root): python3 runs/bench-threads-16core/drive16.py BIN DEADLINE_S
BIN is the pdla binary; LD_LIBRARY_PATH as it needs.
"""
import concurrent.futures as cf
import json
import os
import subprocess
import sys
import tempfile
import time

T0 = time.monotonic()
OUT = os.environ.get("OUT", "/tmp/out16")
os.makedirs(OUT, exist_ok=True)
PDLA = sys.argv[1]
DEADLINE = float(sys.argv[2])


def left():
    return DEADLINE - (time.monotonic() - T0)


def log(msg):
    line = f"[{time.monotonic() - T0:7.1f}s] {msg}"
    print(line, flush=True)
    with open(os.path.join(OUT, "driver.log"), "a") as f:
        f.write(line + "\n")


def run(args, timeout):
    """One pdla run: (stats dict or None, wall seconds, stderr)."""
    with tempfile.TemporaryDirectory() as tmp:
        js = os.path.join(tmp, "s.json")
        cmd = [PDLA] + args + ["--no-output", "-q", "--stats-json", js]
        t = time.monotonic()
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            _, err = p.communicate(timeout=max(1.0, timeout))
        except subprocess.TimeoutExpired:
            p.kill()
            _, err = p.communicate()
            return None, time.monotonic() - t, "timeout"
        wall = time.monotonic() - t
        stats = None
        if p.returncode == 0 and os.path.exists(js):
            with open(js) as f:
                stats = json.load(f)
        return stats, wall, err.decode(errors="replace").strip()


def scaling():
    path = os.path.join(OUT, "scaling.jsonl")
    plan = [(2, "1e5", "5e6", n) for n in (1, 2, 4, 8, 16)] + \
           [(3, "1e5", "1e6", n) for n in (1, 4, 16)]
    if os.environ.get("QUICK"):  # a dry run of the driver on a small machine
        plan = [(2, "1e4", "1e5", n) for n in (1, 2)] + [(3, "1e4", "3e4", 2)]
    for dim, serial, target, n in plan:
        if left() < 60:
            log("scaling: deadline, stop")
            return
        args = ["--dim", str(dim), "--serial-until", serial, "--target", target,
                "--threads", str(n), "--seed", "1", "--bind", "core"]
        stats, wall, err = run(args, min(left() - 30, 200))
        keep = {k: stats.get(k) for k in (
            "particles", "jumps", "rg_diam", "grow_seconds", "parallel_seconds", "threads",
            "binding", "peak_rss_bytes", "worker_cpu_seconds", "mutex_taken", "mutex_contended",
            "mutex_wait_ns", "mutex_hold_ns", "recheck_overlaps", "stale_jumps", "relaunches",
            "lag_mean")} if stats else {"error": err}
        rec = {"dim": dim, "serial": serial, "target": target, "workers": n, "wall": wall, **keep}
        with open(path, "a") as f:
            f.write(json.dumps(rec) + "\n")
        log(f"scaling {dim}D {serial}->{target} workers {n}: wall {wall:.2f} s "
            f"parallel {keep.get('parallel_seconds')} rss {keep.get('peak_rss_bytes')} {keep.get('error', '')}")


def rg_line(seed, stats):
    if not stats:
        return f"{seed}\tfailed\n"
    hist, n = stats.get("lag_hist"), stats.get("lag_n")
    lag0 = hist[0] / n if hist and n else "-"
    return (f"{seed}\t{stats['rg_diam']:.9g}\t{stats['particles']}\t{stats['jumps']}\t"
            f"{stats.get('relaunches', '-')}\t{stats.get('lag_mean', '-')}\t{lag0}\t"
            f"{stats.get('parallel_seconds', '-')}\n")


def bias(t16_budget):
    base = ["--dim", "2", "--target", "2e4", "--serial-until", "2e3"]
    seeds = []
    stop = time.monotonic() + t16_budget
    with open(os.path.join(OUT, "bias-t16.tsv"), "a") as f:
        s = 1001
        while time.monotonic() < stop and left() > 90:
            stats, _, _ = run(base + ["--seed", str(s), "--threads", "16"], 30)
            f.write(rg_line(s, stats))
            seeds.append(s)
            s += 1
    log(f"bias: t16 arm {len(seeds)} seeds")
    for name, extra in (("serial", []), ("ref16", ["--reference-walkers", "16"])):
        rows = {}
        with cf.ThreadPoolExecutor(16) as ex:
            futs = {ex.submit(run, base + ["--seed", str(s)] + extra, 60): s for s in seeds}
            for fu in cf.as_completed(futs):
                rows[futs[fu]] = fu.result()[0]
        with open(os.path.join(OUT, f"bias-{name}.tsv"), "a") as f:
            for s in seeds:
                f.write(rg_line(s, rows[s]))
        log(f"bias: {name} arm done")


def big():
    budget = left() - 15
    if budget < 30:
        log("big: no time left")
        return
    big_target = "3e5" if os.environ.get("QUICK") else "1e8"
    args = ["--dim", "2", "--serial-until", "1e5" if os.environ.get("QUICK") else "1e6", "--target", big_target, "--threads", "16",
            "--seed", "1", "--bind", "core"]
    with open(os.path.join(OUT, "big.log"), "w") as errf:
        js = os.path.join(OUT, "big.json")
        cmd = [PDLA] + args + ["--no-output", "--progress", "--stats-json", js]
        errf.write(" ".join(cmd) + "\n")
        errf.flush()
        t = time.monotonic()
        p = subprocess.Popen(cmd, stdout=errf, stderr=errf)
        try:
            p.wait(timeout=budget)
            log(f"big: exit {p.returncode} after {time.monotonic() - t:.1f} s")
        except subprocess.TimeoutExpired:
            p.terminate()  # pdla stops cleanly on SIGTERM and writes its summary
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            log(f"big: stopped at the deadline after {time.monotonic() - t:.1f} s")


def env():
    with open(os.path.join(OUT, "env.txt"), "w") as f:
        for c in ("nproc", "uname -a", "cat /proc/loadavg", "free -g",
                  "grep -m1 'model name' /proc/cpuinfo", "lscpu",
                  f"{PDLA} --version"):
            r = subprocess.run(c, shell=True, capture_output=True, text=True)
            f.write(f"$ {c}\n{r.stdout}{r.stderr}\n")


def main():
    env()
    log("start")
    scaling()
    bias(min(150.0, left() - 200))
    big()
    log("end")


if __name__ == "__main__":
    main()
