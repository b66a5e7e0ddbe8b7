#!/usr/bin/python3
"""test_check_event.py PDLA - `pdla check` of event-model files.

Pass (exit 0, "result pass"), each cluster.h5 grown here: 2D between
elastic walls run to completion (every particle stuck, stop "all stuck");
3D elastic; 2D and 3D periodic; a --species mix with a bath kind that
never sticks; a --seeds file of 3 seeds (2D and 3D); --stick-p 0.5; and a
run's checkpoint.h5 (--checkpoint), loaded as --resume does and checked.
--json gives one object with every kind of check.

Fail (exit 1, the report naming the check, one line on stderr "fails the
check"), each on a copy of a passing file changed in one way with h5py:
the last stuck particle moved 1e-6 (of a contact distance 1) away from its
parent (contact); a free particle moved onto another (overlap); a free one
put across an elastic wall (box); a parent naming a later particle
(parent); two arrival times swapped (arrival); /results stuck + 1
(counts); kinetic_energy_free x (1 + 1e-9) (energy); a stuck particle's
radius changed by 1e-9 of it (species); a checkpoint's stuck particle moved
1e-7 from its parent, which the loader's 1e-6 accepts (contact), and one
moved 1e-3, which the loader refuses (exit 1, its line).

Hostile (exit 1, one line on stderr, nothing on stdout unless a report):
a NaN position (finite); /cluster/arrival_time and /free/positions
declaring 2^40 rows the file does not store (refused before any
allocation: the child's peak memory stays under 100 MB); no /free; 3000
free particles at one point (checking stops after 10000 failures, in
seconds). A DLA cluster file is not taken for an event file.

Two engine faults the check found (engine_faults) pass since their fix.
"""
import json
import os
import shutil
import sys
import tempfile
import time

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally, child_peak_rss, forged_copy as forged, run_text as run  # noqa: E402

T = Tally()
PDLA = sys.argv[1]


def grow(tmp, name, args, files=None):
    out = os.path.join(tmp, name)
    rc, _, err = run([PDLA, "--model", "event", *args, "--out", out, "--quiet"])
    T.check(rc == 0, "grow %s: rc %d %s" % (name, rc, err))
    return os.path.join(out, "cluster.h5")


def check_file(path, want_rc, want_text=(), what=""):
    rc, out, err = run([PDLA, "check", path])
    T.check(rc == want_rc, "%s: rc %d, want %d\n%s%s" % (what, rc, want_rc, out, err))
    for t in want_text:
        T.check(t in out + err, "%s: %r not in the report\n%s%s" % (what, t, out, err))
    if want_rc == 0:
        T.check("result       pass" in out and "FAILED" not in out and err == "", "%s: report\n%s%s" % (what, out, err))
    if want_rc == 1:
        T.check(err.count("\n") == 1 and err.startswith("pdla check: "), "%s: stderr %r" % (what, err))
    return out, err


def failed(path, kind, what):
    """A forged copy: exit 1, the kind's line FAILED, the stderr line naming it."""
    out, err = check_file(path, 1, (), what)
    if os.environ.get("PDLA_TEST_VERBOSE"):  # to see what each forgery tripped
        print("==", what, [line for line in out.split("\n") if "FAILED" in line])
    T.check(any(line.startswith(kind + " ") and "FAILED" in line for line in out.split("\n")),
            "%s: no %r FAILED line\n%s" % (what, kind, out))
    T.check("fails the check" in err and kind in err, "%s: stderr %r" % (what, err))


