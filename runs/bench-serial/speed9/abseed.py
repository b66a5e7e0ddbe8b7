import json, os, subprocess, sys, tempfile
b, label, dim, n, seed = sys.argv[1:6]
with tempfile.TemporaryDirectory() as tmp:
    sj = os.path.join(tmp, "s.json")
    p = subprocess.Popen(["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", seed, "--no-output", "-q", "--stats-json", sj])
    _, st, ru = os.wait4(p.pid, 0)
    s = json.load(open(sj))
print(f"{label},{dim},{n},{seed},{ru.ru_utime:.2f},{s['peak_rss_bytes']/1024:.0f},{s['jumps']/s['particles']:.3f},{1e9*ru.ru_utime/s['jumps']:.1f},{s['rg_diam']:.6f}", flush=True)
