#!/usr/bin/env python3
"""progress_cpu.py BIN DIM N OUT.csv: one run of pdla under nice 10 with
progress lines on stderr (one every 5 s of wall time); at each line it
reads the process's user CPU seconds and VmHWM from /proc, so the run's
CPU time is known at many N (the wall time of a loaded machine is not).
Writes OUT.csv (particles as printed, 3 digits; user s; VmHWM KiB) and the
final --stats-json next to it (OUT.json); prints the summary line as
ab_measure.py does."""
import json, os, re, subprocess, sys

b, dim, n, out = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
sj = re.sub(r"\.csv$", "", out) + ".json"
tck = os.sysconf("SC_CLK_TCK")
cmd = ["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", "1",
       "--no-output", "-q", "--progress", "--stats-json", sj]
p = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
sfx = {"": 1, "k": 1e3, "M": 1e6, "G": 1e9}


def child_pid():
    # nice execs the binary in place, so p.pid is pdla itself
    return p.pid


def sample():
    pid = child_pid()
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    user = int(fields[11]) / tck  # utime is field 14; index 11 after the ')'
    hwm = 0
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                hwm = int(line.split()[1])
    return user, hwm


with open(out, "w") as fo:
    fo.write("particles,user_s,vmhwm_kib\n")
    for line in p.stderr:
        m = re.match(r"\s*([0-9.]+)([kMG]?)/", line)
        if not m:
            continue
        try:
            user, hwm = sample()
        except OSError:
            break
        fo.write(f"{float(m.group(1)) * sfx[m.group(2)]:.0f},{user:.2f},{hwm}\n")
        fo.flush()
_, st, ru = os.wait4(p.pid, 0)
s = json.load(open(sj))
user = ru.ru_utime
with open(out, "a") as fo:
    fo.write(f"{s['particles']},{user:.2f},{s['peak_rss_bytes'] // 1024}\n")
print(f"{dim},{n},{user:.2f},{s['peak_rss_bytes']/1024:.0f},{s['jumps']/s['particles']:.3f},"
      f"{1e9*user/s['jumps']:.1f},{s['rg_diam']:.6f}", flush=True)