def passing(tmp):
    seeds2 = os.path.join(tmp, "seeds2.txt")
    with open(seeds2, "w") as f:
        f.write("12 12 1.0\n40 20 0.5\n25 44 2.5\n")
    seeds3 = os.path.join(tmp, "seeds3.txt")
    with open(seeds3, "w") as f:
        f.write("5 5 5 1.0\n15 8 12 0.5\n10 15 6 2.0\n")
    files = {
        "complete": grow(tmp, "complete", ["--dim", "2", "--particles", "600", "--packing", "0.05", "--seed", "3"]),
        "3d": grow(tmp, "3d", ["--dim", "3", "--particles", "800", "--packing", "0.05", "--seed", "4",
                               "--max-stuck", "300"]),
        "periodic2": grow(tmp, "periodic2", ["--dim", "2", "--particles", "800", "--packing", "0.1",
                                             "--box-walls", "periodic", "--seed", "5", "--max-stuck", "200"]),
        "periodic3": grow(tmp, "periodic3", ["--dim", "3", "--particles", "800", "--packing", "0.1",
                                             "--box-walls", "periodic", "--seed", "6", "--max-stuck", "200"]),
        "bath": grow(tmp, "bath", ["--dim", "2", "--species", "200:0.5:1,800:0.3:1:0", "--packing", "0.2",
                                   "--seed", "7", "--max-stuck", "100"]),
        "seeds2": grow(tmp, "seeds2", ["--dim", "2", "--particles", "600", "--packing", "0.05", "--seeds", seeds2,
                                       "--seed", "8", "--max-stuck", "300"]),
        "seeds3": grow(tmp, "seeds3", ["--dim", "3", "--particles", "600", "--packing", "0.05", "--seeds", seeds3,
                                       "--seed", "8", "--max-stuck", "300"]),
        "stick": grow(tmp, "stick", ["--dim", "2", "--particles", "600", "--packing", "0.05", "--stick-p", "0.5",
                                     "--seed", "9", "--max-stuck", "300"]),
        "ckpt": grow(tmp, "ckpt", ["--dim", "3", "--particles", "800", "--packing", "0.1", "--seed", "10",
                                   "--max-stuck", "200", "--checkpoint"]),
    }
    for name, path in files.items():
        check_file(path, 0, ("model        event",), name)
    with h5py.File(files["complete"], "r") as f:
        T.check(f["results"].attrs["stop_reason"] in (b"all stuck", "all stuck") and len(f["free/radii"]) == 0,
                "complete: not run to completion")
    with h5py.File(files["bath"], "r") as f:
        T.check(f["species/sticky"][1] == 0 and f["species/stuck"][1] == 0 and len(f["free/radii"]) > 0,
                "bath: no free bath particles")
    with h5py.File(files["seeds2"], "r") as f:
        T.check(len(f["cluster/seed_radii"]) == 3 and set(f["cluster/parent"][:]) >= {-1, -2, -3},
                "seeds2: the particles did not stick to all 3 seeds")
    ck = os.path.join(os.path.dirname(files["ckpt"]), "checkpoint.h5")
    out, _ = check_file(ck, 0, ("checkpoint (loaded",), "checkpoint")
    rc, out, err = run([PDLA, "check", "--json", files["periodic3"]])
    try:
        j = json.loads(out)
        T.check(rc == 0 and j["pass"] and j["model"] == "event" and j["periodic"] and j["dim"] == 3 and
                j["failures"] == 0 and len(j["checks"]) == 12 and j["pairs"] > 0 and j["series_at_end"],
                "json: %s" % out)
        with h5py.File(files["periodic3"], "r") as f:
            stored = float(f["results"].attrs["kinetic_energy_free"])
        T.check(j["kinetic_energy_free"] == stored, "json: energy summed again %r, stored %r (want the same bits)"
                % (j["kinetic_energy_free"], stored))
    except ValueError:
        T.check(False, "json: not JSON: %r %r" % (out, err))
    return files, ck


def last_stuck_moved(f, eps):
    """The last stuck row moved eps (of a contact distance) away from its parent."""
    pos = f["cluster/positions"][:]
    par = f["cluster/parent"][:]
    idx = list(f["cluster/index"][:])
    a = len(pos) - 1
    p = par[a]
    if p >= 0:
        pp = pos[idx.index(p)]
    else:  # the central seed
        pp = np.array([f["cluster"].attrs[n] for n in ("seed_x", "seed_y", "seed_z")[:pos.shape[1]]])
    u = (pos[a] - pp) / np.linalg.norm(pos[a] - pp)
    pos[a] = pos[a] + eps * u
    f["cluster/positions"][...] = pos


def forgeries(files, tmp):
    c = files["complete"]
    failed(forged(c, tmp, "contact", lambda f: last_stuck_moved(f, 1e-6)), "contact", "stuck moved 1e-6")

    def onto(f):
        p = f["free/positions"][:]
        p[0] = p[1]
        f["free/positions"][...] = p
    failed(forged(files["3d"], tmp, "onto", onto), "overlap", "free onto free")

    def wall(f):
        p = f["free/positions"][:]
        p[0, 0] = 0.25  # radius 0.5: half through the wall x = 0
        f["free/positions"][...] = p
    failed(forged(files["3d"], tmp, "wall", wall), "box", "free across a wall")

    def later(f):
        par = f["cluster/parent"][:]
        par[5] = f["cluster/index"][10]
        f["cluster/parent"][...] = par
    failed(forged(c, tmp, "later", later), "parent", "parent later")

    def order(f):
        t = f["cluster/arrival_time"][:]
        t[3], t[7] = t[7], t[3]
        f["cluster/arrival_time"][...] = t
    failed(forged(c, tmp, "order", order), "arrival", "arrival swapped")
    failed(forged(files["3d"], tmp, "stuck1", lambda f: f["results"].attrs.__setitem__(
        "stuck", np.uint64(f["results"].attrs["stuck"] + 1))), "counts", "/results stuck + 1")
    failed(forged(files["bath"], tmp, "ke", lambda f: f["results"].attrs.__setitem__(
        "kinetic_energy_free", f["results"].attrs["kinetic_energy_free"] * (1 + 1e-9))), "energy", "ke x (1 + 1e-9)")

    def radius(f):
        r = f["cluster/radii"][:]
        r[4] *= 1 + 1e-9
        f["cluster/radii"][...] = r
    failed(forged(files["seeds2"], tmp, "radius", radius), "species", "radius changed")


