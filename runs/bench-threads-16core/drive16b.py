#!/usr/bin/env python3
"""drive16b.py - the second 16-core call of session 24: where the 16-worker
bias found by drive16.py comes from, under a deadline.

  A. exact_probe (tests/physics/exact_probe.c): every worker jump and append
     checked against the whole cluster, with the lag distribution; 2D and 3D,
     16 workers, and the same with --reference-walkers is not possible there
     (the probe drives workers only).
  B. 2D, 16 workers against serial DLA and reference-16, prefix 1e4 -> 1e5.
  C. 2D, 16 workers against serial DLA, prefix 1e5 -> 1e6.
  D. 3D, 16 workers against serial and reference-16, prefix 2e3 -> 2e4.
  E. 2D, 4 and 8 workers against serial and reference-4/8, 2e3 -> 2e4.

Each arm of threaded runs runs THREADS-wide processes side by side so the
16 cores are used without oversubscription; serial and reference arms 16 at
a time. Results go to $OUT as they come: arms.tsv (every arm, its name
first on each row), probe.txt, driver.log (session 24's call wrote a file
per arm and lost all past the eighth: the device returns at most 8).

usage: python3 drive16b.py BIN_DIR DEADLINE_S
"""
import concurrent.futures as cf
import json
import os
import subprocess
import sys
import tempfile
import time

T0 = time.monotonic()
OUT = os.environ.get("OUT", "/tmp/out16b")
os.makedirs(OUT, exist_ok=True)
BIN = sys.argv[1]
PDLA = os.path.join(BIN, "pdla")
PROBE = os.path.join(BIN, "exact_probe")
DEADLINE = float(sys.argv[2])
QUICK = bool(os.environ.get("QUICK"))


def left():
    return DEADLINE - (time.monotonic() - T0)


def log(msg):
    line = f"[{time.monotonic() - T0:7.1f}s] {msg}"
    print(line, flush=True)
    with open(os.path.join(OUT, "driver.log"), "a") as f:
        f.write(line + "\n")


def run(args, timeout):
    with tempfile.TemporaryDirectory() as tmp:
        js = os.path.join(tmp, "s.json")
        cmd = [PDLA] + args + ["--no-output", "-q", "--stats-json", js]
        try:
            p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               timeout=max(1.0, timeout))
        except subprocess.TimeoutExpired:
            return None
        if p.returncode == 0 and os.path.exists(js):
            with open(js) as f:
                return json.load(f)
        return None


def row(seed, st):
    if not st:
        return f"{seed}\tfailed\n"
    hist, n = st.get("lag_hist"), st.get("lag_n")
    lag0 = hist[0] / n if hist and n else "-"
    return (f"{seed}\t{st['rg_diam']:.9g}\t{st['particles']}\t{st['jumps']}\t"
            f"{st.get('relaunches', '-')}\t{st.get('lag_mean', '-')}\t{lag0}\t"
            f"{st.get('parallel_seconds', '-')}\n")


def arm(name, args, seeds, width, timeout):
    """Run seeds, `width` processes at a time; write name.tsv; return done seeds."""
    rows = {}
    with cf.ThreadPoolExecutor(width) as ex:
        futs = {ex.submit(run, args + ["--seed", str(s)], timeout): s for s in seeds}
        for fu in cf.as_completed(futs):
            rows[futs[fu]] = fu.result()
    # One file for every arm (the device returns at most 8 files): the arm's
    # name first on each row.
    with open(os.path.join(OUT, "arms.tsv"), "a") as f:
        for s in seeds:
            f.write(name + "\t" + row(s, rows[s]))
    return rows


def timed_arm(name, args, first_seed, width, budget, timeout):
    """Threaded arm: batches of `width` seeds until `budget` s are spent."""
    seeds, s = [], first_seed
    stop = time.monotonic() + budget
    while time.monotonic() < stop and left() > 20:
        batch = list(range(s, s + width))
        arm(name, args, batch, width, timeout)
        seeds += batch
        s += width
    log(f"{name}: {len(seeds)} seeds")
    return seeds


def probe():
    plan = [(2, "2e4", "2e3", 16, 1001, 4), (3, "2e4", "2e3", 16, 1001, 3),
            (2, "1e5", "1e4", 16, 2001, 2), (2, "2e4", "2e3", 4, 1001, 2)]
    if QUICK:
        plan = [(2, "2e4", "2e3", 2, 1001, 1)]
    with open(os.path.join(OUT, "probe.txt"), "a") as f:
        for dim, n, ser, th, s0, k in plan:
            if left() < 60:
                return
            p = subprocess.run([PROBE, str(dim), n, ser, str(th), str(s0), str(k)],
                               capture_output=True, text=True, timeout=max(5, left() - 30))
            f.write(f"# exact_probe {dim} {n} {ser} {th} {s0} {k} (rc {p.returncode})\n"
                    f"{p.stdout}{p.stderr}")
            f.flush()
            log(f"probe {dim}D {ser}->{n} threads {th}: rc {p.returncode}")


def compare(tag, base, threads, budget, first_seed, ref=True, timeout=60):
    if left() < 40:
        log(f"{tag}: no time")
        return
    width = max(1, 16 // threads)
    seeds = timed_arm(f"{tag}-t{threads}", base + ["--threads", str(threads)], first_seed,
                      width, budget, timeout)
    if not seeds:
        return
    arm(f"{tag}-serial", base, seeds, 16, timeout)
    log(f"{tag}-serial done")
    if ref and left() > 15:
        arm(f"{tag}-ref{threads}", base + ["--reference-walkers", str(threads)], seeds, 16, timeout)
        log(f"{tag}-ref{threads} done")


def main():
    log("start")
    probe()
    q = 0.1 if QUICK else 1.0
    compare("b2d-1e5", ["--dim", "2", "--target", "1e5", "--serial-until", "1e4"], 16, 60 * q, 2001)
    compare("c2d-1e6", ["--dim", "2", "--target", "1e6", "--serial-until", "1e5"], 16, 55 * q, 3001,
            ref=False)
    compare("d3d-2e4", ["--dim", "3", "--target", "2e4", "--serial-until", "2e3"], 16, 35 * q, 4001)
    compare("e2d-2e4", ["--dim", "2", "--target", "2e4", "--serial-until", "2e3"], 4, 25 * q, 5001)
    compare("e2d-2e4", ["--dim", "2", "--target", "2e4", "--serial-until", "2e3"], 8, 25 * q, 6001)
    log("end")


if __name__ == "__main__":
    main()
