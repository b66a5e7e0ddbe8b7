import json, os, subprocess, sys, tempfile
b, dim, n, s0, s1 = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
J=[];R=[];U=0
for seed in range(s0, s1+1):
    with tempfile.TemporaryDirectory() as tmp:
        sj=os.path.join(tmp,"s.json")
        p=subprocess.Popen(["nice","-n","10",b,"--dim",dim,"--target",n,"--seed",str(seed),"--no-output","-q","--stats-json",sj])
        _,st,ru=os.wait4(p.pid,0); U+=ru.ru_utime
        s=json.load(open(sj)); J.append(s['jumps']/s['particles']); R.append(s['rg_diam'])
import statistics as st
print(b, n, f"seeds {s0}-{s1} jumps/p mean {st.mean(J):.3f} sd {st.stdev(J):.3f} Rg mean {st.mean(R):.3f} sd {st.stdev(R):.3f} user {U:.2f}")
