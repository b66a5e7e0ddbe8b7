#!/usr/bin/env python3
"""oracle_runs.py BIN DIM N SEED...: for each seed, one run with the engine's
bounds and one with --exact-search (every jump by the exact nearest distance:
the oracle empty ball; same law, different clusters), nice 10. Prints
jumps/particle, returns/particle, R_g and user CPU s (wait4) of each."""
import json, os, subprocess, sys, tempfile
b, dim, n, seeds = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
print("mode,dim,N,seed,jumps_per_particle,returns_per_particle,rg_diam,user_s", flush=True)
for seed in seeds:
    for mode, extra in (("engine", []), ("oracle", ["--exact-search"])):
        with tempfile.TemporaryDirectory() as tmp:
            sj = os.path.join(tmp, "s.json")
            cmd = ["nice", "-n", "10", b, "--dim", dim, "--target", n, "--seed", seed,
                   "--no-output", "-q", "--stats-json", sj] + extra
            p = subprocess.Popen(cmd)
            _, st, ru = os.wait4(p.pid, 0)
            s = json.load(open(sj))
        N = s["particles"]
        print(f"{mode},{dim},{n},{seed},{s['jumps']/N:.3f},{s['returns']/N:.3f},{s['rg_diam']:.4f},{ru.ru_utime:.2f}", flush=True)
