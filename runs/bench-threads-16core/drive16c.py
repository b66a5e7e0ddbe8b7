#!/usr/bin/env python3
"""drive16c.py - session 28's one 16-core call: the re-measure, with the
claims (src/dla/claims.h), of what session 24 found, in priority order under
a deadline. It reuses drive16b.py's runner (same argv: BIN_DIR DEADLINE_S).

  1. the PDLA bias on free cores, 2D 2e3 -> 2e4 (the slow test
     pdla-vs-reference-2e4's case): 16 workers one run at a time, then serial
     DLA and reference-16 for the same seeds, 16 processes at a time;
  2. exact_probe with the claims: 2D and 3D, 16 workers;
  3. thread scaling: 2D serial 1e5 then to 5e6 with 1, 4, 8, 16 workers,
     3D serial 1e5 then to 1e6 with 1, 16 (what the claims cost);
  4. the bias at 1e4 -> 1e5 (2D) and 2e3 -> 2e4 (3D), 16 workers against
     serial and reference-16; then 4 workers at 2D 2e4 if time is left.

Results: $OUT/arms.tsv (every arm, its name first), scaling.jsonl,
probe.txt, driver.log, env.txt: five files (the device returns eight).

usage: python3 drive16c.py BIN_DIR DEADLINE_S   (LD_LIBRARY_PATH=BIN_DIR/lib)
"""
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drive16b as d  # noqa: E402  (reads BIN_DIR and DEADLINE_S from argv)

KEEP = ("particles", "jumps", "rg_diam", "grow_seconds", "parallel_seconds", "threads",
        "binding", "peak_rss_bytes", "worker_cpu_seconds", "mutex_taken", "mutex_contended",
        "mutex_wait_ns", "mutex_hold_ns", "recheck_overlaps", "stale_jumps", "claim_waits",
        "relaunches", "lag_mean")


def scaling():
    plan = [(2, "1e5", "5e6", n) for n in (1, 4, 8, 16)] + \
           [(3, "1e5", "1e6", n) for n in (1, 16)]
    if d.QUICK:
        plan = [(2, "1e4", "1e5", n) for n in (1, 2)] + [(3, "1e4", "3e4", 2)]
    for dim, serial, target, n in plan:
        if d.left() < 45:
            d.log("scaling: deadline, stop")
            return
        args = ["--dim", str(dim), "--serial-until", serial, "--target", target,
                "--threads", str(n), "--seed", "1", "--bind", "core"]
        t = time.monotonic()
        st = d.run(args, min(d.left() - 20, 120))
        wall = time.monotonic() - t
        rec = {"dim": dim, "serial": serial, "target": target, "workers": n, "wall": wall}
        rec.update({k: st.get(k) for k in KEEP} if st else {"error": "failed or timeout"})
        with open(os.path.join(d.OUT, "scaling.jsonl"), "a") as f:
            f.write(json.dumps(rec) + "\n")
        d.log(f"scaling {dim}D {serial}->{target} workers {n}: wall {wall:.2f} s "
              f"parallel {rec.get('parallel_seconds')} claim_waits {rec.get('claim_waits')}")


def probe():
    plan = [(2, "2e4", "2e3", 16, 1001, 2), (3, "2e4", "2e3", 16, 1001, 1)]
    if d.QUICK:
        plan = [(2, "2e4", "2e3", 2, 1001, 1)]
    with open(os.path.join(d.OUT, "probe.txt"), "a") as f:
        for dim, n, ser, th, s0, k in plan:
            if d.left() < 60:
                return
            t = time.monotonic()
            try:
                p = subprocess.run([d.PROBE, str(dim), n, ser, str(th), str(s0), str(k)],
                                   capture_output=True, text=True, timeout=min(60, d.left() - 30))
                out, rc = p.stdout + p.stderr, p.returncode
            except subprocess.TimeoutExpired:
                out, rc = "timeout\n", "timeout"
            f.write(f"# exact_probe {dim} {n} {ser} {th} {s0} {k} (rc {rc}, "
                    f"{time.monotonic() - t:.1f} s)\n{out}")
            f.flush()
            d.log(f"probe {dim}D {ser}->{n} threads {th}: rc {rc}")


def main():
    d.log("start (drive16c)")
    q = 0.1 if d.QUICK else 1.0
    two = ["--dim", "2", "--target", "2e4", "--serial-until", "2e3"]
    d.compare("a2d-2e4", two, 16, 100 * q, 1001, timeout=30)
    probe()
    scaling()
    d.compare("b2d-1e5", ["--dim", "2", "--target", "1e5", "--serial-until", "1e4"], 16,
              45 * q, 2001)
    d.compare("d3d-2e4", ["--dim", "3", "--target", "2e4", "--serial-until", "2e3"], 16,
              30 * q, 4001)
    if d.left() > 60:
        d.compare("e2d-2e4", two, 4, min(25 * q, d.left() - 45), 5001)
    d.log("end")


if __name__ == "__main__":
    subprocess.run(f"(nproc; uname -a; cat /proc/loadavg; free -g; lscpu; "
                   f"{d.PDLA} --version) > {d.OUT}/env.txt 2>&1", shell=True)
    main()
