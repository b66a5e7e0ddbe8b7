#!/usr/bin/env python3
"""test_event_adversary.py PDLA - what an adversarial test of the event
model found (session 23), each case as it was found:

- a kind light enough that its start speed sqrt(2 kT / m) overflowed (each
  option within its range): NaN positions, a run that never ended, or exit
  0 with a NaN cluster.h5 under --max-events;
- --species read with plain strtod (blanks, hexadecimal, subnormals, a
  trailing comma taken);
- a small seed in a corner of a box with walls, which no particle can
  touch: "all stuck" never came and the run never ended;
- `pdla analyze` comparing every stuck particle with every seed: a 3e5 x
  3e5 file ran for minutes;
- `info --json` passing invalid UTF-8 through and printing NaN in
  /species (event), and invalid UTF-8 and unescaped attribute names (dlca);
- `render` not drawing a --seeds run's seeds;
- a --seeds run's resume reading the file again (moved: refused; edited:
  "damaged", or ignored);
- messages that named 1.0000001 as "1", 0.05000000000000001 as "0.05", and
  an empty value as "";
- (review E) a resume that removed the stop of a run whose seeds no
  particle can touch (ran for ever), and --species and --seeds compared as
  text on resume (100:0.50:1.0 against 100:0.5:1, ./s.txt against s.txt).
Every refusal must be one line, exit 2, within TIME_LIMIT.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

PDLA = os.path.abspath(sys.argv[1])  # runs below change the working directory
TIME_LIMIT = 60
fails = 0
work = tempfile.mkdtemp()


def check(cond, msg):
    global fails
    if not cond:
        print("FAIL: " + msg)
        fails += 1


def run(args, cwd=None):
    """(exit status, stdout bytes, stderr lines), or (None, b"", []) past TIME_LIMIT."""
    try:
        p = subprocess.run([PDLA] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           timeout=TIME_LIMIT, cwd=cwd)
    except subprocess.TimeoutExpired:
        return None, b"", []
    err = p.stderr.decode("utf-8", "replace").rstrip("\n")
    return p.returncode, p.stdout, err.split("\n") if err else []


def refused(tag, args, want):
    rc, _, err = run(args)
    check(rc == 2 and len(err) == 1 and want in err[0],
          "%s: want one line with '%s', exit 2; got %s %s" % (tag, want, rc, err))


def w(name, text):
    path = os.path.join(work, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def out(tag):
    return os.path.join(work, tag)


EV = ["--model", "event", "--quiet", "--force"]

# ---- a kind whose thermal speed overflows (or vanishes) ---------------------
refused("tiny mass", EV + ["--out", out("m1"), "--radius", "1e-6", "--seed-radius", "1e-6",
                           "--density", "1e-300", "--particles", "100"], "thermal speed")
refused("tiny mass, event limit", EV + ["--out", out("m2"), "--radius", "1e-6", "--seed-radius", "1e-6",
                                        "--density", "1e-300", "--particles", "100", "--max-events", "20"],
        "thermal speed")
refused("species, huge speed", EV + ["--out", out("m3"), "--species", "100:0.5:1,50:1e-6:1e-290"],
        "--species kind 2")
check(not os.path.exists(os.path.join(out("m2"), "cluster.h5")), "tiny mass: a cluster.h5 was written")
# radii whose squared sums are subnormal doubles (mass and speed in range):
# radius 1e-158 ran and wrote 173 overlapping pairs; 1e-150 is the floor
TINY = ["--density", "1e12", "--kT", "1e-300", "--particles", "200", "--seed", "1"]
refused("radius 1e-158", EV + ["--out", out("r1"), "--radius", "1e-158", "--seed-radius", "1e-158"] + TINY,
        "radius must be in [1e-150")
refused("species radius 1e-158", EV + ["--out", out("r2"), "--species", "200:1e-158:1e12", "--seed-radius",
                                       "1e-158", "--kT", "1e-300"], "RADIUS must be in [1e-150")
rc, _, err = run(EV + ["--out", out("r3"), "--radius", "1e-150", "--seed-radius", "1e-150"] + TINY)
check(rc == 0, "radius 1e-150 (the floor) refused: %s %s" % (rc, err))
rc, so, err = run(["check", os.path.join(out("r3"), "cluster.h5")])
check(rc == 0, "radius 1e-150: pdla check fails: %s %s %s" % (rc, so[-300:], err))
refused("seeds file radius 1e-200", EV + ["--out", out("r4"), "--seeds", w("tiny.txt", "0 0 1e-200\n"),
                                         "--max-events", "100"], "radius must be >= 1e-150")
rc, _, err = run(EV + ["--out", out("m4"), "--species", "100:0.5:1,50:0.01:1e-3", "--max-events", "2000"])
check(rc == 0, "species of very different masses (in range) refused: %s %s" % (rc, err))

# ---- --species numbers as the command line reads them -----------------------
for spec, want in (("100:0x1p-1:1", "RADIUS is not a number"), ("100:0.5:0x10", "DENSITY is not a number"),
                   (" 100:0.5:1", "bad COUNT"), ("100: 0.5:1", "RADIUS is not a number"),
                   ("+100:0.5:1", "bad COUNT"), ("100:0.5:1e-320", "DENSITY is not a number"),
                   ("100:0.5:1,", "nothing after the last comma"), ("100:2e6:1", "got 2000000")):
    refused("--species '%s'" % spec, EV + ["--out", out("sp"), "--species", spec, "--max-events", "100"], want)
rc, _, err = run(EV + ["--out", out("sp2"), "--species", "1e2:0.5:1,20:0.3:2:0", "--max-events", "1000"])
check(rc == 0, "--species 1e2:0.5:1,20:0.3:2:0 refused: %s %s" % (rc, err))

# ---- seeds no particle can touch ---------------------------------------------
c2 = w("corner2.txt", "0.05 0.05 0.05\n")
c3 = w("corner3.txt", "0.05 0.05 0.05 0.05\n")
refused("corner seed 2D", EV + ["--out", out("c2"), "--particles", "100", "--seeds", c2], "can reach any seed")
refused("corner seed 3D", EV + ["--out", out("c3"), "--dim", "3", "--particles", "100", "--seeds", c3],
        "can reach any seed")
refused("corner seed, --max-stuck", EV + ["--out", out("c4"), "--particles", "100", "--seeds", c2,
                                          "--max-stuck", "5"], "can reach any seed")
rc, _, err = run(EV + ["--out", out("c5"), "--particles", "100", "--seeds", c2, "--t-max", "2", "--checkpoint"])
check(rc == 0, "corner seed with --t-max (a plain gas) refused: %s %s" % (rc, err))
# its resume without the stop: the load checked the checkpoint's --t-max 2
# only, and the run went on for ever
RS = ["--model", "event", "--quiet", "--resume", out("c5")]
refused("corner seed resumed with --t-max 0", RS + ["--t-max", "0"], "can reach any seed")
rc, _, err = run(RS + ["--t-max", "3"])
check(rc == 0, "corner seed resumed with a later --t-max refused: %s %s" % (rc, err))
# 0.2 from the corner: a radius-0.5 disc at (0.5, 0.5) is 0.42 from it, within 0.7
near = w("near.txt", "0.2 0.2 0.2\n")
rc, so, err = run(EV[:-2] + ["--force", "--out", out("c6"), "--particles", "30", "--seeds", near])
check(rc == 0 and b"all stuck" in so, "a seed near the corner but reachable: %s %s %s" % (rc, so[-200:], err))

# ---- analyze: the farthest stuck particle from its nearest seed ---------------
rng = np.random.default_rng(7)
for dim in (2, 3):
    # a real --seeds run: 40 seeds on a grid, then brute force in numpy
    # (analyze --json prints 10 digits)
    pts = []
    for i in range(40):
        if dim == 2:  # 5 x 8 seeds, 12 apart (box side 217)
            x = [8 + 12 * (i % 5), 8 + 12 * (i // 5)]
        else:  # 5 x 4 x 2 seeds, 8 apart (box side 43.8)
            x = [6 + 8 * (i % 5), 6 + 8 * ((i // 5) % 4), 6 + 8 * (i // 20)]
        pts.append(" ".join("%g" % v for v in x) + " %g" % (0.3 + 0.1 * (i % 4)))
    sf = w("grid%d.txt" % dim, "\n".join(pts) + "\n")
    d = out("an%d" % dim)
    n = "3000" if dim == 2 else "8000"
    rc, _, err = run(EV + ["--out", d, "--dim", str(dim), "--particles", n, "--packing", "0.05",
                           "--seeds", sf, "--max-events", "100000"])
    check(rc == 0, "analyze run %dD: %s %s" % (dim, rc, err))
    if rc != 0:
        continue
    with h5py.File(os.path.join(d, "cluster.h5"), "r") as f:
        p = f["/cluster/positions"][()]
        s = f["/cluster/seed_positions"][()]
    far = np.sqrt(((p[:, None, :] - s[None, :, :]) ** 2).sum(-1)).min(1).max() if len(p) else 0
    rc, so, err = run(["analyze", "--json", os.path.join(d, "cluster.h5")])
    got = json.loads(so.decode()) if rc == 0 else {}
    val = got.get("max_distance_from_seed")
    check(len(p) > 40 and val is not None and abs(val - far) <= 1e-8 * max(1, far),
          "analyze %dD: farthest from a seed %s, numpy %r (%d stuck)" % (dim, val, far, len(p)))
    # forged: 3000 random seeds (duplicates and a tight clump among them)
    # and 5000 random positions, so the nearest seed often lies across a
    # splitting plane; numpy's brute force must agree
    fz = out("rand%d.h5" % dim)
    shutil.copy(os.path.join(d, "cluster.h5"), fz)
    sd = rng.uniform(0, 40, (3000, dim))
    sd[100:200] = sd[7]
    sd[200:400] = 20 + rng.normal(0, 1e-3, (200, dim))
    ps = rng.uniform(-5, 45, (5000, dim))
    with h5py.File(fz, "r+") as f:
        g = f["cluster"]
        for name in ("positions", "seed_positions", "seed_radii", "radii"):
            if name in g:
                del g[name]
        g.create_dataset("positions", data=ps)
        g.create_dataset("radii", data=np.full(len(ps), 0.5))
        g.create_dataset("seed_positions", data=sd)
        g.create_dataset("seed_radii", data=np.ones(len(sd)))
    far = np.sqrt(((ps[:, None, :] - sd[None, :, :]) ** 2).sum(-1)).min(1).max()
    rc, so, err = run(["analyze", "--json", fz])
    got = json.loads(so.decode()) if rc == 0 else {}
    val = got.get("max_distance_from_seed")
    check(val is not None and abs(val - far) <= 1e-8 * far,
          "analyze %dD, random seeds: farthest %s, numpy %r (%s %s)" % (dim, val, far, rc, err))
    if dim == 2:
        # forged: 3e5 seeds and 3e5 positions (deflated), each position its
        # seed moved by a known offset; the answer is the largest offset
        big = out("quad.h5")
        shutil.copy(os.path.join(d, "cluster.h5"), big)
        m = 300000
        seeds = np.zeros((m, 2))
        seeds[:, 0] = (np.arange(m) % 547) * 3.0
        seeds[:, 1] = (np.arange(m) // 547) * 3.0
        off = np.zeros((m, 2))
        off[:, 0] = 0.25 * ((np.arange(m) % 5) / 4.0)
        off[12345, 1] = 0.75  # nearest seed still its own (spacing 3)
        with h5py.File(big, "r+") as f:
            g = f["cluster"]
            for name in ("positions", "seed_positions", "seed_radii", "radii"):
                if name in g:
                    del g[name]
            kw = dict(compression="gzip", compression_opts=9)
            g.create_dataset("positions", data=seeds + off, chunks=(65536, 2), **kw)
            g.create_dataset("radii", data=np.full(m, 0.5), chunks=(65536,), **kw)
            g.create_dataset("seed_positions", data=seeds, chunks=(65536, 2), **kw)
            g.create_dataset("seed_radii", data=np.ones(m), chunks=(65536,), **kw)
        rc, so, err = run(["analyze", "--json", big])
        got = json.loads(so.decode()) if rc == 0 else {}
        val = got.get("max_distance_from_seed")
        check(rc == 0 and val is not None and abs(val - 0.75) < 1e-12,
              "analyze of 3e5 x 3e5 (within %d s): %s, farthest %s, want 0.75 %s" % (TIME_LIMIT, rc, val, err))

# ---- info --json: valid JSON whatever the path and the file hold ---------------
odd = os.path.join(work.encode(), b"d\xff\xfe")
for model, args in (("event", ["--particles", "100", "--max-events", "100"]),
                    ("dlca", ["--dim", "2", "--box", "64x64", "--fill", "0.05", "--until-clusters", "5"])):
    d = odd + b"-" + model.encode()
    p = subprocess.run([PDLA, "--model", model, "--quiet", "--out", d] + args, stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, timeout=TIME_LIMIT)
    check(p.returncode == 0, "%s run in a non-UTF-8 directory: %s" % (model, p.stderr))
    q = subprocess.run([PDLA, "info", "--json", os.path.join(d, b"cluster.h5")], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, timeout=TIME_LIMIT)
    try:
        doc = json.loads(q.stdout.decode("utf-8"))
        ok = q.returncode == 0 and "\ufffd" in json.dumps(doc, ensure_ascii=False)
    except (UnicodeDecodeError, ValueError) as e:
        ok = False
        print("  %s info --json: %s" % (model, e))
    check(ok, "%s info --json in a non-UTF-8 directory: not valid JSON with U+FFFD" % model)
src = os.path.join(odd + b"-event", b"cluster.h5")
for bad in (float("nan"), float("inf")):
    f2 = out("species_%s.h5" % bad)
    shutil.copy(src, f2)
    with h5py.File(f2, "r+") as f:
        r = f["/species/radius"][()]
        r[0] = bad
        f["/species/radius"][...] = r
    rc, so, err = run(["info", "--json", f2])
    try:
        doc = json.loads(so.decode())
        ok = rc == 0 and doc["species"][0]["radius"] is None
    except (ValueError, KeyError, IndexError, TypeError):
        ok = False
    check(ok, "info --json with /species/radius %s: want null, got %s %s" % (bad, rc, so[:300]))
# a dlca file's attribute name with a quote
dl = os.path.join(odd + b"-dlca", b"cluster.h5")
f3 = out("dlca_name.h5")
shutil.copy(dl, f3)
with h5py.File(f3, "r+") as f:
    f.attrs['a"b'] = 1.0
rc, so, err = run(["info", "--json", f3])
try:
    json.loads(so.decode())
    ok = rc == 0
except ValueError:
    ok = False
check(ok, "dlca info --json with an attribute named a\"b: not valid JSON (%s)" % rc)

# ---- render draws a --seeds run's seeds ----------------------------------------
try:
    from PIL import Image
except ImportError:
    Image = None
three = w("three.txt", "20 20 2\n60 60 3\n20 60 1\n")
d = out("rs")
rc, _, err = run(EV + ["--out", d, "--particles", "400", "--seeds", three, "--max-events", "3000"])
png = out("rs.png")
rc2, _, err2 = run(["render", os.path.join(d, "cluster.h5"), "-o", png, "--size", "256", "--force"])
check(rc == 0 and rc2 == 0, "render of a --seeds run: %s %s %s %s" % (rc, err, rc2, err2))
if Image is None:
    print("skip: no PIL to read the picture")
elif rc2 == 0:
    with h5py.File(os.path.join(d, "cluster.h5"), "r") as f:
        L = float(f["/results"].attrs["box_side"])
    im = Image.open(png).convert("RGB")
    n = im.size[0]
    for x, y in ((20, 20), (60, 60), (20, 60)):
        px, py = int(x * n / L), n - 1 - int(y * n / L)
        check(im.getpixel((px, py)) == (255, 255, 255),
              "render: the seed at (%g, %g) is not drawn white: %s" % (x, y, im.getpixel((px, py))))

# ---- resume of a --seeds run without its file ----------------------------------
sdir = os.path.join(work, "sd")
os.mkdir(sdir)
with open(os.path.join(sdir, "seeds3.txt"), "w") as f:
    f.write("20 20 1\n50 50 1.5\n20 50 0.5\n")
common = ["--particles", "300", "--packing", "0.05", "--seeds", "seeds3.txt"]
rc, _, err = run(EV + ["--out", "A", "--max-events", "3000", "--checkpoint-every", "0.5"] + common, cwd=sdir)
rc2, _, err2 = run(EV + ["--out", "B"] + common, cwd=sdir)
check(rc == 0 and rc2 == 0, "seeds runs: %s %s %s %s" % (rc, err, rc2, err2))
# the same file by another name is the same parameter (the texts were
# compared: ./seeds3.txt was "a different physics parameter"); another file,
# though a copy, is not
RA = ["--model", "event", "--quiet", "--resume", "A"]
rc, _, err = run(RA + ["--seeds", "./seeds3.txt", "--max-events", "3500"], cwd=sdir)
check(rc == 0, "resume with --seeds ./seeds3.txt refused: %s %s" % (rc, err))
shutil.copy(os.path.join(sdir, "seeds3.txt"), os.path.join(sdir, "copy.txt"))
rc, _, err = run(RA + ["--seeds", "copy.txt", "--max-events", "4000"], cwd=sdir)
check(rc == 2 and len(err) == 1 and "seeds is seeds3.txt in the checkpoint, copy.txt asked" in err[0],
      "resume with another seeds file: %s %s" % (rc, err))
os.rename(os.path.join(sdir, "seeds3.txt"), os.path.join(sdir, "moved.txt"))
rc, _, err = run(["--model", "event", "--quiet", "--resume", os.path.join(sdir, "A"), "--max-events", "0"],
                 cwd=work)
check(rc == 0, "resume without the seeds file, from another directory: %s %s" % (rc, err))
if rc == 0:
    with h5py.File(os.path.join(sdir, "A", "cluster.h5"), "r") as a, \
            h5py.File(os.path.join(sdir, "B", "cluster.h5"), "r") as b:
        for k in ("/cluster/positions", "/cluster/seed_positions", "/cluster/seed_radii"):
            check(np.array_equal(a[k][()], b[k][()]), "resumed seeds run: %s differs from a straight run" % k)

# ---- messages that name the values ----------------------------------------------
refused("stick-p 1.0000001", EV + ["--out", out("sp3"), "--stick-p", "1.0000001"], "got 1.0000001")
ck = out("ck")
rc, _, err = run(EV + ["--out", ck, "--particles", "200", "--packing", "0.05", "--seed-radius", "0",
                       "--t-max", "1", "--checkpoint-every", "1"])
check(rc == 0, "checkpointed gas: %s %s" % (rc, err))
rc, _, err = run(["--model", "event", "--resume", ck, "--packing", "0.05000000000000001", "--t-max", "2"])
check(rc == 2 and len(err) == 1 and "0.050000000000000003 in the checkpoint, 0.05000000000000001 asked" in err[0],
      "packing that differs in the 17th digit: %s %s" % (rc, err))
rc, _, err = run(["--model", "event", "--resume", ck, "--species", "200:0.5:1", "--t-max", "2"])
check(rc == 2 and len(err) == 1 and "(none) in the checkpoint" in err[0], "empty species: %s %s" % (rc, err))

# --species as the kinds it gives, not its text (100:0.50:1.0 was refused
# beside 100:0.5:1)
sk = out("spk")
rc, _, err = run(EV + ["--out", sk, "--species", "100:0.5:1,50:0.3:2:0", "--max-events", "2000", "--checkpoint"])
check(rc == 0, "two-kind run: %s %s" % (rc, err))
RK = ["--model", "event", "--quiet", "--resume", sk]
rc, _, err = run(RK + ["--species", "1e2:0.50:1.0,50:.3:2:0", "--max-events", "3000"])
check(rc == 0, "resume with the same kinds written otherwise refused: %s %s" % (rc, err))
refused("resume with another STICKY", RK + ["--species", "100:0.5:1,50:0.3:2:1", "--max-events", "4000"],
        "species is 100:0.5:1,50:0.3:2:0 in the checkpoint")
refused("resume with another radius", RK + ["--species", "100:0.5:1,50:0.30000000000000004:2:0", "--max-events",
                                            "4000"], "species is")

shutil.rmtree(work, ignore_errors=True)
print("%d failures" % fails)
sys.exit(1 if fails else 0)
