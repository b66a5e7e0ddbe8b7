#!/usr/bin/python3
"""journal-scan.py PDLA [ROUNDS] - how long `pdla ensemble --resume` takes
to scan the forged journal of test `ensemble-files` (README, "Ensembles"
and "What is not here yet"): record 0 of a 2-cluster ensemble of 2e4
particles with positions, then 4 MiB of copies of record 1's head (its
fingerprint and fixed fields: each candidate read whole to its declared
length and hashed before its checksum fails). The test sends SIGTERM once
the scan has read 20 MB, so it never runs the scan to its end; here it
does, with no signal. The journal is built exactly as
tests/ensemble/test_ens_files.py builds it (sigterm_in_scan's argument).

Each round: a resume of record 0 alone (the baseline: cluster 1 grown
again) and a resume of record 0 plus the 4 MiB of heads (the scan, the
heads cut as a torn tail, then cluster 1 grown again), each under
/usr/bin/time (wall, user and sys CPU, peak RSS in KiB) and with the
bytes it read (/proc/PID/io rchar, sampled last). The scan's cost is the
difference of the two."""
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time

PDLA = os.path.abspath(sys.argv[1])
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 3


def timed(journal, what):
    with open("dos/clusters.journal", "wb") as fh:
        fh.write(journal)
    p = subprocess.Popen(["/usr/bin/time", "-o", "time.txt", "-f", "%e s wall, %U s user, %S s sys, %M KB",
                          PDLA, "ensemble", "--resume", "dos", "-q"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    rchar = 0
    while p.poll() is None:  # the pdla child of /usr/bin/time
        try:
            kids = open("/proc/%d/task/%d/children" % (p.pid, p.pid)).read().split()
            if kids:
                with open("/proc/%s/io" % kids[0]) as f:
                    rchar = next(int(l.split()[1]) for l in f if l.startswith("rchar:"))
        except (OSError, StopIteration, ValueError):
            pass
        time.sleep(0.05)
    err = p.stderr.read().strip()
    t = open("time.txt").read().strip().splitlines()[-1]
    print("%s: exit %d, %s, read %.2f GB%s" % (what, p.returncode, t, rchar / 1e9, (": " + err) if err else ""),
          flush=True)


def main():
    tmp = tempfile.mkdtemp(prefix="journal-scan.")
    os.chdir(tmp)
    try:
        subprocess.run([PDLA, "ensemble", "--clusters", "2", "--target", "20000", "--keep-positions", "--out", "dos",
                        "-q"], check=True)
        with open("dos/clusters.journal", "rb") as fh:
            d = fh.read()
        hl = struct.unpack("<I", d[12:16])[0]
        rec0, n0 = 24 + hl, struct.unpack_from("<Q", d, 24 + hl + 8)[0]
        skip = 24 if d[rec0:rec0 + 8] == b"PDLAREC2" else 16
        rec1 = rec0 + skip + n0 + 8
        n1 = struct.unpack_from("<Q", d, rec1 + 8)[0]
        heads = d[rec1:rec1 + skip + 136] * ((4 << 20) // (skip + 136))
        print("journal: record 0 (%d bytes), then %d copies of record 1's head (%d bytes each, declaring %d bytes): "
              "%d bytes" % (rec1 - rec0, len(heads) // (skip + 136), skip + 136, n1, rec1 + len(heads)), flush=True)
        for r in range(1, ROUNDS + 1):
            timed(d[:rec1], "round %d: resume of record 0 alone" % r)
            timed(d[:rec1] + heads, "round %d: resume of record 0 + 4 MiB of heads" % r)
    finally:
        os.chdir("/")
        shutil.rmtree(tmp, ignore_errors=True)


main()