def setter(group, name, fn):
    def f(h):
        h[group].attrs[name] = fn(h[group].attrs[name])
    return f


def rows(ds, fn):
    def f(h):
        a = h[ds][:]
        fn(a)
        h[ds][...] = a
    return f


def more_forgeries(files, tmp):
    """The README's other claims: each fails its own check."""
    c, b = files["complete"], files["bath"]

    def dup(a):
        a[6] = a[5]
    cases = (
        (c, "seedx", setter("cluster", "seed_x", lambda v: v + 1e-9), "seeds"),
        (c, "side", setter("results", "box_side", lambda v: v * (1 + 1e-15)), "box"),
        (b, "mass", rows("species/mass", lambda a: a.__setitem__(1, a[1] * (1 + 1e-15))), "species"),
        (b, "bathstuck", rows("cluster/species", lambda a: a.__setitem__(0, 1)), "species"),
        (c, "dupindex", rows("cluster/index", dup), "index"),
        (b, "kestuck", setter("results", "kinetic_energy_stuck", lambda v: v * (1 + 1e-6)), "energy"),
        (b, "spstuck", rows("species/stuck", lambda a: a.__setitem__(0, a[0] - 1)), "counts"),
        (b, "serstuck", rows("series/stuck", lambda a: a.__setitem__(len(a) // 2, a[len(a) // 2] + 5)), "series"),
        (files["3d"], "lastrow", rows("series/time", lambda a: a.__setitem__(-1, a[-1] * (1 - 1e-12))), "series"),
    )
    p2, s2 = files["periodic2"], files["seeds2"]

    def past_side(a):
        a[0, 0] = -1e-3  # a periodic centre below 0

    def onto_big_seed(h):
        a = h["free/positions"][:]
        a[0] = h["cluster/seed_positions"][2] + [2.0, 0.0]  # seed 2 has radius 2.5: 0.5 + 2.5 apart at contact
        h["free/positions"][...] = a
    cases += (
        (p2, "periodic-out", rows("free/positions", past_side), "box"),
        (c, "seedr", setter("cluster", "seed_radius", lambda v: v * 2), "seeds"),
        (s2, "noseed", rows("cluster/parent", lambda a: a.__setitem__(3, -5)), "parent"),
        (c, "bigindex", rows("cluster/index", lambda a: a.__setitem__(3, 600)), "index"),
        (c, "kind7", rows("cluster/species", lambda a: a.__setitem__(3, 7)), "species"),
        (s2, "bigseed", onto_big_seed, "overlap"),
    )
    for src, name, fn, kind in cases:
        failed(forged(src, tmp, name, fn), kind, name)

    def f32(h):
        a = h["free/radii"][:]
        del h["free/radii"]
        h.create_dataset("free/radii", data=a.astype("f4"))

    def short(h):
        a = h["cluster/radii"][:]
        del h["cluster/radii"]
        h.create_dataset("cluster/radii", data=a[:-1])

    def long_series(h):
        for k in ("time", "kinetic_energy", "stuck", "collisions", "pressure"):
            a = h["series/" + k][:]
            del h["series/" + k]
            h.create_dataset("series/" + k, data=np.resize(a, 70000))
    def nine_kinds(h):
        for k in ("count", "radius", "density", "mass", "stuck", "sticky"):
            a = h["species/" + k][:]
            del h["species/" + k]
            h.create_dataset("species/" + k, data=np.resize(a, 9))
    for name, fn, want in (("f32", f32, "type"), ("short", short, "rows"), ("longseries", long_series, "65536"),
                           ("ninekinds", nine_kinds, "more than 8")):
        _, err = check_file(forged(b, tmp, name, fn), 1, (), name)
        T.check(want in err, "%s: %r" % (name, err))


def checkpoint_forgeries(ck, tmp):
    def moved(eps):
        def fn(f):
            dim = int(f.attrs["dim"])
            s = 2 * dim + 2
            ps = f["state/ps"][:]
            i = int(f["state/stuck_idx"][-1])
            p = int(f["state/parent"][i])
            xi, xp = ps[i * s:i * s + dim], ps[p * s:p * s + dim]
            ps[i * s:i * s + dim] = xi + eps * (xi - xp) / np.linalg.norm(xi - xp)
            f["state/ps"][...] = ps
        return fn
    failed(forged(ck, tmp, "ck-1e-7", moved(1e-7)), "contact", "checkpoint stuck moved 1e-7 (loader accepts)")
    _, err = check_file(forged(ck, tmp, "ck-1e-3", moved(1e-3)), 1, (), "checkpoint stuck moved 1e-3")
    T.check("checkpoint" in err and "parent" in err, "loader's line: %r" % err)


def peak_rss_mb(args):
    """Run args in a fresh python: (exit status, stderr, the child's peak RSS in MB)."""
    rc, err, kb = child_peak_rss(args, 60)
    return rc, err, kb / 1024


def hostile(files, tmp):
    def nan(f):
        p = f["free/positions"][:]
        p[2, 1] = float("nan")
        f["free/positions"][...] = p
    failed(forged(files["periodic2"], tmp, "nan", nan), "finite", "NaN position")

    for name, ds in (("arrival", "cluster/arrival_time"), ("freepos", "free/positions")):
        def huge(f, ds=ds):
            shape = f[ds].shape
            del f[ds]
            f.create_dataset(ds, shape=(2 ** 40,) + shape[1:], dtype="f8", chunks=(4096,) + shape[1:])
        path = forged(files["3d"], tmp, "huge-" + name, huge)
        t0 = time.time()
        rc, err, mb = peak_rss_mb([PDLA, "check", path])
        T.check(rc == 1 and err.count("\n") == 1 and ds in err and "stores" in err and mb < 100 and
                time.time() - t0 < 10, "%s of 2^40 rows: rc %d, %.0f MB, %r" % (ds, rc, mb, err))

    def nofree(f):
        del f["free"]
    _, err = check_file(forged(files["3d"], tmp, "nofree", nofree), 1, (), "no /free")
    T.check("free/" in err, "no /free: %r" % err)

    def crowd(f):
        p = f["free/positions"][:]
        p[:] = p[0]
        f["free/positions"][...] = p
    path = forged(files["bath"], tmp, "crowd", crowd)
    t0 = time.time()
    out, _ = check_file(path, 1, ("stopped      after 10000 failures",), "crowded")
    T.check(time.time() - t0 < 10, "crowded: %.1f s" % (time.time() - t0))

    dla = os.path.join(tmp, "dla")
    rc, _, err = run([PDLA, "--dim", "2", "--target", "300", "--seed", "1", "--out", dla, "-q"])
    if T.check(rc == 0, "dla run: %s" % err):
        out, _ = check_file(os.path.join(dla, "cluster.h5"), 0, ("R_g",), "a DLA file")
        T.check("model        event" not in out, "a DLA file taken for an event file")


def engine_faults(tmp):
    """Two faults of the engine that this check found, fixed in ev_core.c
    (pred_pp: ev_image, solve_far); each file failed before. 3D periodic,
    20 particles at packing 1e-4, seed 3: 4 cells a side, so a neighbour
    cell reaches exactly half the box; particle 17 crossed the periodic face
    at L/2 from the central seed, the pair was predicted with the receding
    image (no event) and never again: it passed 0.81 from the seed's centre,
    0.193 of a contact distance inside. 2D periodic, same, seed 4: a stuck
    particle 3.27e-7 of a contact distance inside its parent, 3000 times the
    engine's stated 1e-10 (a contact solved across a flight of ~1e4 box
    sides from an old stored state). Now both pass, every contact and
    overlap within 1e-10 of a contact distance."""
    for name, dim, seed in (("pass-through", "3", "3"), ("round-off", "2", "4"), ("pass-through-2", "3", "2"),
                            ("pass-through-6", "3", "6")):
        path = grow(tmp, name, ["--dim", dim, "--particles", "20", "--packing", "1e-4", "--box-walls", "periodic",
                                "--seed", seed])
        rc, out, err = run([PDLA, "check", "--json", path])
        try:
            j = json.loads(out)
        except ValueError:
            j = {}
        T.check(rc == 0, "engine fault %s: the file fails the check: rc %d %r" % (name, rc, err))
        off = max(float(j.get("worst_contact", 1)), float(j.get("worst_overlap", 1)))
        T.check(off < 1e-10, "engine fault %s: worst contact/overlap %r of a contact distance" % (name, off))


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-check-event-")
    t0 = time.time()
    try:
        files, ck = passing(tmp)
        forgeries(files, tmp)
        more_forgeries(files, tmp)
        checkpoint_forgeries(ck, tmp)
        hostile(files, tmp)
        engine_faults(tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("%.1f s" % (time.time() - t0))
    T.done()


main()
